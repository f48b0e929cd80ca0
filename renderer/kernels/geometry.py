"""Ray-primitive intersection (distance only) and the surface record of the closest hit."""

import math

from numba import njit

from ..config import SPAWN_OFFSET
from ..layout import BOX, DISK, MOVING_SPHERE, QUAD, SPHERE, TRIANGLE
from .features import MOTION
from .vec import dot, madd, max_abs, row3, scale, sub

INF = math.inf
# A ray this close to parallel with a plane misses it: the hit would be numerically meaningless.
PARALLEL_EPS = 1e-12


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def sphere_center(kind, data, i, time):
    c = row3(data, i, 0)
    if MOTION and kind == MOVING_SPHERE:
        c = madd(c, row3(data, i, 4), time)
    return c


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def first_inside(t0, t1, tmin, tmax):
    """The first of the distances t0 <= t1 (where a ray enters and leaves a solid) in (tmin, tmax), or inf."""
    if tmin < t0 < tmax:
        return t0
    if tmin < t1 < tmax:
        return t1
    return INF


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def hit_sphere(c, r, o, d, inv_a, tmin, tmax):
    """Nearest root in (tmin, tmax) of |o + t d - c| = r, or inf; `inv_a` is 1 / (d . d).

    The discriminant is formed from the distance between the centre and the ray's line (the
    perpendicular part of o - c) rather than as b^2 - ac, which loses every digit when the
    sphere is large or far away (Haines et al., Ray Tracing Gems, ch. 7). The caller divides
    by d . d once per ray: two of the three divisions of a test become products.
    """
    f = sub(o, c)
    a = dot(d, d)
    b = dot(f, d)
    # Perpendicular offset of the line from the centre, computed without cancellation.
    s = b * inv_a
    lx, ly, lz = f[0] - s * d[0], f[1] - s * d[1], f[2] - s * d[2]
    perp2 = lx * lx + ly * ly + lz * lz
    disc = a * (r * r - perp2)
    if disc < 0.0:
        return INF
    cc = dot(f, f) - r * r
    # q has the sign of -b so the two roots below never subtract nearly equal numbers.
    q = -b - math.copysign(math.sqrt(disc), b) if b != 0.0 else math.sqrt(disc)
    if q == 0.0:
        return INF
    t0 = cc / q
    t1 = q * inv_a
    return first_inside(min(t0, t1), max(t0, t1), tmin, tmax)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def hit_planar(kind, data, i, o, d, tmin, tmax):
    nx, ny, nz = data[i, 3], data[i, 4], data[i, 5]
    denom = nx * d[0] + ny * d[1] + nz * d[2]
    if abs(denom) <= PARALLEL_EPS * max_abs(d):
        return INF
    t = (data[i, 6] - (nx * o[0] + ny * o[1] + nz * o[2])) / denom
    if not (tmin < t < tmax):
        return INF
    rx = o[0] + t * d[0] - data[i, 0]
    ry = o[1] + t * d[1] - data[i, 1]
    rz = o[2] + t * d[2] - data[i, 2]
    alpha = rx * data[i, 7] + ry * data[i, 8] + rz * data[i, 9]
    if kind == QUAD:
        if alpha < 0.0 or alpha > 1.0:
            return INF
        beta = rx * data[i, 10] + ry * data[i, 11] + rz * data[i, 12]
        if beta < 0.0 or beta > 1.0:
            return INF
    elif kind == TRIANGLE:
        if alpha < 0.0:
            return INF
        beta = rx * data[i, 10] + ry * data[i, 11] + rz * data[i, 12]
        if beta < 0.0 or alpha + beta > 1.0:
            return INF
    else:  # DISK
        beta = rx * data[i, 10] + ry * data[i, 11] + rz * data[i, 12]
        if alpha * alpha + beta * beta > 1.0:
            return INF
    return t


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def hit_box(data, i, o, d, inv, tmin, tmax):
    """Distance in (tmin, tmax) to the surface of axis-aligned box i (lo 0:3, hi 3:6), or inf.

    `inv` is the ray's inverse direction. The ray enters at the largest of the three near plane
    distances and leaves at the smallest far one; from inside the box, the exit is the hit.
    Faces are closed, as a quad's edges are: a ray parallel to an axis is inside that slab when
    its origin lies between the two planes or on one of them, so a ray lying in a face meets
    the faces it crosses at their edges (docs/robustness.md).
    """
    near, far = -INF, INF
    for k in range(3):
        lo, hi = data[i, k], data[i, 3 + k]
        if d[k] == 0.0:
            if not lo <= o[k] <= hi:
                return INF
            continue
        t0 = (lo - o[k]) * inv[k]
        t1 = (hi - o[k]) * inv[k]
        near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    if not near <= far:
        return INF
    return first_inside(near, far, tmin, tmax)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def hit_primitive(kind, data, i, o, d, inv, inv_a, tmin, tmax, time):
    """Distance to primitive i of a surface kind along the ray, or inf; `inv` is the inverse
    direction (see hit_box) and `inv_a` is 1 / (d . d)."""
    if kind == SPHERE or kind == MOVING_SPHERE:
        return hit_sphere(sphere_center(kind, data, i, time), data[i, 3], o, d, inv_a, tmin, tmax)
    if kind == BOX:
        return hit_box(data, i, o, d, inv, tmin, tmax)
    return hit_planar(kind, data, i, o, d, tmin, tmax)


@njit(_nrt=False, cache=True, error_model="numpy")
def sphere_uv(n_obj):
    """(u, v) of a unit outward normal: u around +y starting at -x, v from the bottom pole."""
    y = min(1.0, max(-1.0, -n_obj[1]))
    theta = math.acos(y)
    phi = math.atan2(-n_obj[2], n_obj[0]) + math.pi
    return phi / (2.0 * math.pi), theta / math.pi


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def box_surface(data, i, p, d):
    """Hit point, outward unit normal and (0, 0) of a hit at p on box i, by a ray along d: the
    face nearest to p among those the ray is not parallel to (a ray lying in a face's plane
    meets the faces it crosses, see hit_box).

    The point is moved onto that face's plane, which removes the rounding of o + t d across
    it. A box row is only made for materials that do not read (u, v) (see layout.BOX).
    """
    best, axis, side = INF, 0, 0
    for k in range(3):
        if d[k] == 0.0:
            continue
        below = abs(p[k] - data[i, k])
        above = abs(data[i, 3 + k] - p[k])
        if below < best:
            best, axis, side = below, k, 0
        if above < best:
            best, axis, side = above, k, 1
    face = data[i, 3 * side + axis]
    sign = 1.0 if side == 1 else -1.0
    if axis == 0:
        return (face, p[1], p[2]), (sign, 0.0, 0.0), 0.0, 0.0
    if axis == 1:
        return (p[0], face, p[2]), (0.0, sign, 0.0), 0.0, 0.0
    return (p[0], p[1], face), (0.0, 0.0, sign), 0.0, 0.0


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def surface(kind, data, i, o, d, t, time, want_uv):
    """Hit point, unit outward normal and (u, v) of a hit at distance t.

    (u, v) is (0, 0) unless `want_uv`: only image textures read it, and on a sphere it costs
    an arc cosine and an arc tangent.
    """
    p = madd(o, d, t)
    if kind == SPHERE or kind == MOVING_SPHERE:
        c = sphere_center(kind, data, i, time)
        r = data[i, 3]
        rel = sub(p, c)
        dist = math.sqrt(dot(rel, rel))
        n = scale(rel, 1.0 / dist) if dist > 0.0 else (0.0, 1.0, 0.0)
        # Re-project the point onto the sphere: removes the error of o + t d.
        p = madd(c, n, r)
        if not want_uv:
            return p, n, 0.0, 0.0
        k = 4 if kind == SPHERE else 7
        n_obj = (
            data[i, k] * n[0] + data[i, k + 1] * n[1] + data[i, k + 2] * n[2],
            data[i, k + 3] * n[0] + data[i, k + 4] * n[1] + data[i, k + 5] * n[2],
            data[i, k + 6] * n[0] + data[i, k + 7] * n[1] + data[i, k + 8] * n[2],
        )
        u, v = sphere_uv(n_obj)
        return p, n, u, v
    if kind == BOX:
        return box_surface(data, i, p, d)
    n = row3(data, i, 3)
    rel = sub(p, row3(data, i, 0))
    alpha = dot(rel, row3(data, i, 7))
    beta = dot(rel, row3(data, i, 10))
    if kind == DISK:
        return p, n, 0.5 * alpha + 0.5, 0.5 * beta + 0.5
    return p, n, alpha, beta


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def spawn_origin(p, o, n, d):
    """Origin of a ray leaving hit point p (reached by a ray from o) in direction d.

    The renderer casts every ray with t_min = 0, so self-intersection is avoided here instead:
    p moves along the unit normal n, to the side d points to, by SPAWN_OFFSET times the
    magnitude of the coordinates involved. The rounding error of a hit point is a few ulps of
    that magnitude, so the margin is always far larger than the error and, being relative,
    looks the same at every scale (see docs/robustness.md).
    """
    eps = SPAWN_OFFSET * (max_abs(p) + max_abs(o))
    return madd(p, n, eps if dot(d, n) > 0.0 else -eps)
