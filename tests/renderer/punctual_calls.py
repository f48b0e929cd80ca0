"""A compiled wrapper that asks the light category's `sample_li` and `pdf_li` at given shading
points, for the punctual lights' tests; declared through renderer/target.py like
tests/renderer/kernel_calls.py (its cached code is kept with the renderer's)."""

import numpy as np
from renderer import target

from renderer.lights import pdf_li, sample_li
from renderer.numerics.rng import light_dim, path_key, uniform


@target.kernel
def li_at(S, points, seed, draws):
    """For each shading point points[k] (no normal), `draws` samples of `sample_li`: rows (point k,
    ok, x 3, wi 3, distance, pdf, radiance 3, delta, u0: the number that chose the light)."""
    out = np.zeros((points.shape[0] * draws, 15))
    none = (0.0, 0.0, 0.0)
    for k in range(points.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        for j in range(draws):
            row = k * draws + j
            key = path_key(seed, row, 0)
            u0, u1, u2 = uniform(key, light_dim(0, 0)), uniform(key, light_dim(0, 1)), uniform(key, light_dim(0, 2))
            ok, x, wi, dist, pdf, le, delta = sample_li(S, p, none, 0.0, u0, u1, u2)
            out[row, 0] = k
            out[row, 1] = 1.0 if ok else 0.0
            out[row, 2], out[row, 3], out[row, 4] = x[0], x[1], x[2]
            out[row, 5], out[row, 6], out[row, 7] = wi[0], wi[1], wi[2]
            out[row, 8], out[row, 9] = dist, pdf
            out[row, 10], out[row, 11], out[row, 12] = le[0], le[1], le[2]
            out[row, 13] = 1.0 if delta else 0.0
            out[row, 14] = u0
    return out


@target.kernel
def pdf_li_of(S, light, p, x):
    """`pdf_li` of light row `light` from p (no normal) at x (a direction for a light at infinity)."""
    pp = (p[0], p[1], p[2])
    xx = (x[0], x[1], x[2])
    return pdf_li(S, light, pp, (0.0, 0.0, 0.0), xx, xx, 0.0)
