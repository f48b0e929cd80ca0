"""Shapes: the primitive table, and one module per family with its rows, flattening and kernels.

Every primitive is a row of `prims_i` (`PRIMITIVE_I`: kind and material) and a row of
`prims_f`, PRIM_WIDTH doubles whose columns depend on the kind: `spheres.py` (SPHERE,
MOVING_SPHERE), `planar.py` (QUAD, TRIANGLE, DISK), `boxes.py` (BOX) and, for a medium's
volume, `renderer/media.py` (MEDIUM). A mesh's triangles (MESH_TRIANGLE) have `prims_i` rows but
no `prims_f` rows: their corners are in tables of their own (`meshes.py`). `dispatch.py` chooses among them by kind, in Python
when flattening and in the kernels when intersecting. Adding a shape means a model in
`scenefmt/shapes.py`, a type code here, a module with its layout, flattening and kernels, and
a case in `dispatch.py`.
"""

import math

from .. import target

from ..columns import Column, Layout

PRIM_WIDTH = 16

# Type codes of primitive rows.
SPHERE = 0
MOVING_SPHERE = 1
QUAD = 2
TRIANGLE = 3
DISK = 4
MEDIUM = 5
BOX = 6
MESH_TRIANGLE = 7

PRIMITIVE_I = Layout("prims_i", "int32", [
    Column("kind", 1, "type code: SPHERE, MOVING_SPHERE, QUAD, TRIANGLE, DISK, MEDIUM, BOX or MESH_TRIANGLE "
                      "(row P + k is mesh triangle k, P the number of prims_f rows)"),
    Column("material", 1, "material row (a medium's: its phase function)"),
])
PRIM_KIND, PRIM_MATERIAL = PRIMITIVE_I.offsets("kind", "material")

INF = math.inf


@target.device
def first_inside(t0, t1, tmin, tmax):
    """The first of the distances t0 <= t1 (where a ray enters and leaves a solid) in (tmin, tmax), or inf."""
    if tmin < t0 < tmax:
        return t0
    if tmin < t1 < tmax:
        return t1
    return INF
