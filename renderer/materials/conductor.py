"""The rough conductor: a metal surface of GGX microfacets, each a perfect mirror, in the local
shading frame (z the shading normal on the viewer's side; see `microfacet.py`).

    f(wo, wi) = tint F(dot(wo, m)) D(m) G(wo, wi, m) / (4 |wo.z| |wi.z|),   m = unit(wo + wi),

with F the exact Fresnel reflectance of the complex index eta + i k (RGB), sampled by the
normals visible from wo (Heitz 2018), so pdf(wi) = D_wo(m) / (4 dot(wo, m)) and the sample's
weight f |wi.z| / pdf reduces to tint F G / G1(wo): no D, which is what makes visible-normal
sampling low in variance. Single scattering only: light that would bounce between microfacets
is lost, more the rougher the surface (see tests/renderer/test_conductor.py for the figure).

Below `MIN_ALPHA` on both axes the surface is a smooth mirror, a delta lobe with weight
tint F(wo.z); an anisotropic lobe with one axis below it has that axis raised to MIN_ALPHA.
A view from below the shading normal (wo.z <= 0, which a normal map can cause) sees black.

Parameters of every function: ax, ay the GGX widths along s and t; eta, k RGB 3-tuples of the
metal's index relative to the outside medium; tint an RGB 3-tuple multiplying F; correlated
whether G is the height-correlated Smith form (else separable, as Mitsuba 3).
"""

import math

from .. import target
from .fresnel import fresnel_conductor
from .microfacet import MIN_ALPHA, ggx_d, sample_visible_normal, smith_g, smith_g1

_BLACK = (0.0, 0.0, 0.0)
_UP = (0.0, 0.0, 1.0)


@target.device
def conductor_is_smooth(ax, ay):
    """Whether the lobe is the smooth mirror (a delta) rather than GGX."""
    return max(ax, ay) < MIN_ALPHA


@target.device
def _widths(ax, ay):
    """The widths a rough lobe works with: neither below MIN_ALPHA, so D stays finite."""
    return max(ax, MIN_ALPHA), max(ay, MIN_ALPHA)


@target.device
def _tinted_fresnel(cos_i, eta, k, tint):
    f = fresnel_conductor(cos_i, eta, k)
    return (f[0] * tint[0], f[1] * tint[1], f[2] * tint[2])


@target.device
def _half_vector(wo, wi):
    """unit(wo + wi), and False when the two cancel (no microfacet reflects one into the other)."""
    hx = wo[0] + wi[0]
    hy = wo[1] + wi[1]
    hz = wo[2] + wi[2]
    length = math.sqrt(hx * hx + hy * hy + hz * hz)
    if length <= 0.0:
        return _UP, False
    return (hx / length, hy / length, hz / length), True


@target.device
def conductor_sample(ax, ay, eta, k, tint, correlated, wo, u0, u1, u2):
    """(wi, weight, pdf, delta): a reflected direction for the view wo, u1 and u2 choosing the
    visible microfacet normal (u0 is unused: one lobe). weight = f |wi.z| / pdf, finite;
    (0, 0, 0) with pdf 0 when the sample fails (a view from below, or a reflection off a
    microfacet that points below the surface, which single-scattering GGX loses)."""
    smooth = conductor_is_smooth(ax, ay)
    if wo[2] <= 0.0:
        return _UP, _BLACK, 0.0, smooth
    if smooth:
        return (-wo[0], -wo[1], wo[2]), _tinted_fresnel(wo[2], eta, k, tint), 0.0, True
    ax, ay = _widths(ax, ay)
    m = sample_visible_normal(ax, ay, wo, u1, u2)
    cos_om = wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2]
    if cos_om <= 0.0:
        return _UP, _BLACK, 0.0, False
    wi = (2.0 * cos_om * m[0] - wo[0], 2.0 * cos_om * m[1] - wo[1], 2.0 * cos_om * m[2] - wo[2])
    if wi[2] <= 0.0:
        return _UP, _BLACK, 0.0, False
    g1 = smith_g1(ax, ay, wo, m)
    pdf = g1 * ggx_d(ax, ay, m) / (4.0 * wo[2])
    if g1 <= 0.0 or not pdf > 0.0:
        return _UP, _BLACK, 0.0, False
    # f |wi.z| / pdf = tint F D G / (4 wo.z) / (G1 D / (4 wo.z)) = tint F G / G1.
    ratio = smith_g(ax, ay, wo, wi, m, correlated) / g1
    f = _tinted_fresnel(cos_om, eta, k, tint)
    return wi, (f[0] * ratio, f[1] * ratio, f[2] * ratio), pdf, False


@target.device
def conductor_eval(ax, ay, eta, k, tint, correlated, wo, wi):
    """f(wo, wi) |wi.z| as RGB; black for a smooth (delta) lobe and where either direction is at
    or below the surface."""
    if conductor_is_smooth(ax, ay) or wo[2] <= 0.0 or wi[2] <= 0.0:
        return _BLACK
    ax, ay = _widths(ax, ay)
    m, ok = _half_vector(wo, wi)
    if not ok:
        return _BLACK
    cos_om = wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2]
    # f |wi.z| = tint F D G / (4 wo.z): the |wi.z| of f's denominator cancels the cosine.
    value = ggx_d(ax, ay, m) * smith_g(ax, ay, wo, wi, m, correlated) / (4.0 * wo[2])
    f = _tinted_fresnel(cos_om, eta, k, tint)
    return (f[0] * value, f[1] * value, f[2] * value)


@target.device
def conductor_pdf(ax, ay, eta, k, tint, correlated, wo, wi):
    """The density per solid angle with which `conductor_sample` gives wi: the visible-normal
    density of the half vector over the Jacobian 4 dot(wo, m) of the reflection,
    D_wo(m) / (4 dot(wo, m)) = G1(wo, m) D(m) / (4 wo.z). 0 for a smooth lobe and below the
    surface."""
    if conductor_is_smooth(ax, ay) or wo[2] <= 0.0 or wi[2] <= 0.0:
        return 0.0
    ax, ay = _widths(ax, ay)
    m, ok = _half_vector(wo, wi)
    if not ok:
        return 0.0
    return smith_g1(ax, ay, wo, m) * ggx_d(ax, ay, m) / (4.0 * wo[2])
