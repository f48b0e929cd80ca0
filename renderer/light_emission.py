"""Photons: light leaving the lights towards the caustic targets (integrator caustics).

The lights category's side of light tracing (tracing/caustics.py traces the photons): which
lights send photons, and a photon's start. A photon leaves an area light, the environment map or
the sun (the lights a path can meet by chance after a specular bounce, which are the ones whose
caustic paths integrator caustics takes from the path tracer), chosen by power, aimed at the
targets of caustic_targets.py. Its weight `beta` is the radiance it carries over the density of
its start: emitted radiance x |cos| at the light / (choice x area density x direction density)
for an area light; radiance / (choice x direction density x area density across the targets'
discs) for light at infinity. Point, spot and directional lights send no photons: a path never
meets them by chance, so mis has no caustics of theirs either, and the two integrators agree.

Tables: `caustic_lf` (CAUSTIC_LIGHT_F), a row per light that sends photons, with its choice's
probability and cumulative distribution.
"""

from __future__ import annotations

import math

import numpy as np

from . import target
from .caustic_targets import sample_across_targets, sample_toward_targets
from .columns import Column, Layout
from .environment import sample_environment
from .light_table import (AREA_LIGHT, ENVIRONMENT_LIGHT, LIGHT_DIRECTION, LIGHT_INSTANCE, LIGHT_KIND,
                          LIGHT_POWER, LIGHT_PRIMITIVE, LIGHT_RADIANCE, LIGHT_SIZE, SUN_LIGHT, light_vector)
from .lights import area_ratio, emission, sample_light_surface
from .materials import one_sided
from .numerics.cdf import search_cdf
from .numerics.vec import dot, madd, neg, unit, xform_normal, xform_point
from .shapes import PRIM_KIND, PRIM_MATERIAL
from .sun import sample_sun_cone
from .trees import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT

CAUSTIC_LIGHT_F = Layout("caustic_lf", "float64", [
    Column("light", 1, "row of light_i / light_f: an area light, the environment map or the sun"),
    Column("pmf", 1, "the probability a photon leaves it: its share of those lights' power"),
    Column("cdf", 1, "the cumulative pmf up to and including this row"),
])
CL_LIGHT, CL_PMF, CL_CDF = CAUSTIC_LIGHT_F.offsets("light", "pmf", "cdf")
# A photon leaves an area light this far along its normal (relative to the coordinates'
# magnitude), as a ray leaving a surface does (shapes/dispatch.spawn_origin).
_OFFSET = 1e-9


def no_photon_lights() -> np.ndarray:
    return np.zeros((0, CAUSTIC_LIGHT_F.width), np.float64)


def photon_lights(flat, env_power: float) -> np.ndarray:
    """The caustic_lf table of `flat` (its targets already in caustic_f): the area lights, the
    environment map and the sun of the light table, each chosen in proportion to the flux it
    sends the targets, roughly: an area light its power times the share of directions from its
    centre that the targets subtend; a light at infinity its irradiance times the targets'
    cross-sections (the map's radiance integrated over the sphere `env_power`, halved: half of it
    arrives from either side of a disc). Only the variance depends on these weights."""
    from .environment import scene_radius
    from .light_bounds import area_light_bounds
    from .light_table import LIGHT_CORNER, LIGHT_EDGE_U, LIGHT_EDGE_V
    from .lights import front_only

    light_i, light_f, targets = flat.light_i, flat.light_f, flat.caustic_f
    if len(light_i) == 0 or len(targets) == 0:
        return no_photon_lights()
    kind = light_i[:, LIGHT_KIND]
    power = light_f[:, LIGHT_POWER]
    centers, radii = targets[:, :3], targets[:, 3]
    cross_section = float(np.sum(np.pi * radii ** 2))
    weight = np.zeros(len(light_i))
    area = np.flatnonzero((kind == AREA_LIGHT) & (power > 0.0))
    if len(area):
        b = area_light_bounds(flat, light_i[area, LIGHT_INSTANCE], light_i[area, LIGHT_PRIMITIVE],
                              light_f[area, LIGHT_EDGE_U:LIGHT_EDGE_U + 3], light_f[area, LIGHT_EDGE_V:LIGHT_EDGE_V + 3],
                              light_f[area, LIGHT_CORNER:LIGHT_CORNER + 3], power[area], front_only(flat, area))
        mid = 0.5 * (b.lo + b.hi)
        d2 = np.sum((mid[:, None, :] - centers[None, :, :]) ** 2, axis=2)
        r2 = radii[None, :] ** 2
        share = np.where(d2 > r2, 0.5 * (1.0 - np.sqrt(np.maximum(0.0, 1.0 - r2 / np.maximum(d2, 1e-300)))), 1.0)
        weight[area] = power[area] * np.minimum(1.0, share.sum(axis=1))
    env = np.flatnonzero(kind == ENVIRONMENT_LIGHT)
    if len(env) and env_power > 0.0:
        weight[env] = 0.5 * env_power * cross_section
    sun = np.flatnonzero((kind == SUN_LIGHT) & (power > 0.0))
    if len(sun):
        radius = scene_radius(flat)
        weight[sun] = power[sun] * cross_section / (np.pi * radius * radius)
    rows = np.flatnonzero(weight > 0.0)
    if len(rows) == 0 or not np.isfinite(weight[rows]).all():
        return no_photon_lights()
    pmf = weight[rows] / weight[rows].sum()
    cdf = np.cumsum(pmf)
    cdf[-1] = 1.0
    return CAUSTIC_LIGHT_F.array(len(rows), light=rows.astype(np.float64), pmf=pmf, cdf=cdf)


@target.device
def emit_photon(S, time, u0, u1, u2, u3, u4, u5):
    """A photon's start: (ok, origin, unit direction, beta (rgb)). Not ok where there is nothing
    to send (no targets, no light, a draw the light does not emit along)."""
    zero = (0.0, 0.0, 0.0)
    n = S.caustic_lf.shape[0]
    if n == 0 or S.caustic_f.shape[0] == 0:
        return False, zero, zero, zero
    k = search_cdf(S.caustic_lf, CL_CDF, 0, n, u0)
    light = int(S.caustic_lf[k, CL_LIGHT])
    choice = S.caustic_lf[k, CL_PMF]
    kind = S.light_i[light, LIGHT_KIND]
    if kind == AREA_LIGHT:
        inst = S.light_i[light, LIGHT_INSTANCE]
        prim = S.light_i[light, LIGHT_PRIMITIVE]
        x_tree, n_tree, pdf_area = sample_light_surface(S, light, S.prims_i[prim, PRIM_KIND], prim, time, u1, u2)
        if S.inst_i[inst, INST_UNTRANSFORMED] != 1:
            x = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, x_tree)
            nrm = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n_tree))
            pdf_area *= area_ratio(S.inst_f, inst, nrm)
        else:
            x, nrm = x_tree, n_tree
        d, pdf_dir = sample_toward_targets(S.caustic_f, x, u3, u4, u5)
        cos_l = dot(nrm, d)
        if not pdf_dir > 0.0 or not pdf_area > 0.0 or cos_l == 0.0:
            return False, zero, zero, zero
        if one_sided(S.mat_i, S.prims_i[prim, PRIM_MATERIAL]) and cos_l < 0.0:
            return False, zero, zero, zero
        le = emission(S, prim, x_tree, n_tree, x, time)
        k_beta = abs(cos_l) / (choice * pdf_area * pdf_dir)
        eps = _OFFSET * (abs(x[0]) + abs(x[1]) + abs(x[2]) + 1.0)
        origin = madd(x, nrm, eps if cos_l > 0.0 else -eps)
        return True, origin, d, (le[0] * k_beta, le[1] * k_beta, le[2] * k_beta)
    # A light at infinity: the direction towards it, then a point across the targets' discs.
    if kind == ENVIRONMENT_LIGHT:
        ok, w, pdf_w, le = sample_environment(S.background, S.env_rgb, S.env_row_f, S.env_texel_f, u1, u2)
        if not ok:
            return False, zero, zero, zero
    else:  # SUN_LIGHT
        w, pdf_w = sample_sun_cone(light_vector(S, light, LIGHT_DIRECTION), S.light_f[light, LIGHT_SIZE], u1, u2)
        le = light_vector(S, light, LIGHT_RADIANCE)
    if not pdf_w > 0.0:
        return False, zero, zero, zero
    y, pdf_y = sample_across_targets(S.caustic_f, w, u3, u4, u5)
    if not pdf_y > 0.0:
        return False, zero, zero, zero
    # Start beyond everything along w: the scene's box (the top-level tree's root) lies within
    # its centre's distance along w plus its half-diagonal.
    lo = (S.tlas_f[0, 0], S.tlas_f[0, 1], S.tlas_f[0, 2])
    hi = (S.tlas_f[0, 3], S.tlas_f[0, 4], S.tlas_f[0, 5])
    c = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]))
    half = 0.5 * math.sqrt((hi[0] - lo[0]) ** 2 + (hi[1] - lo[1]) ** 2 + (hi[2] - lo[2]) ** 2)
    along = max(dot(c, w) + 2.0 * half, dot(y, w)) + 1.0
    origin = madd(y, w, along)
    k_beta = 1.0 / (choice * pdf_w * pdf_y)
    return True, origin, neg(w), (le[0] * k_beta, le[1] * k_beta, le[2] * k_beta)
