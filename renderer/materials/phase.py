"""Henyey and Greenstein's phase function: the anisotropic scattering of a medium (haze, clouds).

p(cos theta) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos theta)^(3/2)), where theta is the angle
between the ray's direction of travel before scattering and after (so g > 0 scatters forward).
It integrates to 1 over the sphere, and is sampled exactly by inverting its cdf in cos theta, so
a sample's weight (value / density) is exactly 1 and the medium's albedo is the whole weight.
g = 0 is the isotropic phase, which the books' media keep (`books.random_unit_vector`): the
kernels take this path only for g != 0.
"""

import math

from .. import target
from ..numerics.frame import basis, to_world
from ..numerics.vec import dot

INV_4PI = 1.0 / (4.0 * math.pi)
# Below this |g| the inverted cdf loses precision (it divides by g): cos theta = 1 - 2u there,
# the isotropic sampler, whose error against the true density is of order g.
SMALL_G = 1e-3


@target.device
def hg_value(g, cos_theta):
    """The phase function's density per solid angle at the scattering angle whose cosine is cos_theta."""
    denom = 1.0 + g * g - 2.0 * g * cos_theta
    # denom >= (1 - |g|)^2 > 0 for |g| < 1 and |cos_theta| <= 1.
    return INV_4PI * (1.0 - g * g) / (denom * math.sqrt(denom))


@target.device
def hg_cos_theta(g, u):
    """cos theta drawn from the phase function by the uniform u in [0, 1)."""
    if abs(g) < SMALL_G:
        return 1.0 - 2.0 * u
    s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u)
    c = (1.0 + g * g - s * s) / (2.0 * g)
    return min(1.0, max(-1.0, c))


@target.device
def hg_sample(g, w, u0, u1):
    """A unit direction scattered from the unit direction of travel w, and its density."""
    c = hg_cos_theta(g, u0)
    sin = math.sqrt(max(0.0, 1.0 - c * c))
    phi = 2.0 * math.pi * u1
    s, t = basis(w)
    return to_world(s, t, w, (sin * math.cos(phi), sin * math.sin(phi), c)), hg_value(g, c)


@target.device
def hg_pdf(g, w, wi):
    """The density `hg_sample` gives unit direction wi from the unit direction of travel w."""
    return hg_value(g, min(1.0, max(-1.0, dot(w, wi))))
