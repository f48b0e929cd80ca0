"""Axis-aligned boxes as one primitive: their row, their flattening, and the slab test.

A box shape becomes one BOX row when its transform keeps it axis-aligned, it has thickness
in every axis and its material does not read (u, v); otherwise it is six quads (planar.py).
One slab test replaces six quad tests: as quads, the final scene's 400 ground boxes were 2400
rows, and a ray leaving a box top met about seven of them.

An emitting box is sampled uniformly on its surface (`sample_box_surface`); its area is
measured once, by `area` when flattening.
"""

import numpy as np
from .. import target

from scenefmt import affine

from ..columns import Column, Layout
from . import BOX, INF, PRIM_WIDTH, first_inside

BOX_F = Layout("prims_f box", "float64", [
    Column("lo", 3, "the corner of least coordinates, in the tree's space"),
    Column("hi", 3, "the corner of greatest coordinates"),
], PRIM_WIDTH)
BOX_LO, BOX_HI = BOX_F.offsets("lo", "hi")


def box_row(model, m):
    """(BOX, row, lo, hi) of a box model that affine map m keeps axis-aligned and not flat, else None."""
    if any(m[r][c] != 0.0 for r in range(3) for c in range(3) if r != c):
        return None
    a, b = affine.apply_point(m, model.min), affine.apply_point(m, model.max)
    lo = tuple(min(a[k], b[k]) for k in range(3))
    hi = tuple(max(a[k], b[k]) for k in range(3))
    if not all(hi[k] > lo[k] for k in range(3)):
        return None
    return BOX, BOX_F.row(lo=lo, hi=hi), lo, hi


def area(prims_f: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Surface area of box rows `rows`: twice the sum of their three faces'."""
    size = prims_f[rows, BOX_HI:BOX_HI + 3] - prims_f[rows, BOX_LO:BOX_LO + 3]
    return 2.0 * (size[:, 0] * size[:, 1] + size[:, 1] * size[:, 2] + size[:, 2] * size[:, 0])


# --- the kernels ------------------------------------------------------------------------------


@target.device
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
        lo, hi = data[i, BOX_LO + k], data[i, BOX_HI + k]
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


@target.device
def box_surface(data, i, p, d):
    """Hit point, outward unit normal and (0, 0) of a hit at p on box i, by a ray along d: the
    face nearest to p among those the ray is not parallel to (a ray lying in a face's plane
    meets the faces it crosses, see hit_box).

    The point is moved onto that face's plane, which removes the rounding of o + t d across
    it. A box row is only made for materials that do not read (u, v) (see `box_row`).
    """
    best, axis, side = INF, 0, 0
    for k in range(3):
        if d[k] == 0.0:
            continue
        below = abs(p[k] - data[i, BOX_LO + k])
        above = abs(data[i, BOX_HI + k] - p[k])
        if below < best:
            best, axis, side = below, k, 0
        if above < best:
            best, axis, side = above, k, 1
    face = data[i, (BOX_HI if side == 1 else BOX_LO) + axis]
    sign = 1.0 if side == 1 else -1.0
    if axis == 0:
        return (face, p[1], p[2]), (sign, 0.0, 0.0), 0.0, 0.0
    if axis == 1:
        return (p[0], face, p[2]), (0.0, sign, 0.0), 0.0, 0.0
    return (p[0], p[1], face), (0.0, 0.0, sign), 0.0, 0.0



@target.device
def box_derivatives():
    """dp/du and dp/dv of a BOX row: (0, 0, 0) both, as its (u, v) is the constant (0, 0). A box
    whose material reads (u, v) or a shading map is made of six quads instead (`box_row`'s
    caller), which have their edges."""
    return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)


@target.device
def sample_box_surface(data, i, box_area, u1, u2):
    """A point uniform on the surface of box row i, its outward normal and the density per
    area, 1 / `box_area` (`area`)."""
    lo = (data[i, BOX_LO], data[i, BOX_LO + 1], data[i, BOX_LO + 2])
    hi = (data[i, BOX_HI], data[i, BOX_HI + 1], data[i, BOX_HI + 2])
    sx, sy, sz = hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]
    faces = (sy * sz, sz * sx, sx * sy)  # the area of a face across x, y and z
    half = faces[0] + faces[1] + faces[2]
    # u1 chooses the face (by area) and is reused, rescaled, as the first coordinate on it.
    pick = u1 * 2.0 * half
    side = 0
    if pick >= half:
        pick -= half
        side = 1
    axis = 0
    while axis < 2 and pick >= faces[axis]:
        pick -= faces[axis]
        axis += 1
    s = min(pick / faces[axis], 1.0) if faces[axis] > 0.0 else 0.5
    sign = 1.0 if side == 1 else -1.0
    if axis == 0:
        x = (hi[0] if side == 1 else lo[0], lo[1] + s * sy, lo[2] + u2 * sz)
        n = (sign, 0.0, 0.0)
    elif axis == 1:
        x = (lo[0] + u2 * sx, hi[1] if side == 1 else lo[1], lo[2] + s * sz)
        n = (0.0, sign, 0.0)
    else:
        x = (lo[0] + s * sx, lo[1] + u2 * sy, hi[2] if side == 1 else lo[2])
        n = (0.0, 0.0, sign)
    return x, n, 1.0 / box_area
