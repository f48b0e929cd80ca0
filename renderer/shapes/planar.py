"""Planar shapes, quads, triangles and disks (and a box's six faces): rows, flattening, intersection.

Every planar row holds a corner (or centre) Q, the unit normal, the plane's offset, and two
vectors A = v x w and B = w x u with w = n / (n . n), n = u x v, so that the plane coordinates
of a point P are alpha = (P - Q) . A and beta = (P - Q) . B. A quad is 0 <= alpha, beta <= 1, a
triangle 0 <= alpha, beta and alpha + beta <= 1, a disk (u and v radius-long axes) alpha^2 +
beta^2 <= 1. Any affine map keeps such a shape planar, so transforms are always baked in.
"""

import math

from numba import njit

from scenefmt import affine

from ..columns import Column, Layout
from ..kernels.vec import dot, max_abs, row3, sub
from . import DISK, INF, PRIM_WIDTH, QUAD, TRIANGLE

# A ray this close to parallel with a plane misses it: the hit would be numerically meaningless.
PARALLEL_EPS = 1e-12

PLANAR_F = Layout("prims_f quad, triangle, disk", "float64", [
    Column("corner", 3, "Q: the corner at (alpha, beta) = (0, 0); a disk's centre"),
    Column("normal", 3, "unit normal u x v (flipped under a mirroring transform)"),
    Column("offset", 1, "the plane's offset D = normal . Q"),
    Column("alpha", 3, "A = v x w: alpha = (P - Q) . A"),
    Column("beta", 3, "B = w x u: beta = (P - Q) . B"),
], PRIM_WIDTH)
PLANAR_CORNER, PLANAR_NORMAL, PLANAR_OFFSET, PLANAR_ALPHA, PLANAR_BETA = PLANAR_F.offsets(
    "corner", "normal", "offset", "alpha", "beta")

_BOX_FACES = (
    # (corner selector, u axis, v axis) as in the book: all six u x v point outward.
    ((0, 0, 1), (1, 0, 0), (0, 1, 0)),  # front  z = max
    ((1, 0, 1), (0, 0, -1), (0, 1, 0)),  # right  x = max
    ((1, 0, 0), (-1, 0, 0), (0, 1, 0)),  # back   z = min
    ((0, 0, 0), (0, 0, 1), (0, 1, 0)),  # left   x = min
    ((0, 1, 1), (1, 0, 0), (0, 0, -1)),  # top    y = max
    ((0, 0, 0), (1, 0, 0), (0, 0, 1)),  # bottom y = min
)


def planar_row(q, u, v, flip: bool) -> list[float]:
    n = affine.cross(u, v)
    nn = affine.dot(n, n)
    length = math.sqrt(nn)
    unit = (n[0] / length, n[1] / length, n[2] / length)
    if flip:
        # A mirroring transform keeps the front face where it was geometrically.
        unit = (-unit[0], -unit[1], -unit[2])
    w = (n[0] / nn, n[1] / nn, n[2] / nn)
    # + 0.0: a plane through the origin gets offset +0, never -0.
    # alpha = w . (p x v) = p . (v x w); beta = w . (u x p) = p . (w x u)
    return PLANAR_F.row(corner=q, normal=unit, offset=affine.dot(unit, q) + 0.0,
                        alpha=affine.cross(v, w), beta=affine.cross(w, u))


def flatten(model, m) -> list[tuple[int, list, tuple, tuple]]:
    """(kind, row, lo, hi) of each planar row of a quad, triangle, disk or box model baked through m."""
    lin = affine.linear(m)
    flip = affine.determinant(lin) < 0
    out = []

    def add(kind, q, u, v, corners):
        q2, u2, v2 = affine.apply_point(m, q), affine.apply_linear(lin, u), affine.apply_linear(lin, v)
        pts = [tuple(q2[k] + a * u2[k] + b * v2[k] for k in range(3)) for a, b in corners]
        lo = tuple(min(p[k] for p in pts) for k in range(3))
        hi = tuple(max(p[k] for p in pts) for k in range(3))
        out.append((kind, planar_row(q2, u2, v2, flip), lo, hi))

    if model.type == "quad":
        add(QUAD, model.q, model.u, model.v, ((0, 0), (1, 0), (0, 1), (1, 1)))
    elif model.type == "triangle":
        p0, p1, p2 = (tuple(float(x) for x in p) for p in model.vertices)
        add(TRIANGLE, p0, affine.sub(p1, p0), affine.sub(p2, p0), ((0, 0), (1, 0), (0, 1)))
    elif model.type == "disk":
        n = affine.unit(tuple(float(x) for x in model.normal))
        helper = (1.0, 0.0, 0.0) if abs(n[0]) < 0.9 else (0.0, 1.0, 0.0)
        a = affine.unit(affine.cross(helper, n))
        b = affine.cross(n, a)  # a x b = n
        r = model.radius
        q2 = affine.apply_point(m, model.center)
        u2, v2 = affine.apply_linear(lin, affine.scale(a, r)), affine.apply_linear(lin, affine.scale(b, r))
        ext = tuple(math.sqrt(u2[k] * u2[k] + v2[k] * v2[k]) for k in range(3))
        out.append((DISK, planar_row(q2, u2, v2, flip), affine.sub(q2, ext), affine.add(q2, ext)))
    else:  # a box as its six faces
        lo, hi = tuple(float(x) for x in model.min), tuple(float(x) for x in model.max)
        size = affine.sub(hi, lo)
        for corner, u_axis, v_axis in _BOX_FACES:
            q = tuple(hi[k] if corner[k] > 0 else lo[k] for k in range(3))
            u = tuple(u_axis[k] * size[k] for k in range(3))
            v = tuple(v_axis[k] * size[k] for k in range(3))
            add(QUAD, q, u, v, ((0, 0), (1, 0), (0, 1), (1, 1)))
    return out


# --- the kernels ------------------------------------------------------------------------------


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def hit_planar(kind, data, i, o, d, tmin, tmax):
    nx, ny, nz = data[i, PLANAR_NORMAL], data[i, PLANAR_NORMAL + 1], data[i, PLANAR_NORMAL + 2]
    denom = nx * d[0] + ny * d[1] + nz * d[2]
    if abs(denom) <= PARALLEL_EPS * max_abs(d):
        return INF
    t = (data[i, PLANAR_OFFSET] - (nx * o[0] + ny * o[1] + nz * o[2])) / denom
    if not (tmin < t < tmax):
        return INF
    rx = o[0] + t * d[0] - data[i, PLANAR_CORNER]
    ry = o[1] + t * d[1] - data[i, PLANAR_CORNER + 1]
    rz = o[2] + t * d[2] - data[i, PLANAR_CORNER + 2]
    a, b = PLANAR_ALPHA, PLANAR_BETA
    alpha = rx * data[i, a] + ry * data[i, a + 1] + rz * data[i, a + 2]
    if kind == QUAD:
        if alpha < 0.0 or alpha > 1.0:
            return INF
        beta = rx * data[i, b] + ry * data[i, b + 1] + rz * data[i, b + 2]
        if beta < 0.0 or beta > 1.0:
            return INF
    elif kind == TRIANGLE:
        if alpha < 0.0:
            return INF
        beta = rx * data[i, b] + ry * data[i, b + 1] + rz * data[i, b + 2]
        if beta < 0.0 or alpha + beta > 1.0:
            return INF
    else:  # DISK
        beta = rx * data[i, b] + ry * data[i, b + 1] + rz * data[i, b + 2]
        if alpha * alpha + beta * beta > 1.0:
            return INF
    return t


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def planar_surface(kind, data, i, p):
    """Unit normal and (u, v) of a hit at p on planar row i."""
    n = row3(data, i, PLANAR_NORMAL)
    rel = sub(p, row3(data, i, PLANAR_CORNER))
    alpha = dot(rel, row3(data, i, PLANAR_ALPHA))
    beta = dot(rel, row3(data, i, PLANAR_BETA))
    if kind == DISK:
        return n, 0.5 * alpha + 0.5, 0.5 * beta + 0.5
    return n, alpha, beta
