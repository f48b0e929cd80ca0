"""The principled material: glTF 2.0's metallic-roughness model with the common extensions
(KHR_materials_transmission, _ior, _specular, _clearcoat), in the local shading frame of the
material interface (z the shading normal on the ray's side, wo.z > 0; see dispatch.py).

The lobes and how glTF's Appendix B mixes them:

- specular(alpha): a GGX microfacet BRDF, D G / (4 |cos_o| |cos_i|), with the Smith shadowing
  `correlated` chooses (microfacet.py);
- metal = specular * Schlick(F0 = base colour, |wo . h|);
- dielectric = the specular layer weighted by s Schlick(F0, |wo . h|) over a base, with s the
  `specular` factor of KHR_materials_specular and F0 = ((ior - 1) / (ior + 1))^2 times its
  `specular_color` (RGB, clamped to 1); the base is
  mix(diffuse base/pi, base-tinted transmission, transmission);
- material = mix(dielectric, metal, metallic);
- clearcoat: a second GGX layer of index 1.5 (F0 = 0.04) and width cc_alpha, weighted by
  clearcoat * Schlick(0.04, |wo . h|), over the material.

Two choices differ from the specification's sample code, for physical plausibility, which the
specification itself asks of a path tracer ("the BRDF MUST be positive, reciprocal, and
energy conserving"; its section "Coupling Diffuse and Specular Reflection"):

- Coupling. glTF's `fresnel_mix` weights the base by 1 - F(wo . h). Its own discussion notes
  that this reflects more than it receives at grazing angles (a mirror-like layer taking ~F(wo.z)
  while the base still gets ~1 - F(wo . h) with h far from wo). We weight the base instead by
  Burley's (2012) (1 - s max F(cos_o)) (1 - s max F(cos_i)), the max over RGB as in
  KHR_materials_specular's max_value, which the same discussion names: symmetric in the two
  directions (reciprocal), energy conserving, and exactly 1 when s = 0. The clearcoat couples to
  what is below it the same way, with its own F. The layers themselves keep F(wo . h), the
  microfacet's own Fresnel factor. The price, which Burley notes: darker grazing angles.
- Transmission comes in two forms, chosen by the row's `thin_walled` flag:
  - thin-walled, glTF's meaning without KHR_materials_volume: the surface is two back-to-back
    interfaces and a ray passes straight through, blurred by roughness. The lobe is the specular
    lobe mirrored through the surface plane (glTF's H_T = normalize(V + L mirrored)), tinted by
    the base colour, under the specular layer like the diffuse base it mixes with; a delta
    straight through (wi = -wo) at roughness 0. The index enters only through F0, the same for
    eta and 1 / eta. A closed sphere of it reads as a soap bubble.
  - volumetric (the default of the file format: a closed shape of principled glass reads as
    glass, as in Blender): the transmitted share (1 - metallic) transmission is the rough
    dielectric of rough_dielectric.py (Walter et al. 2007: its own exact Fresnel reflection and
    its refraction, eta = far index / near index by the side hit), its refraction tinted by the
    base colour; the specular layer and the diffuse base share the rest, (1 - transmission).
    With transmission 1 and metallic 0 the material is that rough dielectric (under any coat).

Roughness 0 (both alphas below MIN_ALPHA; one alone below it is raised to it, as the conductor
does) makes the specular, metal and transmission lobes deltas, and a clearcoat alpha below it
the coat's. `principled_eval` and `principled_pdf` cover the other lobes only;
`principled_sample`'s weight for them is exactly eval / pdf of the whole non-delta mixture, and
for a delta lobe its value over the probability of choosing it.

The lobe is chosen by u0 in proportion to an estimate of each lobe's share of the reflected
energy at wo (`lobe_probabilities`): Fresnel factors at cos theta_o in place of wo . h, and a
white base (the density is asked without the colour). A lobe that can be non-zero is never
given probability 0 (the specular floor below), so the estimator stays unbiased whatever the
estimate gets wrong.
"""

import math

from .. import target

from .fresnel import schlick
from .microfacet import MIN_ALPHA, ggx_d, sample_visible_normal, smith_g, visible_normal_pdf
from .rough_dielectric import rough_dielectric_sample, rough_dielectric_value_and_pdf

# glTF's clearcoat is a layer of index 1.5: F0 = ((1.5 - 1) / (1.5 + 1))^2.
COAT_F0 = 0.04
# Least Fresnel weight the lobe choice gives the specular lobe: F0 can be 0 (ior 1, or a black
# metal) at normal incidence while F(wo . h) is not elsewhere, so an estimate of 0 would leave
# directions the lobe reaches unsampled.
SPECULAR_FLOOR = 0.02

_ZERO = (0.0, 0.0, 0.0)
_WHITE = (1.0, 1.0, 1.0)


@target.device
def schlick1(f0, cos):
    """Schlick's F0 + (1 - F0)(1 - cos)^5 for one channel, cos clamped to [0, 1]."""
    c = 1.0 - min(1.0, max(0.0, cos))
    c2 = c * c
    return f0 + (1.0 - f0) * c2 * c2 * c


@target.device
def dielectric_f0(eta):
    """F0 of an interface of relative index eta (or 1 / eta: the same), clamped to [0, 1]."""
    r = (eta - 1.0) / (eta + 1.0)
    return min(1.0, r * r)


@target.device
def half_vector(wo, wi):
    """normalize(wo + wi) for two directions on the upper side (their sum has z > 0)."""
    hx = wo[0] + wi[0]
    hy = wo[1] + wi[1]
    hz = wo[2] + wi[2]
    inv = 1.0 / math.sqrt(hx * hx + hy * hy + hz * hz)
    return (hx * inv, hy * inv, hz * inv)


@target.device
def cosine_direction(u1, u2):
    """A cosine-weighted direction about z (density z / pi): a uniform point of the unit disk
    lifted onto the hemisphere (Malley's method)."""
    r = math.sqrt(u1)
    phi = 2.0 * math.pi * u2
    return (r * math.cos(phi), r * math.sin(phi), math.sqrt(max(0.0, 1.0 - u1)))


@target.device
def microfacet_value(ax, ay, correlated, wo, wi, h):
    """D(h) G(wo, wi, h) / (4 wo.z): f . cos of a GGX specular lobe without its Fresnel factor,
    for wo and wi above the surface and h their half vector (the cos_i of f . cos cancels)."""
    return ggx_d(ax, ay, h) * smith_g(ax, ay, wo, wi, h, correlated) / (4.0 * wo[2])


@target.device
def reflection_pdf(ax, ay, wo, h):
    """The density of wi = reflect(wo, h) when h is drawn from the normals visible from wo:
    D_wo(h) / (4 |wo . h|), the Jacobian of the reflection."""
    cos_oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]
    if cos_oh <= 0.0:
        return 0.0
    return visible_normal_pdf(ax, ay, wo, h) / (4.0 * cos_oh)


@target.device
def layer_f0(eta, specular_color):
    """The specular layer's RGB reflectance at normal incidence: F0 of the index times
    KHR_materials_specular's colour, clamped to 1 (its f90 stays 1)."""
    f0 = dielectric_f0(eta)
    return (min(1.0, f0 * specular_color[0]), min(1.0, f0 * specular_color[1]), min(1.0, f0 * specular_color[2]))


@target.device
def layer_share(specular, f0_rgb, cos):
    """What the specular layer takes of the light at cos theta before the base gets the rest:
    specular x the largest channel of its Fresnel factor (KHR_materials_specular's max_value,
    so the base is never tinted by the complement of the specular colour)."""
    f = schlick(f0_rgb, cos)
    return specular * max(f[0], f[1], f[2])


@target.device
def is_rough(ax, ay):
    """Whether the specular lobes are GGX rather than a mirror (and straight through): as for the
    conductor, a lobe is smooth only when both widths are below MIN_ALPHA."""
    return max(ax, ay) >= MIN_ALPHA


@target.device
def lobe_probabilities(metallic, transmission, clearcoat, specular, f0_rgb, thin_walled, cos_o, rough):
    """(diffuse, specular, transmission, clearcoat) choice probabilities at cos theta_o, summing
    to 1, or all 0 when the material reflects nothing. `rough`: whether the specular lobe is
    GGX (then it gets at least SPECULAR_FLOOR) or a mirror (whose value at wo is exact).

    The base colour is not read: the interface asks a material's density without its colour
    (`pdf_bsdf`), so the choice weighs the lobes as if the base were white, and a metal's
    Fresnel factor as 1. The volumetric transmission lobe is a whole dielectric (its own
    reflection included), so it takes its share from beside the layer, not from under it."""
    floor = SPECULAR_FLOOR if rough else 0.0
    f_coat = clearcoat * schlick1(COAT_F0, cos_o)
    under_coat = 1.0 - f_coat
    f_layer = schlick(f0_rgb, cos_o)
    layer_mean = (f_layer[0] + f_layer[1] + f_layer[2]) / 3.0
    under_layer = under_coat * (1.0 - metallic) * (1.0 - layer_share(specular, f0_rgb, cos_o))
    if thin_walled:
        w_spec = under_coat * ((1.0 - metallic) * specular * max(layer_mean, floor) + metallic)
        w_diffuse = under_layer * (1.0 - transmission)
        w_trans = under_layer * transmission
    else:
        opaque = (1.0 - metallic) * (1.0 - transmission)
        w_spec = under_coat * (opaque * specular * max(layer_mean, floor) + metallic)
        w_diffuse = under_layer * (1.0 - transmission)
        w_trans = under_coat * (1.0 - metallic) * transmission
    total = w_diffuse + w_spec + w_trans + f_coat
    if not total > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    return w_diffuse / total, w_spec / total, w_trans / total, f_coat / total


@target.device
def glass_value_and_pdf(ax, ay, eta, correlated, wo, wi):
    """The volumetric transmission lobe: the rough dielectric's (f . |cos theta_i|, pdf), both 0
    where it is smooth (its deltas)."""
    return rough_dielectric_value_and_pdf(ax, ay, eta, correlated, wo, wi)


@target.device
def principled_eval(ax, ay, metallic, transmission, clearcoat, cc_alpha, specular, specular_color, eta, thin_walled, base,
                    correlated, wo, wi):
    """f(wo, wi) . |cos theta_i| of the non-delta lobes, RGB: 0 where wo.z <= 0 or wi.z = 0.

    Reflection (wi.z > 0) is reciprocal; transmission (wi.z < 0) goes through the mirrored
    specular lobe (thin-walled) or the rough dielectric's refraction (volumetric). See the
    module's docstring for the model."""
    if not wo[2] > 0.0 or wi[2] == 0.0:
        return _ZERO
    cos_o = min(wo[2], 1.0)
    cos_i = min(abs(wi[2]), 1.0)
    f0 = layer_f0(eta, specular_color)
    coat = (1.0 - clearcoat * schlick1(COAT_F0, cos_o)) * (1.0 - clearcoat * schlick1(COAT_F0, cos_i))
    under_layer = (1.0 - layer_share(specular, f0, cos_o)) * (1.0 - layer_share(specular, f0, cos_i))
    rough = is_rough(ax, ay)
    glass = 0.0 if thin_walled else (1.0 - metallic) * transmission
    if glass > 0.0:
        value = glass * glass_value_and_pdf(ax, ay, eta, correlated, wo, wi)[0]
    else:
        value = 0.0
    ax = max(ax, MIN_ALPHA)
    ay = max(ay, MIN_ALPHA)
    if wi[2] < 0.0:
        if not thin_walled:
            # Refraction into (or out of) the volume, tinted by the base colour.
            k = value * coat
        elif rough and transmission > 0.0 and metallic < 1.0:
            mirrored = (wi[0], wi[1], -wi[2])
            h = half_vector(wo, mirrored)
            k = (1.0 - metallic) * transmission * under_layer * coat * microfacet_value(ax, ay, correlated, wo, mirrored, h)
        else:
            return _ZERO
        return (base[0] * k, base[1] * k, base[2] * k)
    k_diffuse = (1.0 - metallic) * (1.0 - transmission) * under_layer * cos_i / math.pi
    r = base[0] * k_diffuse + value
    g = base[1] * k_diffuse + value
    b = base[2] * k_diffuse + value
    h = half_vector(wo, wi)
    cos_oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]
    if rough:
        spec = microfacet_value(ax, ay, correlated, wo, wi, h)
        layer = schlick(f0, cos_oh)
        # Thin-walled, the layer lies over the transmission too; volumetric, the glass reflects by itself.
        dielectric = (1.0 - metallic) * specular * (1.0 if thin_walled else 1.0 - transmission)
        f_metal = schlick((base[0], base[1], base[2]), cos_oh)
        r += spec * (dielectric * layer[0] + metallic * f_metal[0])
        g += spec * (dielectric * layer[1] + metallic * f_metal[1])
        b += spec * (dielectric * layer[2] + metallic * f_metal[2])
    r *= coat
    g *= coat
    b *= coat
    if clearcoat > 0.0 and cc_alpha >= MIN_ALPHA:
        c = clearcoat * schlick1(COAT_F0, cos_oh) * microfacet_value(cc_alpha, cc_alpha, correlated, wo, wi, h)
        r += c
        g += c
        b += c
    return (r, g, b)


@target.device
def principled_pdf(ax, ay, metallic, transmission, clearcoat, cc_alpha, specular, specular_color, eta, thin_walled, base,
                   correlated, wo, wi):
    """The density per solid angle with which `principled_sample` gives wi through a non-delta
    lobe: the choice probabilities times each lobe's density, summed (a delta lobe's share
    missing, so it integrates to less than 1 when there is one). `base` is not read (see
    `lobe_probabilities`): it is there so that the three functions take the same arguments."""
    if not wo[2] > 0.0 or wi[2] == 0.0:
        return 0.0
    rough = is_rough(ax, ay)
    p_diffuse, p_spec, p_trans, p_coat = lobe_probabilities(metallic, transmission, clearcoat, specular,
                                                           layer_f0(eta, specular_color), thin_walled, min(wo[2], 1.0),
                                                           rough)
    pdf = 0.0
    if not thin_walled and p_trans > 0.0:
        pdf = p_trans * glass_value_and_pdf(ax, ay, eta, correlated, wo, wi)[1]
    ax = max(ax, MIN_ALPHA)
    ay = max(ay, MIN_ALPHA)
    if wi[2] < 0.0:
        if thin_walled and rough and p_trans > 0.0:
            mirrored = (wi[0], wi[1], -wi[2])
            pdf += p_trans * reflection_pdf(ax, ay, wo, half_vector(wo, mirrored))
        return pdf
    pdf += p_diffuse * wi[2] / math.pi
    h = half_vector(wo, wi)
    if rough and p_spec > 0.0:
        pdf += p_spec * reflection_pdf(ax, ay, wo, h)
    if p_coat > 0.0 and cc_alpha >= MIN_ALPHA:
        pdf += p_coat * reflection_pdf(cc_alpha, cc_alpha, wo, h)
    return pdf


@target.device
def principled_has_density(ax, ay, metallic, transmission, clearcoat, cc_alpha):
    """Whether some lobe is not a delta, so that light sampling serves the material: the diffuse
    base (unless metallic or transmission is 1), rough specular lobes or a rough coat."""
    return (metallic < 1.0 and transmission < 1.0) or is_rough(ax, ay) or (clearcoat > 0.0 and cc_alpha >= MIN_ALPHA)


@target.device
def principled_sample(ax, ay, metallic, transmission, clearcoat, cc_alpha, specular, specular_color, eta, thin_walled,
                      base, correlated, wo, u0, u1, u2):
    """(wi, weight, pdf, delta): a direction from the lobe u0 chooses (`lobe_probabilities`),
    u1 and u2 drawing its cosine direction or microfacet normal (and u0, rescaled within the
    lobe's share, the volumetric glass's choice between reflection and refraction).

    A non-delta lobe's sample has weight eval / pdf of the whole non-delta mixture (`principled_eval`
    over `principled_pdf`); a delta lobe's (mirror, straight through or a smooth refraction) has
    that lobe's value over its choice probability, pdf 0 and delta True. A failed sample (wo at
    or below the surface, a reflection that lands below it, a material that reflects nothing)
    is direction (0, 0, 0), weight black."""
    fail = (_ZERO, _ZERO, 0.0, False)
    if not wo[2] > 0.0:
        return fail
    cos_o = min(wo[2], 1.0)
    rough = is_rough(ax, ay)
    f0 = layer_f0(eta, specular_color)
    p_diffuse, p_spec, p_trans, p_coat = lobe_probabilities(metallic, transmission, clearcoat, specular, f0, thin_walled,
                                                           cos_o, rough)
    if p_diffuse + p_spec + p_trans + p_coat == 0.0:
        return fail
    wx = max(ax, MIN_ALPHA)
    wy = max(ay, MIN_ALPHA)
    mirror = (-wo[0], -wo[1], wo[2])
    # The lobe u0 falls in; a u0 past the rounded sum of the shares goes to the last lobe there is.
    lobe = 3 if p_coat > 0.0 else (2 if p_trans > 0.0 else (1 if p_spec > 0.0 else 0))
    if u0 < p_diffuse:
        lobe = 0
    elif u0 < p_diffuse + p_spec:
        lobe = 1
    elif u0 < p_diffuse + p_spec + p_trans:
        lobe = 2
    transmits = lobe == 2
    if lobe == 0:
        wi = cosine_direction(u1, u2)
    elif lobe == 1:
        if not rough:
            # The specular layer and the metal as one mirror: their Fresnel factors at wo.z.
            coat = 1.0 - clearcoat * schlick1(COAT_F0, cos_o)
            k = coat * coat / p_spec
            dielectric = (1.0 - metallic) * specular * (1.0 if thin_walled else 1.0 - transmission)
            layer = schlick(f0, cos_o)
            f_metal = schlick((base[0], base[1], base[2]), cos_o)
            weight = ((dielectric * layer[0] + metallic * f_metal[0]) * k, (dielectric * layer[1] + metallic * f_metal[1]) * k,
                      (dielectric * layer[2] + metallic * f_metal[2]) * k)
            return mirror, weight, 0.0, True
        wi = _reflect(wo, sample_visible_normal(wx, wy, wo, u1, u2))
    elif lobe == 2 and not thin_walled:
        # The rough dielectric chooses reflection or refraction with what is left of u0.
        v0 = min(max((u0 - p_diffuse - p_spec) / p_trans, 0.0), 1.0 - 1e-16)
        wi, w, _, delta = rough_dielectric_sample(ax, ay, eta, _WHITE, correlated, wo, v0, u1, u2)
        if wi[0] == 0.0 and wi[1] == 0.0 and wi[2] == 0.0:
            return fail
        if delta:
            cos_i = min(abs(wi[2]), 1.0)
            k = ((1.0 - metallic) * transmission * (1.0 - clearcoat * schlick1(COAT_F0, cos_o))
                 * (1.0 - clearcoat * schlick1(COAT_F0, cos_i)) / p_trans)
            if wi[2] < 0.0:
                return wi, (w[0] * k * base[0], w[1] * k * base[1], w[2] * k * base[2]), 0.0, True
            return wi, (w[0] * k, w[1] * k, w[2] * k), 0.0, True
        transmits = wi[2] < 0.0
    elif lobe == 2:
        if not rough:
            # Straight through both faces: the base's share at wo.z on the way in and on the way out.
            coat = 1.0 - clearcoat * schlick1(COAT_F0, cos_o)
            under_layer = 1.0 - layer_share(specular, f0, cos_o)
            k = (1.0 - metallic) * transmission * under_layer * under_layer * coat * coat / p_trans
            return (-wo[0], -wo[1], -wo[2]), (base[0] * k, base[1] * k, base[2] * k), 0.0, True
        wr = _reflect(wo, sample_visible_normal(wx, wy, wo, u1, u2))
        wi = (wr[0], wr[1], -wr[2])
    else:
        if cc_alpha < MIN_ALPHA:
            c = clearcoat * schlick1(COAT_F0, cos_o) / p_coat
            return mirror, (c, c, c), 0.0, True
        wi = _reflect(wo, sample_visible_normal(cc_alpha, cc_alpha, wo, u1, u2))
    if (wi[2] < 0.0) != transmits or wi[2] == 0.0:
        # A reflection off a microfacet that leaves below the surface: the surface shadows it.
        return fail
    pdf = principled_pdf(ax, ay, metallic, transmission, clearcoat, cc_alpha, specular, specular_color, eta, thin_walled,
                         base, correlated, wo, wi)
    if not pdf > 0.0:
        return fail
    f = principled_eval(ax, ay, metallic, transmission, clearcoat, cc_alpha, specular, specular_color, eta, thin_walled,
                        base, correlated, wo, wi)
    return wi, (f[0] / pdf, f[1] / pdf, f[2] / pdf), pdf, False


@target.device
def _reflect(wo, m):
    """wo mirrored about the unit microfacet normal m: 2 (wo . m) m - wo (unit for unit inputs)."""
    c = 2.0 * (wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2])
    return (c * m[0] - wo[0], c * m[1] - wo[1], c * m[2] - wo[2])
