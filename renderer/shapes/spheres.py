"""Spheres and moving spheres: their rows, their flattening, their intersection and their sampling.

A sphere is baked into world space under any similarity (a rotation, a uniform scale, a
translation or a mirror); under any other transform it stays a unit-space sphere in a tree of
its own, placed by an instance (compile.py). A moving sphere's centre is a linear function of
time over the shutter interval.

An emitting sphere is sampled two ways (lights.py chooses): uniformly on its surface
(`sample_sphere_surface`, density 1 / area), or, seen from outside under a similarity, by a
direction uniform in the cone it subtends (`sample_cone`, density per solid angle
1 / `cone_solid_angle`).
"""

import math

import numpy as np
from .. import target

from scenefmt import affine

from ..columns import Column, Layout
from ..kernel_flags import MOTION
from ..numerics.vec import dot, madd, row3, scale, sub
from . import INF, MOVING_SPHERE, PRIM_WIDTH, SPHERE, first_inside

_RADIUS = Column("radius", 1, "radius")
SPHERE_F = Layout("prims_f sphere", "float64", [
    Column("center", 3, "centre"),
    _RADIUS,
    Column("rotation", 9, "object_from_world rotation, row-major: the frame of the (u, v) coordinates"),
], PRIM_WIDTH)
MOVING_SPHERE_F = Layout("prims_f moving_sphere", "float64", [
    Column("center", 3, "centre at time 0 (extrapolated from the shutter interval)"),
    _RADIUS,
    Column("velocity", 3, "centre's velocity per unit of time"),
    Column("rotation", 9, "as for a sphere"),
], PRIM_WIDTH)
SPHERE_F.shares(MOVING_SPHERE_F, "center", "radius")
SPHERE_CENTER, SPHERE_RADIUS, SPHERE_ROTATION = SPHERE_F.offsets("center", "radius", "rotation")
MOVING_VELOCITY, MOVING_ROTATION = MOVING_SPHERE_F.offsets("velocity", "rotation")


def sphere_row(model, m, lin, s, shutter_open: float, shutter_close: float):
    """(kind, row, lo, hi) of a sphere or moving sphere model baked through affine map m, whose
    linear part `lin` is s times a rotation; lo and hi bound it over the shutter interval."""
    # The object_from_world rotation for the uv frame, (lin / s) transposed, row by row.
    rot = [lin[j][i] / s for i in range(3) for j in range(3)]
    r = model.radius * s
    if model.type == "sphere":
        c = affine.apply_point(m, model.center)
        row = SPHERE_F.row(center=c, radius=r, rotation=rot)
        return SPHERE, row, affine.sub(c, (r, r, r)), affine.add(c, (r, r, r))
    c0, c1 = affine.apply_point(m, model.center0), affine.apply_point(m, model.center1)
    span = shutter_close - shutter_open
    vel = tuple((c1[k] - c0[k]) / span for k in range(3)) if span > 0 else (0.0, 0.0, 0.0)
    row = MOVING_SPHERE_F.row(center=affine.sub(c0, affine.scale(vel, shutter_open)), radius=r, velocity=vel, rotation=rot)
    if span == 0:
        c1 = c0
    lo = tuple(min(c0[k], c1[k]) - r for k in range(3))
    hi = tuple(max(c0[k], c1[k]) + r for k in range(3))
    return MOVING_SPHERE, row, lo, hi


def area(prims_f: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Surface area of sphere rows `rows` (a moving sphere's does not change with time)."""
    r = prims_f[rows, SPHERE_RADIUS]
    return 4.0 * math.pi * r * r


def sphere_run_rows(centers: np.ndarray, radii: np.ndarray, m, lin, s):
    """Rows, lo and hi of many plain spheres (no motion) baked through the same affine map m: the
    arrays `sphere_row` makes one sphere at a time, value for value (the same products and sums in the
    same order), built in numpy. `centers` is (n, 3), `radii` (n,)."""
    rows = np.zeros((len(radii), PRIM_WIDTH))
    # Apply m to the centres as affine.apply_point does: ((m0 p0 + m1 p1) + m2 p2) + m3, row by row.
    for k in range(3):
        mk = m[k]
        rows[:, SPHERE_CENTER + k] = centers[:, 0] * mk[0] + centers[:, 1] * mk[1] + centers[:, 2] * mk[2] + mk[3]
    r = radii * s
    rows[:, SPHERE_RADIUS] = r
    rows[:, SPHERE_ROTATION:SPHERE_ROTATION + 9] = [lin[j][i] / s for i in range(3) for j in range(3)]
    c = rows[:, SPHERE_CENTER:SPHERE_CENTER + 3]
    return rows, c - r[:, None], c + r[:, None]


# --- the kernels ------------------------------------------------------------------------------


@target.device
def sphere_center(kind, data, i, time):
    c = row3(data, i, SPHERE_CENTER)
    if MOTION and kind == MOVING_SPHERE:
        c = madd(c, row3(data, i, MOVING_VELOCITY), time)
    return c


@target.device
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


@target.device_noinline
def sphere_uv(n_obj):
    """(u, v) of a unit outward normal: u around +y starting at -x, v from the bottom pole."""
    y = min(1.0, max(-1.0, -n_obj[1]))
    theta = math.acos(y)
    phi = math.atan2(-n_obj[2], n_obj[0]) + math.pi
    return phi / (2.0 * math.pi), theta / math.pi


@target.device
def sphere_surface(kind, data, i, p, time, want_uv):
    """Hit point (moved onto the sphere), unit outward normal and (u, v) of a hit near p."""
    c = sphere_center(kind, data, i, time)
    r = data[i, SPHERE_RADIUS]
    rel = sub(p, c)
    dist = math.sqrt(dot(rel, rel))
    n = scale(rel, 1.0 / dist) if dist > 0.0 else (0.0, 1.0, 0.0)
    # Re-project the point onto the sphere: removes the error of o + t d.
    p = madd(c, n, r)
    if not want_uv:
        return p, n, 0.0, 0.0
    k = SPHERE_ROTATION if kind == SPHERE else MOVING_ROTATION
    n_obj = (
        data[i, k] * n[0] + data[i, k + 1] * n[1] + data[i, k + 2] * n[2],
        data[i, k + 3] * n[0] + data[i, k + 4] * n[1] + data[i, k + 5] * n[2],
        data[i, k + 6] * n[0] + data[i, k + 7] * n[1] + data[i, k + 8] * n[2],
    )
    u, v = sphere_uv(n_obj)
    return p, n, u, v



@target.device
def sphere_derivatives(kind, data, i, n):
    """dp/du and dp/dv (the tree's space) at the point of sphere row i whose unit outward normal
    is n, for the (u, v) of `sphere_uv`: u = phi / 2 pi around the object's +y, v = theta / pi
    from its bottom pole. With (x, y, z) the normal in the object's frame R n (R the row's
    object_from_world rotation), a point is c + r R^T (sin theta cos psi, -cos theta,
    -sin theta sin psi) with psi = 2 pi u - pi, theta = pi v, so

        dp/du = 2 pi r R^T (z, 0, -x),    dp/dv = pi r R^T (-x y / s, s, -y z / s),  s = sqrt(x^2 + z^2).

    dp/du x dp/dv points outward. At a pole (s = 0) u has no direction: both are (0, 0, 0), and
    a shading frame falls back to any frame there (numerics/frame.frame_of)."""
    r = data[i, SPHERE_RADIUS]
    k = SPHERE_ROTATION if kind == SPHERE else MOVING_ROTATION
    x = data[i, k] * n[0] + data[i, k + 1] * n[1] + data[i, k + 2] * n[2]
    y = data[i, k + 3] * n[0] + data[i, k + 4] * n[1] + data[i, k + 5] * n[2]
    z = data[i, k + 6] * n[0] + data[i, k + 7] * n[1] + data[i, k + 8] * n[2]
    s = math.sqrt(x * x + z * z)
    if s < 1e-12:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    au, bu, cu = 2.0 * math.pi * r * z, 0.0, -2.0 * math.pi * r * x
    av, bv, cv = -math.pi * r * x * y / s, math.pi * r * s, -math.pi * r * y * z / s
    # Back to the tree's space through R^T: column j of R is row j of R^T.
    dpdu = (data[i, k] * au + data[i, k + 3] * bu + data[i, k + 6] * cu,
            data[i, k + 1] * au + data[i, k + 4] * bu + data[i, k + 7] * cu,
            data[i, k + 2] * au + data[i, k + 5] * bu + data[i, k + 8] * cu)
    dpdv = (data[i, k] * av + data[i, k + 3] * bv + data[i, k + 6] * cv,
            data[i, k + 1] * av + data[i, k + 4] * bv + data[i, k + 7] * cv,
            data[i, k + 2] * av + data[i, k + 5] * bv + data[i, k + 8] * cv)
    return dpdu, dpdv


# --- sampling ---------------------------------------------------------------------------------

# Below this squared sine of the cone's half-angle, 1 - cos is computed from its series:
# the difference itself would have lost most of its digits.
SMALL_CONE = 1e-4


@target.device
def frame_of(w):
    """Two unit vectors completing unit w to an orthonormal frame (Duff et al. 2017)."""
    sign = math.copysign(1.0, w[2])
    a = -1.0 / (sign + w[2])
    b = w[0] * w[1] * a
    return (1.0 + sign * w[0] * w[0] * a, sign * b, -sign * w[0]), (b, sign + w[1] * w[1] * a, -w[1])


@target.device
def uniform_sphere(u1, u2):
    z = 1.0 - 2.0 * u1
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * u2
    return (r * math.cos(phi), r * math.sin(phi), z)


@target.device
def sample_sphere_surface(kind, data, i, sphere_area, time, u1, u2):
    """A point uniform on the surface of sphere row i at `time`, its outward normal and the
    density per area, 1 / `sphere_area` (the row's `area`, measured when flattening)."""
    c = sphere_center(kind, data, i, time)
    r = data[i, SPHERE_RADIUS]
    n = uniform_sphere(u1, u2)
    return madd(c, n, r), n, 1.0 / sphere_area


@target.device
def cone_one_minus_cos(sin2_max):
    """1 - cos(theta_max) of a cone whose half-angle has squared sine sin2_max, without cancellation."""
    if sin2_max < SMALL_CONE:
        return 0.5 * sin2_max + 0.125 * sin2_max * sin2_max
    return 1.0 - math.sqrt(max(0.0, 1.0 - sin2_max))


@target.device
def cone_from(p, c, r):
    """|p - c|^2, and whether p is outside the sphere (c, r) by enough for the cone it subtends
    to be sampled (from inside, or on it, only the surface can be)."""
    rel = sub(p, c)
    dist2 = dot(rel, rel)
    return dist2, dist2 > r * r * (1.0 + 1e-9)


@target.device
def cone_solid_angle(r, dist2):
    """The solid angle of the cone a sphere of radius r subtends from a point dist2 (squared)
    from its centre: `sample_cone`'s density is its inverse."""
    return 2.0 * math.pi * cone_one_minus_cos(r * r / dist2)


@target.device
def sample_cone(p, c, r, dist2, u1, u2):
    """A point and outward normal on the sphere (c, r) seen from p outside it, whose direction from
    p is uniform in the cone the sphere subtends; and that cone's solid angle density.

    The direction makes angle theta with the axis, cos theta uniform in [cos theta_max, 1]; the
    point is where it first meets the sphere, found from the angle alpha at the centre between
    the axis and the point (law of sines in the triangle p, c, point) rather than by intersecting
    a ray that may graze the sphere.
    """
    sin2_max = r * r / dist2
    one_minus = cone_one_minus_cos(sin2_max)
    # 1 - cos(theta) uniform in [0, 1 - cos(theta_max)], kept as a difference for small cones.
    om = u1 * one_minus
    cos_t = 1.0 - om
    sin2_t = om * (2.0 - om)
    sin_max = math.sqrt(sin2_max)
    cos_a = sin2_t / sin_max + cos_t * math.sqrt(max(0.0, 1.0 - sin2_t / sin2_max))
    cos_a = min(1.0, max(-1.0, cos_a))
    sin_a = math.sqrt(max(0.0, 1.0 - cos_a * cos_a))
    phi = 2.0 * math.pi * u2
    axis = scale(sub(p, c), 1.0 / math.sqrt(dist2))  # from the centre towards p
    e1, e2 = frame_of(axis)
    ca, sa = sin_a * math.cos(phi), sin_a * math.sin(phi)
    n = (ca * e1[0] + sa * e2[0] + cos_a * axis[0], ca * e1[1] + sa * e2[1] + cos_a * axis[1],
         ca * e1[2] + sa * e2[2] + cos_a * axis[2])
    return madd(c, n, r), n, 1.0 / (2.0 * math.pi * one_minus)
