"""Compiled loops over the rough dielectric's device functions, for its tests: many samples or
many evaluations in one call. Declared through renderer/target.py, as tests/renderer/kernel_calls.py
is, so their cached code is compiled again whenever a renderer source changes."""

import numpy as np
from renderer import target

from renderer.materials.rough_dielectric import rough_dielectric_eval, rough_dielectric_pdf, rough_dielectric_sample


@target.kernel
def rough_samples(ax, ay, eta, tint, correlated, wo, us):
    """One row per row of `us` (u0, u1, u2): wi (3), weight (3), pdf, delta (0 or 1)."""
    n = us.shape[0]
    out = np.empty((n, 8))
    for k in range(n):
        wi, weight, pdf, delta = rough_dielectric_sample(ax, ay, eta, (tint[0], tint[1], tint[2]), correlated,
                                                         (wo[0], wo[1], wo[2]), us[k, 0], us[k, 1], us[k, 2])
        out[k, 0], out[k, 1], out[k, 2] = wi[0], wi[1], wi[2]
        out[k, 3], out[k, 4], out[k, 5] = weight[0], weight[1], weight[2]
        out[k, 6] = pdf
        out[k, 7] = 1.0 if delta else 0.0
    return out


@target.kernel
def rough_values(ax, ay, eta, tint, correlated, wo, wis):
    """One row per row of `wis`: eval (3), pdf."""
    n = wis.shape[0]
    out = np.empty((n, 4))
    t = (tint[0], tint[1], tint[2])
    w = (wo[0], wo[1], wo[2])
    for k in range(n):
        wi = (wis[k, 0], wis[k, 1], wis[k, 2])
        f = rough_dielectric_eval(ax, ay, eta, t, correlated, w, wi)
        out[k, 0], out[k, 1], out[k, 2] = f[0], f[1], f[2]
        out[k, 3] = rough_dielectric_pdf(ax, ay, eta, t, correlated, w, wi)
    return out
