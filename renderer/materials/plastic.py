"""Plastic: a diffuse base under a smooth or rough (GGX) dielectric coat, as Mitsuba 3's
`plastic` and `roughplastic` model it, in the local shading frame (z the shading normal on the
viewer's side; see the contract in `dispatch.py`).

Parameters shared by the three functions: the coat's GGX widths `ax`, `ay` (both below
MIN_ALPHA: a smooth coat, whose reflection is a delta), its relative index `eta` (coat over
outside), the base's `albedo` (RGB), `nonlinear` (whether the base's colour darkens and
saturates through the bounces under the coat, see `coat.py`) and `correlated` (the shadowing
form of the coat's specular lobe: height-correlated, or Mitsuba's separable G1 G1).

The lobes, as f . cos(theta_i) for light arriving from wi and leaving toward wo:

- the coat's reflection: smooth, a mirror of weight F(wo); rough, the GGX microfacet lobe
  F(wo.h) D(h) G(wo, wi, h) / (4 wo.z) with h the half vector;
- the base seen through the coat: A / (pi eta^2) T(wi) T(wo) wi.z, where T is the coat's
  transmittance of each crossing (smooth: 1 - F; rough: the tabulated `coat_transmittance`),
  1 / eta^2 the compression of solid angle on the way out, and A the base's albedo with the
  coat's internal reflections summed (a / (1 - R_in), or a / (1 - a R_in) when `nonlinear`).

Sampling picks the coat's reflection with probability proportional to (1 - T(wo)) w and the
base with T(wo) (1 - w), then a visible GGX normal or a cosine-weighted direction. Mitsuba takes
w = 1 / (1 + the albedo texture's mean); here the density is asked without the colour
(`dispatch.pdf_bsdf` has none, as the principled material found), so w is Mitsuba's for its
default albedo, 0.5: w = 2/3, whatever the albedo. The estimate is the same; only its noise
differs from Mitsuba's for a very dark or very bright base.

A rough coat's density is the mixture of both lobes'. A smooth coat's mirror is a delta, so
`plastic_eval` and `plastic_pdf` cover only the base, whose density is scaled by the probability
of choosing it, and `plastic_sample` returns delta=True only when it chose the mirror. The weight
of any non-delta sample is computed as plastic_eval / plastic_pdf, so the two agree exactly.
"""

import math

from .. import target

from .coat import (coat_internal_reflectance, coat_reflectance, coat_transmittance,
                   inner_diffuse_reflectance)
from .microfacet import MIN_ALPHA, ggx_d, sample_visible_normal, smith_g, smith_g1

_ZERO = (0.0, 0.0, 0.0)


@target.device
def plastic_is_smooth(ax, ay):
    """Whether the coat is smooth (a delta reflection): both widths below MIN_ALPHA. A coat rough
    along one tangent only is GGX with the other width raised to MIN_ALPHA."""
    return ax < MIN_ALPHA and ay < MIN_ALPHA


# Mitsuba's steering of samples toward the coat, s / (s + d) with s = 1 (the coat's own colour is
# white) and d the base's mean albedo, taken at Mitsuba's default d = 0.5 (see above).
SPECULAR_WEIGHT = 1.0 / (1.0 + 0.5)


@target.device
def plastic_specular_probability(ax, ay, eta, cos_o):
    """Probability that `plastic_sample` picks the coat's reflection for a viewer at cosine
    cos_o > 0 (0 without a coat, 1 where a smooth coat reflects everything)."""
    if plastic_is_smooth(ax, ay):
        reflected = coat_reflectance(cos_o, eta)
    else:
        reflected = 1.0 - coat_transmittance(eta, math.sqrt(max(ax, MIN_ALPHA) * max(ay, MIN_ALPHA)), cos_o)
    p_spec = reflected * SPECULAR_WEIGHT
    # The denominator is (1 + reflected) / 3 > 0, reflected lying in [0, 1].
    return p_spec / (p_spec + (1.0 - reflected) * (1.0 - SPECULAR_WEIGHT))


@target.device
def _base_channel(a, nonlinear, r_in):
    """One channel of the base's albedo with the coat's internal reflections summed."""
    den = 1.0 - (a * r_in if nonlinear else r_in)
    # R_in < 1 and a <= 1 keep den > 0; an albedo above 1 with `nonlinear` could reach 0.
    return a / max(den, 1e-6)


@target.device
def plastic_eval(ax, ay, eta, albedo, nonlinear, correlated, wo, wi):
    """f(wo, wi) . wi.z of the plastic's non-delta parts (RGB): the base, and a rough coat's
    reflection; 0 unless both directions are above the surface. Reciprocal."""
    if not (wo[2] > 0.0 and wi[2] > 0.0):
        return _ZERO
    spec = 0.0
    if plastic_is_smooth(ax, ay):
        t_o = 1.0 - coat_reflectance(wo[2], eta)
        t_i = 1.0 - coat_reflectance(wi[2], eta)
        r_in = inner_diffuse_reflectance(eta)
    else:
        ax = max(ax, MIN_ALPHA)
        ay = max(ay, MIN_ALPHA)
        alpha = math.sqrt(ax * ay)
        t_o = coat_transmittance(eta, alpha, wo[2])
        t_i = coat_transmittance(eta, alpha, wi[2])
        r_in = coat_internal_reflectance(eta, alpha)
        hx, hy, hz = wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]
        inv = 1.0 / math.sqrt(hx * hx + hy * hy + hz * hz)  # hz > 0: both directions are above
        h = (hx * inv, hy * inv, hz * inv)
        cos_oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]
        spec = (coat_reflectance(cos_oh, eta) * ggx_d(ax, ay, h) * smith_g(ax, ay, wo, wi, h, correlated)
                / (4.0 * wo[2]))
    base = t_i * t_o * wi[2] / (math.pi * eta * eta)
    return (_base_channel(albedo[0], nonlinear, r_in) * base + spec,
            _base_channel(albedo[1], nonlinear, r_in) * base + spec,
            _base_channel(albedo[2], nonlinear, r_in) * base + spec)


@target.device
def plastic_pdf(ax, ay, eta, albedo, nonlinear, correlated, wo, wi):
    """The density per solid angle with which `plastic_sample` gives wi (its non-delta parts):
    the probability of each lobe times its own density; 0 unless both directions are above.
    `albedo` and `nonlinear` are not read: they are there so that the three functions take the
    same arguments."""
    if not (wo[2] > 0.0 and wi[2] > 0.0):
        return 0.0
    p_spec = plastic_specular_probability(ax, ay, eta, wo[2])
    pdf = (1.0 - p_spec) * wi[2] / math.pi
    if not plastic_is_smooth(ax, ay):
        ax = max(ax, MIN_ALPHA)
        ay = max(ay, MIN_ALPHA)
        hx, hy, hz = wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]
        inv = 1.0 / math.sqrt(hx * hx + hy * hy + hz * hz)
        h = (hx * inv, hy * inv, hz * inv)
        # Visible normals D_wo(h) = G1 (wo.h) D / wo.z, times the reflection's Jacobian
        # 1 / (4 wo.h): the dot products cancel, which keeps grazing half vectors finite.
        pdf += p_spec * smith_g1(ax, ay, wo, h) * ggx_d(ax, ay, h) / (4.0 * wo[2])
    return pdf


@target.device
def _cosine_direction(u1, u2):
    """A cosine-weighted direction about z (density z / pi); z > 0 for u1 < 1."""
    r = math.sqrt(u1)
    phi = 2.0 * math.pi * u2
    return (r * math.cos(phi), r * math.sin(phi), math.sqrt(max(0.0, 1.0 - u1)))


@target.device
def plastic_sample(ax, ay, eta, albedo, nonlinear, correlated, wo, u0, u1, u2):
    """(wi, weight, pdf, delta) for a viewer at wo: u0 picks the coat's reflection or the base
    (`plastic_specular_probability`), u1 and u2 the visible normal or the cosine direction.

    A smooth coat's mirror: wi the mirror direction, weight F(wo) / P(mirror), pdf 0, delta True.
    Otherwise the weight is plastic_eval / plastic_pdf of wi (the mixture's density), and (0, 0, 0)
    with pdf 0 when the sample fails: wo below the surface, or a microfacet reflection that
    points below it."""
    if not wo[2] > 0.0:
        return (0.0, 0.0, 1.0), _ZERO, 0.0, False
    p_spec = plastic_specular_probability(ax, ay, eta, wo[2])
    if u0 < p_spec:
        if plastic_is_smooth(ax, ay):
            w = coat_reflectance(wo[2], eta) / p_spec
            return (-wo[0], -wo[1], wo[2]), (w, w, w), 0.0, True
        m = sample_visible_normal(max(ax, MIN_ALPHA), max(ay, MIN_ALPHA), wo, u1, u2)
        c = 2.0 * (wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2])
        wi = (c * m[0] - wo[0], c * m[1] - wo[1], c * m[2] - wo[2])
    else:
        wi = _cosine_direction(u1, u2)
    pdf = plastic_pdf(ax, ay, eta, albedo, nonlinear, correlated, wo, wi)
    if not pdf > 0.0:
        return wi, _ZERO, 0.0, False
    f = plastic_eval(ax, ay, eta, albedo, nonlinear, correlated, wo, wi)
    return wi, (f[0] / pdf, f[1] / pdf, f[2] / pdf), pdf, False
