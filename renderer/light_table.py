"""The light table's declaration: the kinds of light and the columns of `light_i` and `light_f`.

Its own module so that each kind's module (punctual.py, sun.py), which reads the columns, and
lights.py, the category that dispatches to every kind, can both import it without a circle.
lights.py describes the table; this module only declares it.
"""

from __future__ import annotations

from . import target
from .columns import Column, Layout

# Kinds of light (light_i.kind).
ENVIRONMENT_LIGHT = 0  # the image background, at infinity (environment.py)
AREA_LIGHT = 1  # an emitting shape placed by an instance (lights.py, sampled by its shape family)
POINT_LIGHT = 2  # a point, or a small sphere that no ray meets (punctual.py)
SPOT_LIGHT = 3  # a point sending light in a cone (punctual.py)
DIRECTIONAL_LIGHT = 4  # parallel light from one direction at infinity (punctual.py)
SUN_LIGHT = 5  # a disc at infinity of small angular size, met by rays that escape (sun.py)
KINDS = {ENVIRONMENT_LIGHT: "environment", AREA_LIGHT: "area", POINT_LIGHT: "point", SPOT_LIGHT: "spot",
         DIRECTIONAL_LIGHT: "directional", SUN_LIGHT: "sun"}

# How an area light's points are drawn (light_i.strategy).
BY_AREA = 0  # uniform on the surface
BY_CONE = 1  # a sphere under a similarity: uniform in the cone it subtends where that exists
BY_RECTANGLE = 2  # a rectangular quad under a similarity: uniform in the solid angle it subtends

LIGHT_I = Layout("light_i", "int32", [
    Column("kind", 1, "ENVIRONMENT_LIGHT (row 0 when present), AREA_LIGHT, POINT_LIGHT, SPOT_LIGHT, DIRECTIONAL_LIGHT or SUN_LIGHT"),
    Column("instance", 1, "area light: row of inst_i that places the light's tree"),
    Column("primitive", 1, "area light: row of prims_i of the emitting primitive"),
    Column("strategy", 1, "area light: BY_AREA, BY_CONE or BY_RECTANGLE"),
    Column("tree_leaf", 1, "with a light tree: the node of light_tree that holds this light; -1 for a light the tree does not choose"),
])
LIGHT_F = Layout("light_f", "float64", [
    Column("cdf", 1, "the map: choose; any other light: probability of choosing it or one before it among the lights after the map (the last row is 1)"),
    Column("pmf", 1, "the map: choose, its probability of being chosen; any other light: its share of those lights' power"),
    Column("area", 1, "area light: the shape's area in the tree's space"),
    Column("edge_u", 3, "area light: a quad's, triangle's, disk's or mesh triangle's first edge (a disk's first radius), in the tree's space"),
    Column("edge_v", 3, "area light: the second edge"),
    Column("corner", 3, "area light: a mesh triangle's first corner (other shapes read theirs from prims_f)"),
    Column("position", 3, "point and spot light: where it is (world)"),
    Column("direction", 3, "spot light: the unit direction of its axis; directional and sun light: the unit direction from the scene toward the light"),
    Column("radiance", 3, "point and spot light: intensity per solid angle (linear RGB); directional light: irradiance on a surface facing it; sun light: radiance of its disc"),
    Column("size", 1, "point light: the radius of the sphere it is sampled as (0: a point); sun light: the cosine of the disc's angular radius"),
    Column("cos_cutoff", 1, "spot light: cosine of the angle past which it sends nothing"),
    Column("cutoff", 1, "spot light: that angle, in radians"),
    Column("beam", 1, "spot light: the angle within which it sends its full intensity, in radians (the profile ramps linearly in angle from beam to cutoff)"),
    Column("power", 1, "the light's power as its choice weighs it (luminance of the flux it sends into the scene)"),
])
LIGHT_KIND, LIGHT_INSTANCE, LIGHT_PRIMITIVE, LIGHT_STRATEGY, LIGHT_TREE_LEAF = LIGHT_I.offsets(
    "kind", "instance", "primitive", "strategy", "tree_leaf")
LIGHT_CDF, LIGHT_PMF, LIGHT_AREA, LIGHT_EDGE_U, LIGHT_EDGE_V, LIGHT_CORNER = LIGHT_F.offsets(
    "cdf", "pmf", "area", "edge_u", "edge_v", "corner")
LIGHT_POSITION, LIGHT_DIRECTION, LIGHT_RADIANCE, LIGHT_SIZE, LIGHT_COS_CUTOFF, LIGHT_CUTOFF, LIGHT_BEAM, LIGHT_POWER = LIGHT_F.offsets(
    "position", "direction", "radiance", "size", "cos_cutoff", "cutoff", "beam", "power")


@target.device
def light_vector(S, light, column):
    """The three values of light row `light`'s 3-wide `column` of light_f (a position, a
    direction, a colour, an edge), as a tuple: every kind reads its vectors this way."""
    return (S.light_f[light, column], S.light_f[light, column + 1], S.light_f[light, column + 2])
