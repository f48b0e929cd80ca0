"""A rough dielectric: reflection and refraction through a surface of GGX microfacets (Walter,
Marschner, Li and Torrance 2007, "Microfacet models for refraction through rough surfaces"),
in the local shading frame of the material interface.

Frame and indices: z is the shading normal on the side the ray came from, so the direction
toward the viewer wo has wo.z > 0; `eta` is the index of the far side over the index of the
near side (1.5 for a ray entering glass from air, 1/1.5 for one leaving it). A reflected wi has
wi.z > 0, a transmitted one wi.z < 0. Alpha_x is the GGX width along the frame's s axis,
alpha_y along t.

Sampling (`rough_dielectric_sample`): a normal m visible from wo (Heitz 2018), then reflection
about m with the exact Fresnel reflectance F(wo . m) as probability, else refraction through m
(F = 1 under total internal reflection, so then always reflection). Its density over wi is

    reflection:    F D_wo(m) / (4 |wo . m|)
    transmission:  (1 - F) D_wo(m) |wi . m| / (wi . m + wo . m / eta)^2

with D_wo the density of visible normals and m the half vector of the pair: wo + wi for a
reflection, wo + eta wi for a refraction, turned toward +z.

The lobe's value f . |cos theta_i| is

    reflection:    F D G / (4 wo.z)
    transmission:  (1 - F) D G |wi . m| |wo . m| / (wo.z (wi . m + wo . m / eta)^2)

so that a sample's weight f |cos| / pdf is G(wo, wi) / G1(wo) in both cases, times the tint.

Radiance across the interface is NOT scaled by 1 / eta^2. The books' smooth dielectric (weight
= its colour for both lobes) does not scale it, and this lobe has to become that one as alpha
goes to 0, so it does the same: its transmission is the form pbrt-v4 uses for importance, not
for radiance. For a closed object lit from outside the factor would cancel anyway (eta^2 on the
way in, 1/eta^2 on the way out). The price is the form of reciprocity: with n_o the index on
wo's side and n_i the index on wi's,

    f(wo, wi) / n_i^2 = f(wi, wo) / n_o^2,   i.e.  f(wo, wi) = eta^2 f(wi, wo) for a refraction,

where the radiance-scaled BSDF would satisfy it with the indices the other way round.
Reflection is symmetric: f(wo, wi) = f(wi, wo).

Smooth limit: below `MIN_ALPHA` in both directions, or with eta = 1 (no interface at all, so no
reflection and no bending: a rough lobe would put all of its light in one direction, a density
with no bound), the material is the smooth dielectric, two deltas chosen exactly as
`books.dielectric_direction` chooses them: `_eval` and `_pdf` give 0 there.

No NaN or Inf: a wo at or below the surface, a sampled direction on the wrong side, or a pair of
directions that no microfacet joins give 0 (and a failed sample has direction (0, 0, 0) and a
black weight, on which the path tracer ends the path).
"""

import math

from .. import target

from ..numerics.vec import dot
from .fresnel import fresnel_dielectric
from .microfacet import MIN_ALPHA, ggx_d, sample_visible_normal, smith_g, smith_g1, visible_normal_pdf

NO_SAMPLE = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, False)


@target.device
def rough_dielectric_is_smooth(ax, ay):
    """Whether the lobe is the smooth dielectric's two deltas because GGX would be too narrow to
    evaluate: both widths below MIN_ALPHA. (With eta = 1 it is a delta too, whatever its widths:
    `no_interface`.)"""
    return ax < MIN_ALPHA and ay < MIN_ALPHA


@target.device
def no_interface(eta):
    """eta = 1: the same index on both sides, so nothing reflects and nothing bends."""
    return eta == 1.0


@target.device
def smooth_dielectric_sample(eta, tint, wo, u0):
    """(wi, weight, pdf, delta) of a smooth interface (eta = far index / near index) for wo.z > 0:
    the mirror direction with the Fresnel probability (u0 decides), else Snell's refraction.
    The same choice and directions as `books.dielectric_direction` for the same u; weight tint,
    the Fresnel factors cancelling against the probabilities."""
    inv_eta = 1.0 / eta
    reflectance, cos_t = fresnel_dielectric(min(wo[2], 1.0), inv_eta)
    if u0 < reflectance:
        return (-wo[0], -wo[1], wo[2]), (tint[0], tint[1], tint[2]), 0.0, True
    return (-wo[0] * inv_eta, -wo[1] * inv_eta, -cos_t), (tint[0], tint[1], tint[2]), 0.0, True


@target.device
def rough_dielectric_sample(ax, ay, eta, tint, correlated, wo, u0, u1, u2):
    """(wi, weight, pdf, delta) for unit wo (local frame, see the module's docstring): u1, u2 draw
    a visible microfacet normal, u0 chooses reflection (probability F) or refraction.

    weight = tint G(wo, wi) / G1(wo), finite and at most the tint; pdf the density of wi as
    `rough_dielectric_pdf` gives it. A sample that leaves on the wrong side of the macro surface
    (a reflection below it, a refraction above it: the single-scattering model's lost energy)
    returns direction (0, 0, 0) and weight black. Smooth (`rough_dielectric_is_smooth`, or
    `no_interface`): a delta.
    """
    if not wo[2] > 0.0:
        return NO_SAMPLE
    if rough_dielectric_is_smooth(ax, ay) or no_interface(eta):
        return smooth_dielectric_sample(eta, tint, wo, u0)
    ax = max(ax, MIN_ALPHA)
    ay = max(ay, MIN_ALPHA)
    m = sample_visible_normal(ax, ay, wo, u1, u2)
    cos_o = dot(wo, m)
    if not cos_o > 0.0:
        return NO_SAMPLE
    inv_eta = 1.0 / eta
    fresnel, cos_t = fresnel_dielectric(min(cos_o, 1.0), inv_eta)
    d_wo = visible_normal_pdf(ax, ay, wo, m)
    if u0 < fresnel:
        wi = (2.0 * cos_o * m[0] - wo[0], 2.0 * cos_o * m[1] - wo[1], 2.0 * cos_o * m[2] - wo[2])
        if not wi[2] > 0.0:
            return NO_SAMPLE
        pdf = fresnel * d_wo / (4.0 * cos_o)
    else:
        # Snell's law about m: unit length for unit wo and m.
        k = cos_o * inv_eta - cos_t
        wi = (k * m[0] - wo[0] * inv_eta, k * m[1] - wo[1] * inv_eta, k * m[2] - wo[2] * inv_eta)
        if not wi[2] < 0.0:
            return NO_SAMPLE
        cos_i = dot(wi, m)
        denom = cos_i + cos_o * inv_eta
        if denom == 0.0:
            return NO_SAMPLE
        pdf = (1.0 - fresnel) * d_wo * abs(cos_i) / (denom * denom)
    g1 = smith_g1(ax, ay, wo, m)
    if not (pdf > 0.0 and g1 > 0.0):
        return NO_SAMPLE
    ratio = smith_g(ax, ay, wo, wi, m, correlated) / g1
    return wi, (tint[0] * ratio, tint[1] * ratio, tint[2] * ratio), pdf, False


@target.device
def half_vector(eta, wo, wi):
    """(m, ok): the unit microfacet normal that takes wo to wi, turned toward +z: by reflection
    (wi.z > 0) the normalised wo + wi, by refraction the normalised wo + eta wi. ok is False
    when no microfacet does it: wi in the tangent plane, a zero half vector, or an m that
    wo does not see or that has wi on the side of it the lobe does not send light to."""
    zero = (0.0, 0.0, 1.0)
    if wi[2] == 0.0:
        return zero, False
    reflected = wi[2] > 0.0
    s = 1.0 if reflected else eta
    h = (wo[0] + s * wi[0], wo[1] + s * wi[1], wo[2] + s * wi[2])
    length = math.sqrt(dot(h, h))
    if not length > 0.0:
        return zero, False
    if h[2] < 0.0:
        length = -length
    m = (h[0] / length, h[1] / length, h[2] / length)
    # wo on m's front, wi on m's front for a reflection and on its back for a refraction.
    if not dot(wo, m) > 0.0 or not dot(wi, m) * wi[2] > 0.0:
        return zero, False
    return m, True


@target.device
def rough_dielectric_value_and_pdf(ax, ay, eta, correlated, wo, wi):
    """(f . |cos theta_i| without the tint, pdf) of the rough lobe for unit wo and wi: the two
    formulas of the module's docstring, sharing their half vector and Fresnel term. (0, 0) for
    a smooth lobe, wo.z <= 0, or a pair that no microfacet joins."""
    if not wo[2] > 0.0 or rough_dielectric_is_smooth(ax, ay) or no_interface(eta):
        return 0.0, 0.0
    ax = max(ax, MIN_ALPHA)
    ay = max(ay, MIN_ALPHA)
    m, ok = half_vector(eta, wo, wi)
    if not ok:
        return 0.0, 0.0
    cos_o = dot(wo, m)
    cos_i = dot(wi, m)
    fresnel = fresnel_dielectric(min(cos_o, 1.0), 1.0 / eta)[0]
    d = ggx_d(ax, ay, m)
    g = smith_g(ax, ay, wo, wi, m, correlated)
    d_wo = visible_normal_pdf(ax, ay, wo, m)
    if wi[2] > 0.0:
        return fresnel * d * g / (4.0 * wo[2]), fresnel * d_wo / (4.0 * cos_o)
    denom = cos_i + cos_o / eta
    jacobian = abs(cos_i) / (denom * denom)
    if not jacobian < math.inf:
        return 0.0, 0.0
    transmitted = 1.0 - fresnel
    return transmitted * d * g * jacobian * cos_o / wo[2], transmitted * d_wo * jacobian


@target.device
def rough_dielectric_eval(ax, ay, eta, tint, correlated, wo, wi):
    """f(wo, wi) . |cos theta_i| as RGB (the tint times the lobe's value); the smooth lobe's
    deltas excluded, so 0 when the lobe is smooth."""
    value = rough_dielectric_value_and_pdf(ax, ay, eta, correlated, wo, wi)[0]
    return (tint[0] * value, tint[1] * value, tint[2] * value)


@target.device
def rough_dielectric_pdf(ax, ay, eta, tint, correlated, wo, wi):
    """The density per solid angle with which `rough_dielectric_sample` gives unit wi for wo;
    0 when the lobe is smooth (deltas)."""
    return rough_dielectric_value_and_pdf(ax, ay, eta, correlated, wo, wi)[1]
