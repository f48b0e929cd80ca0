"""Planar shapes, quads, triangles and disks (and a box's six faces): rows, flattening, intersection.

Every planar row holds a corner (or centre) Q, the unit normal, the plane's offset, and two
vectors A = v x w and B = w x u with w = n / (n . n), n = u x v, so that the plane coordinates
of a point P are alpha = (P - Q) . A and beta = (P - Q) . B. A quad is 0 <= alpha, beta <= 1, a
triangle 0 <= alpha, beta and alpha + beta <= 1, a disk (u and v radius-long axes) alpha^2 +
beta^2 <= 1. Any affine map keeps such a shape planar, so transforms are always baked in.

An emitting planar shape is sampled uniformly on its surface (`sample_planar_surface`, from the
edges u, v that `edges` recovers when flattening, density 1 / area); a rectangular quad near the
shading point also by the solid angle it subtends (`rectangle_frame`, `sample_rectangle`: the
spherical rectangle). lights.py chooses between the two.
"""

import math

import numpy as np
from .. import target

from scenefmt import affine

from ..columns import Column, Layout
from ..numerics.vec import cross, dot, madd, max_abs, neg, row3, scale, sub, unit
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


def planar_rows(model, m) -> list[tuple[int, list, tuple, tuple]]:
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


def edges(prims_f: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges u, v of planar rows, recovered from their (alpha, beta) dual vectors A and B:
    u is perpendicular to B and the normal with A . u = 1, v perpendicular to A and the normal
    with B . v = 1. (A disk's are its two radius vectors.)"""
    a = prims_f[rows, PLANAR_ALPHA:PLANAR_ALPHA + 3]
    b = prims_f[rows, PLANAR_BETA:PLANAR_BETA + 3]
    n = prims_f[rows, PLANAR_NORMAL:PLANAR_NORMAL + 3]
    u = np.cross(b, n)
    u /= np.einsum("ij,ij->i", u, a)[:, None]
    v = np.cross(n, a)
    v /= np.einsum("ij,ij->i", v, b)[:, None]
    return u, v


def area(kind: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Surface area of planar rows of kinds `kind` with edges u, v (`edges`)."""
    para = np.linalg.norm(np.cross(u, v), axis=1)
    out = np.zeros(len(kind))
    out[kind == QUAD] = para[kind == QUAD]
    out[kind == TRIANGLE] = 0.5 * para[kind == TRIANGLE]
    out[kind == DISK] = math.pi * para[kind == DISK]
    return out


def rectangular(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Whether edges u, v meet at a right angle (a quad with them is a rectangle), row by row."""
    return np.abs(np.einsum("ij,ij->i", u, v)) <= 1e-9 * np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)


# --- the kernels ------------------------------------------------------------------------------


@target.device
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


@target.device
def planar_surface(kind, data, i, p):
    """Unit normal and (u, v) of a hit at p on planar row i."""
    n = row3(data, i, PLANAR_NORMAL)
    rel = sub(p, row3(data, i, PLANAR_CORNER))
    alpha = dot(rel, row3(data, i, PLANAR_ALPHA))
    beta = dot(rel, row3(data, i, PLANAR_BETA))
    if kind == DISK:
        return n, 0.5 * alpha + 0.5, 0.5 * beta + 0.5
    return n, alpha, beta



@target.device
def planar_derivatives(kind, data, i):
    """dp/du and dp/dv of planar row i for the (u, v) `planar_surface` gives: a quad's or a
    triangle's edges u and v (u = alpha, v = beta), a disk's radius vectors doubled (u = alpha / 2
    + 1/2). The edges are recovered from the dual vectors A, B and the normal as `edges` does: u
    is perpendicular to B and the normal with A . u = 1, v perpendicular to A with B . v = 1."""
    n = row3(data, i, PLANAR_NORMAL)
    a = row3(data, i, PLANAR_ALPHA)
    b = row3(data, i, PLANAR_BETA)
    eu = cross(b, n)
    ev = cross(n, a)
    su, sv = dot(eu, a), dot(ev, b)
    # Never 0 for a row made by planar_row (A . u = 1 for its u); guarded all the same.
    eu = scale(eu, 1.0 / su) if su != 0.0 else (0.0, 0.0, 0.0)
    ev = scale(ev, 1.0 / sv) if sv != 0.0 else (0.0, 0.0, 0.0)
    if kind == DISK:
        return scale(eu, 2.0), scale(ev, 2.0)
    return eu, ev


# --- sampling ---------------------------------------------------------------------------------

# A rectangle subtending less than this solid angle is sampled by area: its spherical sampling
# would lose digits to the arc cosines, and area sampling is nearly uniform in angle there anyway.
SMALL_RECTANGLE = 1e-3
# Farther from its centre than this many times the sum of its edges' |x| + |y| + |z|, a rectangle
# is sampled by area too: the spherical rectangle's four arc cosines and dozen roots buy little there. On the
# Cornell box they were 45% of a sample's time and changed its error by under 2%, while sampling
# all by area, the ceiling beside the lamp included, had 1.4 times the variance.
FAR_RECTANGLE = 0.5


@target.device
def sample_planar_surface(kind, data, i, eu, ev, planar_area, u1, u2):
    """A point uniform on planar row i with edges eu, ev (`edges`), its normal and the density
    per area, 1 / `planar_area` (`area`)."""
    q = (data[i, PLANAR_CORNER], data[i, PLANAR_CORNER + 1], data[i, PLANAR_CORNER + 2])
    n = (data[i, PLANAR_NORMAL], data[i, PLANAR_NORMAL + 1], data[i, PLANAR_NORMAL + 2])
    if kind == TRIANGLE:
        su = math.sqrt(u1)
        a, b = 1.0 - su, u2 * su
    elif kind == DISK:
        rr = math.sqrt(u1)
        phi = 2.0 * math.pi * u2
        a, b = rr * math.cos(phi), rr * math.sin(phi)
    else:  # QUAD
        a, b = u1, u2
    return madd(madd(q, eu, a), ev, b), n, 1.0 / planar_area


@target.device
def rectangle_is_near(q, eu, ev, p):
    """Whether the rectangle (corner q, edges eu, ev) is near enough p to be sampled by the solid
    angle it subtends (FAR_RECTANGLE); the sampler and its density decide alike."""
    reach = 0.0
    dist2 = 0.0
    for k in range(3):
        a, b = eu[k], ev[k]
        c = q[k] + 0.5 * (a + b) - p[k]
        dist2 += c * c
        reach += abs(a) + abs(b)
    return dist2 < (FAR_RECTANGLE * reach) ** 2


@target.device
def rectangle_frame(q, eu, ev, p):
    """The rectangle (corner q, perpendicular edges eu, ev) as seen from p: its unit axes x, y, z
    (z pointing away from p's side), the coordinates x0 <= x1, y0 <= y1 and z0 <= 0 of its
    edges relative to p, the solid angle it subtends, and the terms the sampler needs."""
    lx, ly = math.sqrt(dot(eu, eu)), math.sqrt(dot(ev, ev))
    x, y = scale(eu, 1.0 / lx), scale(ev, 1.0 / ly)
    z = cross(x, y)
    rel = sub(q, p)
    z0 = dot(rel, z)
    if z0 > 0.0:
        z, z0 = neg(z), -z0
    x0, y0 = dot(rel, x), dot(rel, y)
    x1, y1 = x0 + lx, y0 + ly
    # The normals of the four planes through p and each edge, and the angles between them.
    n0 = unit(cross((x0, y0, z0), (x1, y0, z0)))
    n1 = unit(cross((x1, y0, z0), (x1, y1, z0)))
    n2 = unit(cross((x1, y1, z0), (x0, y1, z0)))
    n3 = unit(cross((x0, y1, z0), (x0, y0, z0)))
    g0 = math.acos(min(1.0, max(-1.0, -dot(n0, n1))))
    g1 = math.acos(min(1.0, max(-1.0, -dot(n1, n2))))
    g2 = math.acos(min(1.0, max(-1.0, -dot(n2, n3))))
    g3 = math.acos(min(1.0, max(-1.0, -dot(n3, n0))))
    k = 2.0 * math.pi - g2 - g3
    solid = g0 + g1 - k
    return x, y, z, x0, x1, y0, y1, z0, solid, k, n0[2], n2[2]


@target.device
def sample_rectangle(p, frame, u1, u2):
    """A point of the rectangle whose direction from p is uniform in the solid angle it subtends
    (the spherical rectangle of Urena, Fajardo and King, 2013): u1 picks the x at which a
    plane through p cuts off that share of the solid angle, u2 the height on that line."""
    x, y, z, x0, x1, y0, y1, z0, solid, k, b0, b1 = frame
    au = u1 * solid + k
    fu = (math.cos(au) * b0 - b1) / math.sin(au)
    cu = math.copysign(1.0, fu) / math.sqrt(fu * fu + b0 * b0)
    cu = min(1.0, max(-1.0, cu))
    xu = -(cu * z0) / math.sqrt(max(1e-300, 1.0 - cu * cu))
    xu = min(x1, max(x0, xu))
    d = math.sqrt(xu * xu + z0 * z0)
    h0 = y0 / math.sqrt(d * d + y0 * y0)
    h1 = y1 / math.sqrt(d * d + y1 * y1)
    hv = h0 + u2 * (h1 - h0)
    hv2 = hv * hv
    yv = (hv * d) / math.sqrt(1.0 - hv2) if hv2 < 1.0 - 1e-12 else y1
    yv = min(y1, max(y0, yv))
    return (p[0] + xu * x[0] + yv * y[0] + z0 * z[0], p[1] + xu * x[1] + yv * y[1] + z0 * z[1],
            p[2] + xu * x[2] + yv * y[2] + z0 * z[2])
