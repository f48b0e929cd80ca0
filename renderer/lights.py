"""Lights: the category. Its table, its one selection step, and the two questions the integrator asks.

Every light is a row of `light_i` (its kind, `LIGHT_KIND`) and of `light_f` (declared in light_table.py):

- ENVIRONMENT_LIGHT, an image background (environment.py, the kind's module: its lookup and its
  sampler by brightness). At infinity: it gives directions, not points.
- AREA_LIGHT, an emitting shape: every primitive whose material `emits` (materials' interface), once per
  instance that places its tree (the row names the instance and the primitive). Its points come
  from its shape family (renderer/shapes/, through shapes/dispatch.py) in the tree's space and
  are carried into the world by the instance's map: a sphere seen from outside under a
  similarity by the cone it subtends, a rectangular quad near the shading point by the solid
  angle it subtends (FAR_RECTANGLE), anything else uniformly on its surface, whose density per
  world area is the tree-space density times the map's area ratio at that normal.
- POINT_LIGHT, SPOT_LIGHT, DIRECTIONAL_LIGHT (punctual.py) and SUN_LIGHT (sun.py): lights that are
  no shape, made from the scene's `lights:` and its sun. A kind is a model, a module with its
  flattening and its two kernels (a sample and its density), and one case in `sample_li`,
  `pdf_li` and `light_tables` below; the integrator does not change.

One selection step sees every light (`select_light`): one power distribution. The map, when
there is one that sends light, is row 0 and is chosen with probability `choose`, its share of
the power (`map_share`: clamped to [0.1, 0.9] beside other lights, so that neither starves when
the estimate is poor); every other row shares 1 - choose in proportion to its own power, by a
binary search of its cdf (`light_f.cdf`, over those rows only) with u0 rescaled to
(u0 - choose) / (1 - choose). A row's density therefore carries its choice as
`pdf x pmf x (1 - choose)` (pmf applied by the kind, the share by the category) and the map's as
`choose x pdf`, in that order: the images are those the two-step choice made before it was one.

The integrator asks two things, and never which kind answers:

- `sample_li(S, p, n, time, u0, u1, u2)`: a light chosen for shading point p with normal n
  ((0, 0, 0) in a medium), then a point on it (or a direction to it): (ok, point or direction,
  unit direction wi, distance to cast the shadow ray to (inf for a light at infinity), solid
  angle density including the choice, emitted radiance, whether the light is a delta).
- `pdf_li(S, light, p, n_p, x, n, time)`: the density `sample_li` from p gives light row `light`
  at point x with normal n (a direction x for a light at infinity), for the weight of a
  BSDF-sampled hit (`light_of_hit`). A ray that meets nothing asks `radiance_escaped`, which
  gives the background's radiance along it already weighted against every light at infinity
  that could have given its direction (`bsdf_weight`, the power heuristic).

A kind's sampler takes the pmf of its choice within its group from `select_light`: by power
from the cdf, or from a light tree that weighs lights as seen from p (`light_pmf` gives it again
for `pdf_li`).

With many lights (`scenefmt.many_lights.wants_light_tree`: at least LIGHT_TREE_THRESHOLD of them
with a place) `light_tables` also builds a light tree (light_tree.py) over the rows that have a
place and some power: area lights, points and spots. The lights at infinity (the map, parallel
light, the sun) stay outside it. The map keeps its share `choose`; among the rest, the tree is
one entry of the power distribution, with the power of all its lights (its root's `share`), and
each light outside it keeps its own power's share, so the cdf of `light_f` serves both: u0 finds
a row by it as without a tree; a row outside the tree is chosen with its pmf as before, a row in
the tree hands u0's place within its own interval (uniform in [0, 1) again) to the tree, which
walks from its root to a light by importance at p. Where every light of positive power is in the
tree (its share exactly 1), the cdf is not searched at all. A kernel compiled without the
`light_tree` path never reads the tree's tables: `light_f`'s cdf and pmf stay valid always.

Emission is two-sided (the books' diffuse light), so the conversion to solid angle takes the
absolute cosine at the light. A one-sided light (`sides: front`, the material interface's
`one_sided`) emits only along its shape's normal: `sample_area_light` draws its points as a
two-sided light's, with the same density (so `pdf_area_light` is unchanged), and refuses a point
whose front does not face p; its power is pi A L, half a two-sided light's.
"""

from __future__ import annotations

import math

import numpy as np
from scenefmt.many_lights import wants_light_tree

from . import target

from . import environment
from .background import BACKGROUND_IMAGE, BG_KIND, BG_SUN, background
from .environment import environment_radiance, sample_environment
from .kernel_flags import ENVIRONMENT, LIGHT_TREE, LIGHTS, MOTION, PUNCTUAL
from .light_table import (AREA_LIGHT, BY_AREA, BY_CONE, BY_RECTANGLE, DIRECTIONAL_LIGHT, ENVIRONMENT_LIGHT, KINDS, LIGHT_AREA,
                          LIGHT_BEAM, LIGHT_CDF, LIGHT_CORNER, LIGHT_COS_CUTOFF, LIGHT_CUTOFF, LIGHT_DIRECTION, LIGHT_EDGE_U,
                          LIGHT_EDGE_V, LIGHT_F, LIGHT_I, LIGHT_INSTANCE, LIGHT_KIND, LIGHT_PMF, LIGHT_POSITION, LIGHT_POWER,
                          LIGHT_PRIMITIVE, LIGHT_RADIANCE, LIGHT_SIZE, LIGHT_STRATEGY, LIGHT_TREE_LEAF, POINT_LIGHT, SPOT_LIGHT,
                          SUN_LIGHT, light_vector)
from .light_bounds import area_light_bounds, point_bounds, spot_bounds
from .light_tree import LT_LIGHT, LT_SHARE, LTREE_F, LTREE_I, LightBounds, ONE_MINUS_EPSILON, build_light_tree, tree_choose, tree_pmf
from .materials import MAT_READS_UV, emission_source, emitting_rows, one_sided, one_sided_rows
from .textures import texture_value
from .numerics.cdf import pmf_and_cdf, search_cdf
from .punctual import punctual_rows, sample_directional_light, sample_point_light, sample_spot_light
from .sun import pdf_sun_light, sample_sun_light, sun_along, sun_rows
from .numerics.vec import dot, madd, neg, scale, sub, unit, xform_normal, xform_point
from .shapes import MOVING_SPHERE, PRIM_KIND, PRIM_MATERIAL, QUAD, SPHERE
from .shapes.dispatch import sample_surface, sampler_normal, surface, surface_records
from .shapes.planar import PLANAR_CORNER, PLANAR_NORMAL, SMALL_RECTANGLE, rectangle_frame, rectangle_is_near, rectangular, sample_rectangle
from .shapes.spheres import SPHERE_RADIUS, cone_from, cone_solid_angle, sample_cone, sphere_center
from .trees import INST_FIRST_KEY, INST_KEYS, INST_OBJECT_FROM_WORLD, INST_ROOT, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT, tree_prims
from .motion import area_ratio_of, instance_maps, map_normal, map_point, moves, uniform_stretch

# What a light placed by an instance that does not move reads in place of a moving one's maps.
NO_MAPS = ((0.0,) * 12, (0.0,) * 12)

# The least and most share of light samples the map gets when other lights are present too.
MIN_CHOOSE = 0.1
MAX_CHOOSE = 0.9
# Lights met at less than this |cosine| are skipped: they send next to nothing, and the solid
# angle density would be huge and inexact.
GRAZING = 1e-10


# --- flattening -------------------------------------------------------------------------------


def no_lights(prims: int, instances: int) -> dict[str, np.ndarray]:
    """The light tables of a scene without lights."""
    return {"light_i": LIGHT_I.array(0), "light_f": LIGHT_F.array(0), "inst_light": np.zeros(instances, np.int32),
            "prim_light": np.full(prims, -1, np.int32), "ltree_f": LTREE_F.array(0), "ltree_i": LTREE_I.array(0)}


def light_tables(flat, env_power: float, graph=None, tree: bool | None = None) -> dict[str, np.ndarray]:
    """The light tables of flat scene `flat` (made from `graph`), whose environment map (if any)
    sends the radiance `env_power` integrated over the sphere (environment.environment_tables's):
    `light_i`, `light_f`, `inst_light` (each instance's first area light row), `prim_light` (an
    emitting primitive's rank among the emitters of its tree, -1 for others): the light of a hit
    is inst_light + prim_light (`light_of_hit`); and the light tree's tables, empty where the
    scene has too few lights for a tree to pay.

    Rows: the map (when it sends light), the area lights, then the lights that are no shape (each
    kind's module makes its rows from the graph, with their `power`). Without those the area
    lights' cdf is the one their measured power gives, as it always was.

    `tree` forces the light tree on or off (None: where `graph` has enough lights for it to
    pay, scenefmt.many_lights.wants_light_tree, which also switches on the kernels' path)."""
    tables, area_power = _area_lights(flat)
    # The rows of the lights that are no shape: (light_i, light_f) pairs, each kind's own.
    extra: list[tuple[np.ndarray, np.ndarray]] = []
    extra.append(punctual_rows(graph, flat))  # point, spot and directional lights
    extra.append(sun_rows(graph, flat))  # a sun_sky background's sun
    extra = [pair for pair in extra if len(pair[0])]
    other_flux = 0.0
    if extra:
        tables["light_i"] = np.concatenate([tables["light_i"]] + [i for i, _ in extra])
        tables["light_f"] = np.concatenate([tables["light_f"]] + [f for _, f in extra])
        other_flux = float(sum(f[:, LIGHT_POWER].sum() for _, f in extra))
        power = tables["light_f"][:, LIGHT_POWER]
        total = float(power.sum())
        if total > 0.0:
            tables["light_f"][:, LIGHT_PMF], tables["light_f"][:, LIGHT_CDF] = pmf_and_cdf(power, total)
    choose = map_share(flat, env_power, area_power, other_flux)
    if choose > 0.0:
        # The map heads the table: the other rows (and their cdf) follow it unchanged.
        tables["light_i"] = np.concatenate([LIGHT_I.array(1, kind=ENVIRONMENT_LIGHT, instance=-1, primitive=-1, tree_leaf=-1), tables["light_i"]])
        tables["light_f"] = np.concatenate([LIGHT_F.array(1, cdf=choose, pmf=choose), tables["light_f"]])
        tables["inst_light"] = tables["inst_light"] + np.int32(1)
    # A light tree over the rows, where there are enough of them for one to pay (the rows keep
    # their order: the sun's is named below).
    if tree is None:
        tree = graph is not None and wants_light_tree(graph)
    if tree:
        tables.update(light_tree_tables(flat._replace(**{k: v for k, v in tables.items() if k in flat._fields})))
    return _place_sun(flat, tables)


def _place_sun(flat, tables: dict) -> dict:
    """The light tables with the sun's row (sun.py) named in the background row, where rays that
    escape look it up (`radiance_escaped`): once the rows are in their final order."""
    rows = np.flatnonzero(tables["light_i"][:, LIGHT_KIND] == SUN_LIGHT)
    if len(rows) and len(flat.background) > BG_SUN:
        background_row = np.array(flat.background, np.float64)
        background_row[BG_SUN] = float(rows[0])
        tables["background"] = background_row
    return tables


def light_tree_tables(flat) -> dict[str, np.ndarray]:
    """The light tree over the lights of `flat` that have a place and some power: `ltree_f`,
    `ltree_i` (empty where there is none) and `light_i` with each such row's `tree_leaf` set (a
    copy; -1 for the rest). The root's share is the share of the power of the lights after the
    map that the tree holds: exactly 1 where none outside it has any."""
    light_i, light_f = flat.light_i.copy(), flat.light_f
    light_i[:, LIGHT_TREE_LEAF] = -1
    kind = light_i[:, LIGHT_KIND]
    power = light_f[:, LIGHT_POWER]
    area = np.flatnonzero((kind == AREA_LIGHT) & (power > 0.0))
    parts = []
    if len(area):
        parts.append(area_light_bounds(flat, light_i[area, LIGHT_INSTANCE], light_i[area, LIGHT_PRIMITIVE],
                                       light_f[area, LIGHT_EDGE_U:LIGHT_EDGE_U + 3], light_f[area, LIGHT_EDGE_V:LIGHT_EDGE_V + 3],
                                       light_f[area, LIGHT_CORNER:LIGHT_CORNER + 3], power[area], front_only(flat, area)))
    points = np.flatnonzero((kind == POINT_LIGHT) & (power > 0.0))
    if len(points):
        parts.append(point_bounds(light_f[points, LIGHT_POSITION:LIGHT_POSITION + 3], light_f[points, LIGHT_SIZE], power[points]))
    spots = np.flatnonzero((kind == SPOT_LIGHT) & (power > 0.0))
    if len(spots):
        parts.append(spot_bounds(light_f[spots, LIGHT_POSITION:LIGHT_POSITION + 3], light_f[spots, LIGHT_DIRECTION:LIGHT_DIRECTION + 3],
                                 light_f[spots, LIGHT_BEAM], light_f[spots, LIGHT_CUTOFF], power[spots]))
    rows = np.concatenate([area, points, spots])
    if not len(rows):
        return {"ltree_f": LTREE_F.array(0), "ltree_i": LTREE_I.array(0), "light_i": light_i}
    ltree_f, ltree_i, leaf_of = build_light_tree(LightBounds.join(parts))
    leaf = ltree_i[:, LT_LIGHT] >= 0
    ltree_i[leaf, LT_LIGHT] = rows[ltree_i[leaf, LT_LIGHT]]
    light_i[rows, LIGHT_TREE_LEAF] = leaf_of
    outside = np.ones(len(light_i), np.bool_)
    outside[rows] = False
    outside &= (kind != ENVIRONMENT_LIGHT) & (light_f[:, LIGHT_PMF] > 0.0)
    ltree_f[0, LT_SHARE] = min(1.0, max(0.0, 1.0 - float(light_f[outside, LIGHT_PMF].sum()))) if outside.any() else 1.0
    return {"ltree_f": ltree_f, "ltree_i": ltree_i, "light_i": light_i}


def front_only(flat, rows: np.ndarray) -> np.ndarray:
    """Whether each area light row of `rows` (of flat.light_i) emits from its front only (its
    tree bound is then the cone of its normal, not both sides of it): the material's `sides: front`."""
    prim = flat.light_i[rows, LIGHT_PRIMITIVE]
    return one_sided_rows(flat.mat_i)[flat.prims_i[prim, PRIM_MATERIAL]]


def map_share(flat, env_power: float, area_power: float, other_flux: float = 0.0) -> float:
    """choose: the probability that a light sample goes to the map, whose radiance integrated
    over the sphere is `env_power`, beside area lights of total power `area_power` (their world
    area times radiance, halved for a one-sided light) and other lights of total flux
    `other_flux`. The map sends a scene of bounding radius R the flux pi R^2 env_power
    (environment.flux), a two-sided area light 2 pi A L, a one-sided one pi A L. A map that
    sends nothing is never sampled (0); a map alone is always (1)."""
    if not env_power > 0.0:
        return 0.0
    if not area_power + other_flux > 0.0:
        return 1.0
    area = 2.0 * math.pi * area_power + other_flux
    env = environment.flux(flat, env_power)
    share = env / (env + area) if math.isfinite(env + area) and env + area > 0.0 else 0.5
    return min(MAX_CHOOSE, max(MIN_CHOOSE, share))


def _area_lights(flat) -> tuple[dict[str, np.ndarray], float]:
    """The area light rows of `flat`, chosen among themselves by power, and their total power.
    Power-proportional choice needs the mean emission, which `_powers` measures with the
    kernels' own sampling."""
    # The materials that emit, as the material interface answers (`emits`): no kind is named here.
    emits = np.zeros(len(flat.mat_i), np.bool_)
    emitting_rows(flat.mat_i, emits)
    emitting = emits[flat.prims_i[:, PRIM_MATERIAL]]
    if not emitting.any():
        return no_lights(len(flat.prims_i), len(flat.inst_i)), 0.0
    inst_light = np.zeros(len(flat.inst_i), np.int32)
    prim_light = np.full(len(flat.prims_i), -1, np.int32)
    instances, prims = [], []
    rows = 0
    emitters_of_root: dict[int, np.ndarray] = {}
    for k, root in enumerate(flat.inst_i[:, INST_ROOT]):
        if root not in emitters_of_root:
            # A tree's rows: one run of surfaces and, with a mesh, one of its triangles.
            in_tree = tree_prims(flat.nodes_i, root)
            emitters_of_root[root] = in_tree[emitting[in_tree]]
            prim_light[emitters_of_root[root]] = np.arange(len(emitters_of_root[root]))
        found = emitters_of_root[root]
        inst_light[k] = rows
        prims.append(found)
        instances.append(np.full(len(found), k, np.int64))
        rows += len(found)
    prim = np.concatenate(prims) if prims else np.zeros(0, np.int64)
    inst = np.concatenate(instances) if instances else np.zeros(0, np.int64)
    kind = flat.prims_i[prim, PRIM_KIND]
    lin = flat.inst_f[inst, INST_WORLD_FROM_OBJECT:INST_WORLD_FROM_OBJECT + 12].reshape(-1, 3, 4)[:, :, :3]
    gram = np.einsum("kij,kil->kjl", lin, lin)
    scale2 = np.trace(gram, axis1=1, axis2=2) / 3.0
    similar = np.all(np.abs(gram - scale2[:, None, None] * np.eye(3)) <= 1e-9 * scale2[:, None, None], axis=(1, 2))
    # On a moving instance a light keeps its cone or rectangle only if every map of its motion is
    # a similarity, as the one at the shutter's opening (inst_f) is: every keyframe's stretch a
    # uniform scale (then the stretches between them are too).
    moving = np.flatnonzero(flat.inst_i[:, INST_KEYS] > 0)
    if len(moving):
        still_similar = np.ones(len(flat.inst_i), np.bool_)
        for k in moving:
            first = flat.inst_i[k, INST_FIRST_KEY]
            still_similar[k] = uniform_stretch(flat.motion_f[first:first + flat.inst_i[k, INST_KEYS]])
        similar &= still_similar[inst]
    area, u, v, corner = surface_records(kind, prim, flat)
    cone = ((kind == SPHERE) | (kind == MOVING_SPHERE)) & similar
    rectangle = (kind == QUAD) & rectangular(u, v) & similar
    strategy = np.where(cone, BY_CONE, np.where(rectangle, BY_RECTANGLE, BY_AREA))
    light_i = LIGHT_I.array(len(prim), kind=AREA_LIGHT, instance=inst, primitive=prim, strategy=strategy, tree_leaf=-1)
    light_f = LIGHT_F.array(len(prim), area=area, edge_u=u, edge_v=v, corner=corner)
    power = _powers(flat, light_i, light_f)
    front_only = one_sided_rows(flat.mat_i)[flat.prims_i[prim, PRIM_MATERIAL]]
    if front_only.any():
        # A one-sided light sends pi A L, half what a two-sided one of the same A L sends: its
        # choice and its share beside the map are weighed by that. (Only where there is one, so
        # the books' lights keep their cdf bit for bit.)
        power = np.where(front_only, 0.5 * power, power)
    total = float(power.sum())
    if not total > 0.0:  # no light sends anything: nothing to sample
        return no_lights(len(flat.prims_i), len(flat.inst_i)), 0.0
    # The flux each sends (two-sided: 2 pi A L; one-sided: pi A L, halved above), as the other
    # kinds state theirs; the choice among area lights alone keeps the cdf of `power`, as it
    # always did.
    light_f[:, LIGHT_POWER] = 2.0 * math.pi * power
    light_f[:, LIGHT_PMF], light_f[:, LIGHT_CDF] = pmf_and_cdf(power, total)
    return {"light_i": light_i, "light_f": light_f, "inst_light": inst_light, "prim_light": prim_light}, total


def _powers(flat, light_i: np.ndarray, light_f: np.ndarray) -> np.ndarray:
    """Each light's power up to a common factor: its world area times the luminance of its
    emission averaged over 16 stratified points of its surface."""
    out = np.zeros(len(light_i))
    light_powers(flat._replace(light_i=light_i, light_f=light_f), out)
    return out


# --- the kernels: selection and the integrator's two questions --------------------------------


@target.device
def lights_to_sample(S):
    """Whether the scene has a light that `sample_li` can draw (a kernel compiled without light
    sampling and without an environment map has none: its code for them is left out)."""
    return (LIGHTS or ENVIRONMENT or PUNCTUAL) and S.light_i.shape[0] > 0


@target.device
def map_choice(S):
    """choose: the probability of row 0 when the map heads the table, else 0."""
    if ENVIRONMENT and S.light_i.shape[0] > 0 and S.light_i[0, LIGHT_KIND] == ENVIRONMENT_LIGHT:
        return S.light_f[0, LIGHT_PMF]
    return 0.0


@target.device
def select_light(S, p, n, u0):
    """The one light-selection step, for shading point p with unit normal n ((0, 0, 0) in a
    medium): (the light row u0 chooses, -1 for none; the share of its group: choose for the
    map, 1 - choose for the rest; and its pmf within that group, which its kind's sampler
    multiplies into its density: 1 for the map). The rest are chosen by power from their cdf
    (p and n unused); a kernel with a light tree asks the tree, which weighs them as seen from p."""
    choose = map_choice(S)
    # (choose > 0 first: in a kernel without maps choose is the constant 0, and this folds away.)
    if choose > 0.0 and u0 < choose:
        return 0, choose, 1.0
    first = 1 if choose > 0.0 else 0
    count = S.light_i.shape[0] - first
    if count <= 0:
        return -1, 0.0, 0.0
    # u0 rescaled to choose among the rest: exactly u0 when there is no map.
    u = (u0 - choose) / (1.0 - choose)
    if LIGHT_TREE and S.ltree_i.shape[0] > 0:
        light, pmf = select_with_tree(S, first, count, p, n, u)
        return light, 1.0 - choose, pmf
    light = search_cdf(S.light_f, LIGHT_CDF, first, count, u)
    return light, 1.0 - choose, S.light_f[light, LIGHT_PMF]


@target.device
def select_with_tree(S, first, count, p, n, u):
    """A light among rows first.. (all but the map) for shading point p with normal n, by u in
    [0, 1), and its pmf among them: by the cdf for the lights outside the tree, by the tree's
    walk (with the tree's share) for those in it (see the module's docstring)."""
    share = S.ltree_f[0, LT_SHARE]
    if share < 1.0:
        light = search_cdf(S.light_f, LIGHT_CDF, first, count, u)
        if S.light_i[light, LIGHT_TREE_LEAF] < 0:
            return light, S.light_f[light, LIGHT_PMF]
        # u's place within the row's interval of the cdf: uniform in [0, 1) again.
        lo = S.light_f[light - 1, LIGHT_CDF] if light > first else 0.0
        width = S.light_f[light, LIGHT_CDF] - lo
        u = min(max((u - lo) / width, 0.0), ONE_MINUS_EPSILON) if width > 0.0 else 0.0
    light, pmf = tree_choose(S.ltree_f, S.ltree_i, p, n, u)
    return light, share * pmf


@target.device
def light_pmf(S, light, p, n):
    """The pmf `select_light` gives light row `light` within its group from shading point p with
    normal n (1 for the map)."""
    if light == 0 and map_choice(S) > 0.0:
        return 1.0
    if LIGHT_TREE and S.ltree_i.shape[0] > 0:
        leaf = S.light_i[light, LIGHT_TREE_LEAF]
        if leaf >= 0:
            return S.ltree_f[0, LT_SHARE] * tree_pmf(S.ltree_f, S.ltree_i, leaf, p, n)
    return S.light_f[light, LIGHT_PMF]


@target.device
def share_of(S, light):
    """The share of light row `light`'s group, as `select_light` gives it."""
    choose = map_choice(S)
    if light == 0 and choose > 0.0:
        return choose
    return 1.0 - choose


@target.device
def sample_li(S, p, n, time, u0, u1, u2):
    """A light sample for shading point p (world) with unit normal n ((0, 0, 0) in a medium:
    only a light tree reads it): (ok, point on the light or, for a light at
    infinity, the direction to it; unit direction wi from p; the distance to the point, inf for
    a light at infinity; solid angle density including the choice of light; emitted radiance).
    u0 chooses the light (`select_light`), u1 and u2 the point on it. Not ok when nothing is
    drawn (a light met edge-on, at p itself, or a map's pole). A seventh value says whether the
    light is a delta (a point, a spot, parallel light): no BSDF-sampled ray can meet it, so its
    sample takes no MIS weight, and its "density" is only the probability of its choice."""
    zero = (0.0, 0.0, 0.0)
    light, share, pmf = select_light(S, p, n, u0)
    if light >= 0:
        kind = S.light_i[light, LIGHT_KIND]
        if ENVIRONMENT and kind == ENVIRONMENT_LIGHT:
            ok, wi, pdf, le = sample_environment(S.background, S.env_rgb, S.env_row_f, S.env_texel_f, u1, u2)
            return ok, wi, wi, math.inf, pdf * share, le, False
        if LIGHTS and kind == AREA_LIGHT:
            ok, x, wi, dist, pdf, le = sample_area_light(S, light, pmf, p, time, u1, u2)
            return ok, x, wi, dist, pdf * share, le, False
        # Deltas (punctual.py): their density is the probability of their choice, and no MIS weight.
        if PUNCTUAL and kind == POINT_LIGHT:
            ok, x, wi, dist, pdf, le = sample_point_light(S, light, pmf, p, time, u1, u2)
            return ok, x, wi, dist, pdf * share, le, True
        if PUNCTUAL and kind == SPOT_LIGHT:
            ok, x, wi, dist, pdf, le = sample_spot_light(S, light, pmf, p, time, u1, u2)
            return ok, x, wi, dist, pdf * share, le, True
        if PUNCTUAL and kind == DIRECTIONAL_LIGHT:
            ok, x, wi, dist, pdf, le = sample_directional_light(S, light, pmf, p, time, u1, u2)
            return ok, x, wi, dist, pdf * share, le, True
        # The sun (sun.py): a disc that BSDF-sampled rays meet too, so no delta.
        if PUNCTUAL and kind == SUN_LIGHT:
            ok, x, wi, dist, pdf, le = sample_sun_light(S, light, pmf, p, time, u1, u2)
            return ok, x, wi, dist, pdf * share, le, False
    return False, p, zero, 0.0, 0.0, zero, False


@target.device
def pdf_li(S, light, p, n_p, x, n, time):
    """The density, per solid angle at p and including the choice of light, with which
    `sample_li` from shading point p (normal n_p, as sample_li took it) gives light row `light`
    at point x with normal n (for a light at infinity, x is the direction); 0 for row -1 (no
    light that is sampled)."""
    if light < 0:
        return 0.0
    kind = S.light_i[light, LIGHT_KIND]
    if ENVIRONMENT and kind == ENVIRONMENT_LIGHT:
        _, pdf = environment_radiance(S.background, S.env_rgb, S.env_texel_f, x)
        return share_of(S, light) * pdf
    if LIGHTS and kind == AREA_LIGHT:
        return pdf_area_light(S, light, light_pmf(S, light, p, n_p), p, x, n, time) * share_of(S, light)
    if PUNCTUAL and kind == SUN_LIGHT:
        # A ray that escapes within the disc meets it.
        return pdf_sun_light(S, light, light_pmf(S, light, p, n_p), p, x, n, time) * share_of(S, light)
    # POINT_LIGHT, SPOT_LIGHT: no BSDF-sampled ray meets a point; DIRECTIONAL_LIGHT: nor a direction.
    return 0.0


@target.device
def light_of_hit(S, inst, prim):
    """The light row of a hit on primitive `prim` placed by instance `inst`: -1 where it does
    not emit, or emits nothing and is never sampled."""
    if S.prim_light[prim] < 0:
        return -1
    return S.inst_light[inst] + S.prim_light[prim]


@target.device
def bsdf_weight(bsdf_pdf, light_pdf):
    """The power heuristic's weight of a BSDF-sampled hit on a light, beside the light sampler's
    density for the same point or direction."""
    return 1.0 / (1.0 + (light_pdf / bsdf_pdf) ** 2)


@target.device
def radiance_escaped(S, p, n_p, d, prev_pdf):
    """What a ray from p (whose vertex had normal n_p) along d that meets nothing brings back:
    the background's radiance, weighted against the light sampler where a light at infinity
    could have given d too and the ray was BSDF-sampled with density prev_pdf > 0 (0 after the
    camera or a delta lobe: no weight). A sun's disc, where d meets it, adds its own weighted
    radiance here (sun.py): each light at infinity is weighed on its own."""
    if ENVIRONMENT and S.background[BG_KIND] == BACKGROUND_IMAGE:
        le, pdf = environment_radiance(S.background, S.env_rgb, S.env_texel_f, d)
        choose = map_choice(S)
        light = choose * pdf if choose > 0.0 else 0.0
        if light > 0.0 and prev_pdf > 0.0:
            w = bsdf_weight(prev_pdf, light)
            le = (le[0] * w, le[1] * w, le[2] * w)
        if PUNCTUAL and S.background[BG_SUN] >= 0.0:
            sun = sun_escaped(S, int(S.background[BG_SUN]), p, n_p, d, prev_pdf)
            le = (le[0] + sun[0], le[1] + sun[1], le[2] + sun[2])
        return le
    return background(S.background, d)


@target.device
def sun_escaped(S, light, p, n_p, d, prev_pdf):
    """The radiance of sun row `light` (sun.py) along d for a ray from p that meets nothing: the
    disc's where d falls inside it, weighed against the sun's own sampler when the ray was
    BSDF-sampled with density prev_pdf > 0 (the map's weight is its own: each light at infinity
    is weighed alone)."""
    le, pdf = sun_along(S, light, d)
    if pdf > 0.0 and prev_pdf > 0.0 and lights_to_sample(S):
        w = bsdf_weight(prev_pdf, pdf * light_pmf(S, light, p, n_p) * share_of(S, light))
        le = (le[0] * w, le[1] * w, le[2] * w)
    return le


# --- the kernels: area lights -----------------------------------------------------------------


@target.device
def light_edges(S, light):
    return light_vector(S, light, LIGHT_EDGE_U), light_vector(S, light, LIGHT_EDGE_V)


@target.device
def light_corner(S, light):
    return light_vector(S, light, LIGHT_CORNER)


@target.device
def planar_corner(S, prim):
    return (S.prims_f[prim, PLANAR_CORNER], S.prims_f[prim, PLANAR_CORNER + 1], S.prims_f[prim, PLANAR_CORNER + 2])


@target.device
def sample_light_surface(S, light, kind, prim, time, u1, u2):
    """A point uniform on area light row `light`'s surface (tree space), its normal and density per area."""
    eu, ev = light_edges(S, light)
    return sample_surface(kind, S.prims_f, prim, S.light_f[light, LIGHT_AREA], eu, ev, light_corner(S, light), time, u1, u2)


@target.device
def area_ratio(inst_f, inst, n_world):
    """Tree-space area per world area at a surface point of world normal n_world (unit): for the
    map L from tree to world, |det L^-1| |L^T n|."""
    m = INST_OBJECT_FROM_WORLD
    det = (inst_f[inst, m] * (inst_f[inst, m + 5] * inst_f[inst, m + 10] - inst_f[inst, m + 6] * inst_f[inst, m + 9])
           - inst_f[inst, m + 1] * (inst_f[inst, m + 4] * inst_f[inst, m + 10] - inst_f[inst, m + 6] * inst_f[inst, m + 8])
           + inst_f[inst, m + 2] * (inst_f[inst, m + 4] * inst_f[inst, m + 9] - inst_f[inst, m + 5] * inst_f[inst, m + 8]))
    w = INST_WORLD_FROM_OBJECT
    # L^T n: column c of L dotted with n.
    lt = (inst_f[inst, w] * n_world[0] + inst_f[inst, w + 4] * n_world[1] + inst_f[inst, w + 8] * n_world[2],
          inst_f[inst, w + 1] * n_world[0] + inst_f[inst, w + 5] * n_world[1] + inst_f[inst, w + 9] * n_world[2],
          inst_f[inst, w + 2] * n_world[0] + inst_f[inst, w + 6] * n_world[1] + inst_f[inst, w + 10] * n_world[2])
    return abs(det) * math.sqrt(dot(lt, lt))


@target.device
def emission(S, prim, x_tree, n_tree, x_world, time):
    """The emitted radiance of primitive `prim` at a point (its texture reads (u, v) there), as
    its material's `emission_source` says, from the front (sample_area_light has refused the
    back of a one-sided light before asking)."""
    mat = S.prims_i[prim, PRIM_MATERIAL]
    kind = S.prims_i[prim, PRIM_KIND]
    # A ray down onto the point from one unit above it: every kind's (u, v) as a hit there gives it.
    _, _, u, v = surface(kind, S, prim, madd(x_tree, n_tree, 1.0), neg(n_tree), 1.0, time, S.mat_i[mat, MAT_READS_UV] != 0)
    row, k = emission_source(S.mat_i, S.mat_f, mat)
    e = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, row, u, v, x_world)
    # k is 1 for the books' light: x * 1.0 is x, bit for bit.
    return (e[0] * k, e[1] * k, e[2] * k)


@target.device
def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


@target.device
def sample_area_light(S, light, pmf, p, time, u1, u2):
    """A point on area light row `light` for shading point p (world): (ok, point, unit direction
    from p, distance, solid angle density times `pmf` (the light's pmf within its group, as
    `select_light` gave it), emitted radiance). Not ok when the light is met edge-on or at p
    itself, or when it is one-sided and the point drawn turns its back (or its edge) to p: the
    points are drawn as on a two-sided light, so the density of those it gives is unchanged."""
    zero = (0.0, 0.0, 0.0)
    inst = S.light_i[light, LIGHT_INSTANCE]
    prim = S.light_i[light, LIGHT_PRIMITIVE]
    kind = S.prims_i[prim, PRIM_KIND]
    moved = S.inst_i[inst, INST_UNTRANSFORMED] != 1
    # A moving instance places its light where it is at the path's time.
    moving = MOTION and moves(S.inst_i, inst)
    world, back = NO_MAPS
    if moving:
        world, back = instance_maps(S.inst_i, S.motion_f, inst, time)
        p_tree = map_point(back, p)
    else:
        p_tree = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
    cone = False  # the density below is per solid angle already (a cone or a spherical rectangle)
    strategy = S.light_i[light, LIGHT_STRATEGY]
    if strategy == BY_CONE:
        c = sphere_center(kind, S.prims_f, prim, time)
        r = S.prims_f[prim, SPHERE_RADIUS]
        dist2, cone = cone_from(p_tree, c, r)
    elif strategy == BY_RECTANGLE:
        eu, ev = light_edges(S, light)
        q = planar_corner(S, prim)
        if rectangle_is_near(q, eu, ev, p_tree):
            frame = rectangle_frame(q, eu, ev, p_tree)
            cone = frame[8] > SMALL_RECTANGLE
    if cone and strategy == BY_CONE:
        x_tree, n_tree, pdf = sample_cone(p_tree, c, r, dist2, u1, u2)
    elif cone:
        x_tree = sample_rectangle(p_tree, frame, u1, u2)
        n_tree = (S.prims_f[prim, PLANAR_NORMAL], S.prims_f[prim, PLANAR_NORMAL + 1], S.prims_f[prim, PLANAR_NORMAL + 2])
        pdf = 1.0 / frame[8]
    else:
        x_tree, n_tree, pdf = sample_light_surface(S, light, kind, prim, time, u1, u2)
    if moving:
        x = map_point(world, x_tree)
        n = unit(map_normal(back, n_tree))
    elif moved:
        x = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, x_tree)
        n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n_tree))
    else:
        x, n = x_tree, n_tree
    to = sub(x, p)
    dist2_w = dot(to, to)
    if not dist2_w > 0.0:
        return False, x, zero, 0.0, 0.0, zero
    dist = math.sqrt(dist2_w)
    wi = scale(to, 1.0 / dist)
    if one_sided(S.mat_i, S.prims_i[prim, PRIM_MATERIAL]) and dot(n, wi) >= 0.0:
        # p is behind a one-sided light (or in its plane): the point sends nothing toward p.
        # Not ok rather than a zero radiance spares the BSDF and the shadow ray; the estimate is
        # the same (0), and a BSDF-sampled ray that hits this back gets black from `emitted`
        # with the very same test (the hit's side is dot(d, n) < 0 for the same normal).
        return False, x, wi, dist, 0.0, zero
    if not cone:
        cos_l = abs(dot(n, wi))
        if cos_l <= GRAZING:
            return False, x, wi, dist, 0.0, zero
        if moving:
            pdf *= area_ratio_of(world, back, n)
        elif moved:
            pdf *= area_ratio(S.inst_f, inst, n)
        pdf *= dist2_w / cos_l
    pdf *= pmf
    return True, x, wi, dist, pdf, emission(S, prim, x_tree, n_tree, x, time)


@target.device
def pdf_area_light(S, light, pmf, p, x, n, time):
    """The density `sample_area_light` from shading point p gives the point x (normal n) of area
    light row `light`, per solid angle at p and times `pmf` (its pmf within its group)."""
    inst = S.light_i[light, LIGHT_INSTANCE]
    prim = S.light_i[light, LIGHT_PRIMITIVE]
    to = sub(x, p)
    dist2 = dot(to, to)
    if not dist2 > 0.0:
        return 0.0
    moved = S.inst_i[inst, INST_UNTRANSFORMED] != 1
    moving = MOTION and moves(S.inst_i, inst)
    world, back = NO_MAPS
    if moving:
        world, back = instance_maps(S.inst_i, S.motion_f, inst, time)
    kind = S.prims_i[prim, PRIM_KIND]
    strategy = S.light_i[light, LIGHT_STRATEGY]
    if strategy == BY_RECTANGLE:
        if moving:
            p_tree = map_point(back, p)
        else:
            p_tree = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
        eu, ev = light_edges(S, light)
        q = planar_corner(S, prim)
        if rectangle_is_near(q, eu, ev, p_tree):
            solid = rectangle_frame(q, eu, ev, p_tree)[8]
            if solid > SMALL_RECTANGLE:
                return pmf / solid
    if strategy == BY_CONE:
        if moving:
            p_tree = map_point(back, p)
        else:
            p_tree = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
        c = sphere_center(kind, S.prims_f, prim, time)
        r = S.prims_f[prim, SPHERE_RADIUS]
        d2, outside = cone_from(p_tree, c, r)
        if outside:
            return pmf / cone_solid_angle(r, d2)
    per_area = 1.0 / S.light_f[light, LIGHT_AREA]
    eu, ev = light_edges(S, light)
    own, n_tree = sampler_normal(kind, eu, ev)
    if own:
        # The sampler's normal, not the hit's (a smooth mesh's hit has a blended one).
        if moving:
            n = unit(map_normal(back, n_tree))
        else:
            n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n_tree)) if moved else n_tree
    if moving:
        per_area *= area_ratio_of(world, back, n)
    elif moved:
        per_area *= area_ratio(S.inst_f, inst, n)
    cos_l = abs(dot(n, to)) / math.sqrt(dist2)
    if cos_l <= GRAZING:
        return math.inf
    return pmf * per_area * dist2 / cos_l


@target.kernel
def light_powers(S, out):
    """out[l] = world area of area light l times the luminance of its mean emission over 4x4
    stratified points (every row of S.light_i an area light)."""
    for light in range(S.light_i.shape[0]):
        inst = S.light_i[light, LIGHT_INSTANCE]
        prim = S.light_i[light, LIGHT_PRIMITIVE]
        kind = S.prims_i[prim, PRIM_KIND]
        moved = S.inst_i[inst, INST_UNTRANSFORMED] != 1
        total_l = 0.0
        total_area = 0.0
        for a in range(4):
            for b in range(4):
                x_tree, n_tree, per_area = sample_light_surface(S, light, kind, prim, 0.0, (a + 0.5) / 4.0, (b + 0.5) / 4.0)
                x = x_tree
                ratio = 1.0
                if moved:
                    x = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, x_tree)
                    ratio = area_ratio(S.inst_f, inst, unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n_tree)))
                total_l += max(0.0, luminance(emission(S, prim, x_tree, n_tree, x, 0.0)))
                total_area += 1.0 / (per_area * ratio)  # world area, as seen from this point's normal
        out[light] = total_area / 16.0 * total_l / 16.0
