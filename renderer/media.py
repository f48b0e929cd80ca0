"""Media: their rows, their flattening, and free-flight sampling in the kernels.

A medium is a primitive of kind MEDIUM in the tree of the shape that bounds it, so a ray
meets it like a surface: its hit distance is drawn from the free-flight distribution, with a
random number keyed by (bounce, instance, medium) so the answer does not depend on the order
the tree is visited in. The boundary's rows (planar or spherical, as the shape's surface
would be) sit in a table of their own, `bnd_i` and `bnd_f`, outside every tree. The medium
scatters with its phase function, a material row (materials.phase_function: isotropic, or
Henyey-Greenstein's). A constant medium's free flight is drawn here in closed form; a medium
whose density varies (a grid, noise: its row's `field` column) is tracked through its field by
grid_media.py, behind the `varying_media` flag.
"""

import math


from . import target
from .columns import Column, Layout
from .grid_media import track
from .kernel_flags import VARYING_MEDIA
from .numerics.rng import DIM_MEDIUM, mix64, uniform
from .numerics.vec import dot, length, sub
from .shapes import INF, MEDIUM, MOVING_SPHERE, PRIM_WIDTH, SPHERE
from .shapes.planar import hit_planar
from .shapes.spheres import SPHERE_RADIUS, sphere_center
from .target import uint64

MEDIUM_F = Layout("prims_f medium", "float64", [
    Column("neg_inv_density", 1, "-1 / density: the mean free path, negated"),
    Column("first_boundary", 1, "first row of its boundary in bnd_i and bnd_f"),
    Column("boundaries", 1, "how many boundary rows"),
    Column("serial", 1, "the medium's number, independent of row order: keys its random numbers"),
    Column("field", 1, "0 for a constant density; else 1 + the bnd_f row of its density field's header "
                       "(grid_media.FIELD_F)"),
], PRIM_WIDTH)
MEDIUM_NEG_INV_DENSITY, MEDIUM_FIRST_BOUNDARY, MEDIUM_BOUNDARIES, MEDIUM_SERIAL, MEDIUM_FIELD = MEDIUM_F.offsets(
    "neg_inv_density", "first_boundary", "boundaries", "serial", "field")
# Mixed into a shadow ray's random numbers in a varying medium, so they differ from the free
# flight's of the same (bounce, instance, medium).
SHADOW_SALT = 0x9E3779B97F4A7C15


def medium_row(density: float, first_boundary: int, boundaries: int, serial: int, field: int = -1) -> tuple[int, list]:
    """(MEDIUM, row) of a medium bounded by boundary rows first_boundary onwards: of constant
    `density`, or (field >= 0) of the density field whose header is bnd_f row `field`, whose
    largest density `density` then is."""
    return MEDIUM, MEDIUM_F.row(neg_inv_density=-1.0 / density if density > 0.0 else 0.0,
                                first_boundary=first_boundary, boundaries=boundaries, serial=serial, field=field + 1)


# --- the kernels ------------------------------------------------------------------------------


@target.device
def medium_span(bnd_i, bnd_f, start, count, o, d, time):
    """(enter, leave) distances of the ray's whole line through a convex boundary; enter >= leave if it misses."""
    enter, leave = INF, -INF
    for b in range(start, start + count):
        kind = bnd_i[b]
        if kind == SPHERE or kind == MOVING_SPHERE:
            c = sphere_center(kind, bnd_f, b, time)
            r = bnd_f[b, SPHERE_RADIUS]
            f = sub(o, c)
            a = dot(d, d)
            half_b = dot(f, d)
            s = half_b / a
            lx, ly, lz = f[0] - s * d[0], f[1] - s * d[1], f[2] - s * d[2]
            disc = a * (r * r - (lx * lx + ly * ly + lz * lz))
            if disc <= 0.0:
                continue
            root = math.sqrt(disc)
            q = -half_b - math.copysign(root, half_b)
            t0, t1 = q / a, (dot(f, f) - r * r) / q if q != 0.0 else q / a
            enter = min(enter, min(t0, t1))
            leave = max(leave, max(t0, t1))
        else:
            t = hit_planar(kind, bnd_f, b, o, d, -INF, INF)
            if t < INF:
                enter = min(enter, t)
                leave = max(leave, t)
    return enter, leave


@target.device
def medium_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, tmax, time, key, bounce, inst):
    """Distance at which the ray scatters in medium `prim`, or inf if it passes through;
    `inst` is the instance's serial number."""
    # Keyed by serial numbers, not table rows: the BVH reorders rows, and must not change the image.
    medium = uint64(prims_f[prim, MEDIUM_SERIAL])
    dim = DIM_MEDIUM + mix64(uint64(bounce) * uint64(0x100000001B3) + uint64(inst) * uint64(0x2545F4914F6CDD1D) + medium)
    if VARYING_MEDIA and prims_f[prim, MEDIUM_FIELD] > 0.0:
        return varying_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, tmax, time, key, dim)
    u = uniform(key, dim)
    speed = length(d)
    # The free-flight distance -ln(1 - u) / density is at least u / density. When that already
    # reaches past where the ray can be inside the medium, it passes through, and neither the
    # boundary nor the logarithm is needed. The answer is the one they would give. Two bounds:
    # the ray's whole extent (tmin, tmax), known before the boundary is intersected (the
    # traversal tests media last, so tmax is then the nearest surface), and the part inside.
    reach = u * -prims_f[prim, MEDIUM_NEG_INV_DENSITY]
    if reach > (tmax - max(tmin, 0.0)) * speed:
        return INF
    start, count = int(prims_f[prim, MEDIUM_FIRST_BOUNDARY]), int(prims_f[prim, MEDIUM_BOUNDARIES])
    enter, leave = medium_span(bnd_i, bnd_f, start, count, o, d, time)
    t0, t1 = max(enter, tmin), min(leave, tmax)
    if not t0 < t1:
        return INF
    t0 = max(t0, 0.0)
    inside = (t1 - t0) * speed
    if reach > inside:
        return INF
    # -ln(1 - u) / density with u in [0, 1): finite, never log(0).
    distance = prims_f[prim, MEDIUM_NEG_INV_DENSITY] * math.log1p(-u)
    if distance > inside:
        return INF
    return t0 + distance / speed


@target.device
def varying_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, tmax, time, key, dim):
    """medium_hit for a medium whose density varies: delta tracking through its field over the
    part of (tmin, tmax) inside its boundary, with random numbers from dimension `dim` on."""
    start, count = int(prims_f[prim, MEDIUM_FIRST_BOUNDARY]), int(prims_f[prim, MEDIUM_BOUNDARIES])
    enter, leave = medium_span(bnd_i, bnd_f, start, count, o, d, time)
    t0, t1 = max(enter, tmin, 0.0), min(leave, tmax)
    if not t0 < t1:
        return INF
    t, _ = track(bnd_f, int(prims_f[prim, MEDIUM_FIELD]) - 1, o, d, t0, t1, length(d), key, dim, False)
    return t


@target.device
def varying_transmittance(prims_f, bnd_i, bnd_f, prim, o, d, tmax, time, key, bounce, inst):
    """An unbiased estimate of the transmittance of a medium whose density varies along o + t d
    for t in (0, tmax), by ratio tracking through its field; `inst` the instance's serial."""
    start, count = int(prims_f[prim, MEDIUM_FIRST_BOUNDARY]), int(prims_f[prim, MEDIUM_BOUNDARIES])
    enter, leave = medium_span(bnd_i, bnd_f, start, count, o, d, time)
    t0, t1 = max(enter, 0.0), min(leave, tmax)
    if not t0 < t1:
        return 1.0
    medium = uint64(prims_f[prim, MEDIUM_SERIAL])
    dim = DIM_MEDIUM + mix64((uint64(bounce) * uint64(0x100000001B3) + uint64(inst) * uint64(0x2545F4914F6CDD1D) + medium)
                             ^ uint64(SHADOW_SALT))
    _, tr = track(bnd_f, int(prims_f[prim, MEDIUM_FIELD]) - 1, o, d, t0, t1, length(d), key, dim, True)
    return tr
