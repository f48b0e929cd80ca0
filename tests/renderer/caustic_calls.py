"""Compiled wrappers of the caustic integrator's sampling routines, for tests (see kernel_calls.py)."""

import numpy as np
from renderer import target

from renderer.camera import camera_importance, camera_ray
from renderer.caustic_targets import pdf_across_targets, pdf_toward_targets, sample_across_targets, sample_toward_targets
from renderer.numerics.rng import path_key, uniform


@target.kernel
def toward_samples(cf, x, n, seed):
    """n directions from point x by `sample_toward_targets`, their densities and `pdf_toward_targets`' of them."""
    out = np.empty((n, 3))
    pdf = np.empty(n)
    again = np.empty(n)
    p = (x[0], x[1], x[2])
    for k in range(n):
        key = path_key(seed, k, 0)
        d, q = sample_toward_targets(cf, p, uniform(key, 0), uniform(key, 1), uniform(key, 2))
        out[k, 0], out[k, 1], out[k, 2] = d
        pdf[k] = q
        again[k] = pdf_toward_targets(cf, p, d)
    return out, pdf, again


@target.kernel
def toward_densities(cf, x, dirs):
    p = (x[0], x[1], x[2])
    out = np.empty(dirs.shape[0])
    for k in range(dirs.shape[0]):
        out[k] = pdf_toward_targets(cf, p, (dirs[k, 0], dirs[k, 1], dirs[k, 2]))
    return out


@target.kernel
def across_samples(cf, w, n, seed):
    """n points of the plane perpendicular to w by `sample_across_targets`, their densities and `pdf_across_targets`'."""
    out = np.empty((n, 3))
    pdf = np.empty(n)
    again = np.empty(n)
    ww = (w[0], w[1], w[2])
    for k in range(n):
        key = path_key(seed, k, 0)
        y, q = sample_across_targets(cf, ww, uniform(key, 0), uniform(key, 1), uniform(key, 2))
        out[k, 0], out[k, 1], out[k, 2] = y
        pdf[k] = q
        again[k] = pdf_across_targets(cf, ww, y)
    return out, pdf, again


@target.kernel
def project_camera_rays(cam, width, height, n, seed, reach):
    """For n camera rays through random pixels: the pixel, the point `reach` along the ray, and
    what `camera_importance` makes of that point with the ray's own lens point (same key)."""
    out = np.empty((n, 7))
    for k in range(n):
        key = path_key(seed, k, 0)
        i = int(uniform(key, 100) * width)
        j = int(uniform(key, 101) * height)
        o, d, _ = camera_ray(cam, i, j, key)
        x = (o[0] + reach * d[0], o[1] + reach * d[1], o[2] + reach * d[2])
        ok, pi, pj, lens, kk = camera_importance(cam, width, height, x, key)
        out[k, 0], out[k, 1] = i, j
        out[k, 2] = 1.0 if ok else 0.0
        out[k, 3], out[k, 4] = pi, pj
        out[k, 5] = kk
        out[k, 6] = abs(lens[0] - o[0]) + abs(lens[1] - o[1]) + abs(lens[2] - o[2])
    return out
