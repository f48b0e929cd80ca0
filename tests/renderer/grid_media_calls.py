"""Compiled entry points into the varying media's kernels, for tests/renderer/test_grid_media.py.
Every draw is keyed by path_key(seed, k, 0), as a render keys its paths."""

import math

import numpy as np

from renderer import target
from renderer.config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from renderer.grid_media import field_density
from renderer.materials.phase import hg_pdf, hg_sample
from renderer.numerics.rng import path_key, uniform
from renderer.tracing.shadow import shadow_transmittance
from renderer.tracing.traverse import intersect_scene


@target.kernel
def shadow_estimates(S, o, d, tmax, seed, n):
    """n estimates of the transmittance along o + t d, t in (0, tmax), each from its own key."""
    stack = (np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64))
    tstack = np.empty((BVH_STACK, 2))
    out = np.empty(n)
    for k in range(n):
        out[k] = shadow_transmittance(S, (o[0], o[1], o[2]), (d[0], d[1], d[2]), tmax, 0.0, stack, tstack,
                                      path_key(seed, k, 0), 1)
    return out


@target.kernel
def free_flights(S, o, d, seed, n):
    """n closest-hit distances along o + t d (inf where the ray escapes), each from its own key."""
    stack = (np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64))
    tstack = np.empty((BVH_STACK, 2))
    out = np.empty(n)
    for k in range(n):
        t, prim, _ = intersect_scene(S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f,
                                     S.bnd_i, S.bnd_f, S.tri_i, S.verts_f, (o[0], o[1], o[2]), (d[0], d[1], d[2]), 0.0,
                                     math.inf, 0.0, path_key(seed, k, 0), 0, stack, tstack)
        out[k] = t if prim >= 0 else math.inf
    return out


@target.kernel
def densities(bnd_f, header, points):
    """The field's density at each row of `points` (the medium's space)."""
    out = np.empty(points.shape[0])
    for k in range(points.shape[0]):
        out[k] = field_density(bnd_f, header, (points[k, 0], points[k, 1], points[k, 2]))
    return out


@target.kernel
def hg_draws(g, w, seed, n):
    """n rows (direction 3, the density hg_sample gave, the density hg_pdf gives it)."""
    out = np.empty((n, 5))
    for k in range(n):
        key = path_key(seed, k, 0)
        wi, pdf = hg_sample(g, (w[0], w[1], w[2]), uniform(key, 0), uniform(key, 1))
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = wi[0], wi[1], wi[2], pdf
        out[k, 4] = hg_pdf(g, (w[0], w[1], w[2]), wi)
    return out
