"""Compiled wrappers over the light selection for the light tree's tests (as kernel_calls.py):
they call the renderer's own `select_light` and `light_pmf` many times from given points."""

import numpy as np
from renderer import target

from renderer.light_tree import importance
from renderer.lights import light_pmf, sample_li, select_light
from renderer.numerics.rng import light_dim, path_key, uniform
from renderer.tracing.shadow import transmittance
from tests.renderer.kernel_calls import _stacks


@target.kernel
def choices(S, points, normals, us):
    """For each (point, normal, u0): rows (the light `select_light` chooses, its share, its pmf
    within the group, the pmf `light_pmf` gives the same light from the same point)."""
    out = np.zeros((us.shape[0], 4))
    for k in range(us.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        n = (normals[k, 0], normals[k, 1], normals[k, 2])
        light, share, pmf = select_light(S, p, n, us[k])
        out[k, 0], out[k, 1], out[k, 2] = light, share, pmf
        if light >= 0:
            out[k, 3] = light_pmf(S, light, p, n)
    return out


@target.kernel
def pmf_table(S, points, normals, first):
    """(points, lights): `light_pmf` of every light row from `first` on at each (point, normal)."""
    count = S.light_i.shape[0] - first
    out = np.zeros((points.shape[0], count))
    for k in range(points.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        n = (normals[k, 0], normals[k, 1], normals[k, 2])
        for j in range(count):
            out[k, j] = light_pmf(S, first + j, p, n)
    return out


@target.kernel
def importances(S, points, normals):
    """(points, nodes): each tree node's importance at each (point, normal)."""
    out = np.zeros((points.shape[0], S.ltree_f.shape[0]))
    for k in range(points.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        n = (normals[k, 0], normals[k, 1], normals[k, 2])
        for j in range(S.ltree_f.shape[0]):
            out[k, j] = importance(S.ltree_f, S.ltree_i, j, p, n)
    return out


@target.kernel
def direct_estimates(S, p, n, seed, count):
    """`count` light-sampled estimates of the luminance of the irradiance at point p (unit normal
    n), each |cos| le V / pdf (V: the shadow ray's transmittance, 0 or 1): the light sampler's own
    noise, without a BSDF or a path around it."""
    out = np.zeros(count)
    stack, tstack = _stacks()
    pp = (p[0], p[1], p[2])
    nn = (n[0], n[1], n[2])
    for k in range(count):
        key = path_key(seed, k, 0)
        ok, x, wi, dist, pdf, le, _ = sample_li(S, pp, nn, 0.0, uniform(key, light_dim(0, 0)), uniform(key, light_dim(0, 1)),
                                                 uniform(key, light_dim(0, 2)))
        if not ok or not pdf > 0.0:
            continue
        cos = abs(wi[0] * nn[0] + wi[1] * nn[1] + wi[2] * nn[2])
        o = (pp[0] + 1e-6 * nn[0], pp[1] + 1e-6 * nn[1], pp[2] + 1e-6 * nn[2])
        seen = transmittance(S, o, (x[0] - o[0], x[1] - o[1], x[2] - o[2]), 1.0 - 1e-7, 0.0, stack, tstack)
        out[k] = seen * cos * (0.2126 * le[0] + 0.7152 * le[1] + 0.0722 * le[2]) / pdf
    return out
