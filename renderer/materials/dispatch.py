"""The material interface the integrator calls: each function dispatches by kind to the
material's own functions (see the package's docstring for the contract)."""

from .. import target

from ..kernel_flags import CONDUCTORS, DIELECTRICS, EMITTERS, IMAGE, PARAMETER_TEXTURES, PHASE_HG, PLASTICS, PRINCIPLED, ROUGH_DIELECTRICS
from ..numerics.frame import frame_of, to_local, to_world
from ..numerics.rng import uniform
from ..numerics.vec import neg, unit
from ..textures import texture_value
from .books import (ISOTROPIC_DENSITY, dielectric_direction, lambertian_direction, lambertian_value, metal_direction,
                    random_unit_vector)
from .families import family_eval, family_has_density, family_pdf, family_sample
from .phase import hg_pdf, hg_sample
from .table import (CONDUCTOR, DIELECTRIC, DIFFUSE_LIGHT, ISOTROPIC, LAMBERTIAN, MAT_EMISSION, MAT_EMISSION_STRENGTH,
                    MAT_FUZZ, MAT_G, MAT_IOR, MAT_KIND, MAT_PARAM, MAT_PARAM_CHANNEL, MAT_PARAM_SQUARED, MAT_PARAM_TEXTURE,
                    MAT_ONE_SIDED, MAT_READS_UV, MAT_TEXTURE, METAL, SLOT_ALPHA_U, SLOT_ALPHA_V)
from .table import PRINCIPLED as PRINCIPLED_KIND  # (PRINCIPLED is the kernel flag here)

# Whether any kind with parameter slots can occur: without one, `material_at` reads none.
MICROFACETS = CONDUCTORS or ROUGH_DIELECTRICS or PLASTICS or PRINCIPLED
# The parameters of a row that has none: what `material_at` returns for the books' materials.
NO_PARAMETERS = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
# The tangent of a hit whose shape gives none: the materials then choose any frame about the normal.
NO_TANGENT = (0.0, 0.0, 0.0)


# --- the interface the integrator calls -------------------------------------------------------
#
# A material's value is split as colour x number: f(wo, wi) . cos = tint * value. The books'
# materials all have the colour of their texture as the tint (the albedo) and a scalar lobe; a
# material whose colour changes with direction returns its whole f . cos as the tint and 1.
# The split keeps the integrator's products in the order they had before this interface, so
# images are unchanged bit for bit.


@target.device
def reads_uv(mat_i, mat):
    """Whether material row `mat` needs the hit's (u, v): only image textures read it, and on a
    sphere it costs an arc cosine and an arc tangent."""
    return IMAGE and mat_i[mat, MAT_READS_UV] != 0


@target.device
def color_at(S, mat, u, v, p):
    """The colour of material row `mat` at a point of the flat scene S: its texture's value there,
    a surface's albedo or a light's emitted radiance. Evaluated once per hit and handed to
    `emitted`, `sample_bsdf` and `eval_bsdf`, as pbrt's materials evaluate their textures once
    into a BSDF."""
    return texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, S.mat_i[mat, MAT_TEXTURE], u, v, p)


@target.device
def parameter(S, mat, slot, u, v, p):
    """Parameter slot `slot` of material row `mat` at a hit: its constant, or the channel of its
    texture there times the slot's scale (squared when the texture holds a roughness), within
    [0, 1] as every slot's meaning requires (table.py lists them)."""
    value = S.mat_f[mat, MAT_PARAM + slot]
    if PARAMETER_TEXTURES:
        row = S.mat_i[mat, MAT_PARAM_TEXTURE + slot]
        if row >= 0:
            c = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, row, u, v, p)
            channel = S.mat_i[mat, MAT_PARAM_CHANNEL + slot]
            x = value * (c[0] if channel == 0 else c[1] if channel == 1 else c[2])
            x = min(max(x, 0.0), 1.0)
            if S.mat_i[mat, MAT_PARAM_SQUARED + slot] != 0:
                x = x * x
            return x
    return value


@target.device
def material_at(S, mat, u, v, p):
    """What material row `mat` is at a hit of the flat scene S: (colour, parameters), its colour
    from `color_at` and its eight parameter slots (roughness, metalness, ...: table.py) evaluated
    once, as pbrt's materials evaluate their textures into a BSDF. The books' materials have no
    parameters: they get NO_PARAMETERS without a read."""
    color = color_at(S, mat, u, v, p)
    if MICROFACETS and S.mat_i[mat, MAT_KIND] >= CONDUCTOR:
        params = (parameter(S, mat, 0, u, v, p), parameter(S, mat, 1, u, v, p), parameter(S, mat, 2, u, v, p),
                  parameter(S, mat, 3, u, v, p), parameter(S, mat, 4, u, v, p), parameter(S, mat, 5, u, v, p),
                  parameter(S, mat, 6, u, v, p), parameter(S, mat, 7, u, v, p))
    else:
        params = NO_PARAMETERS
    return color, params


@target.device
def emits(mat_i, mat):
    """Whether material row `mat` emits light (then `emitted_at` says how much): the books'
    diffuse light, and a principled material whose row names an emission texture (table.py
    leaves it -1 for a black emission). The path tracer ends a path at an emitter unless it
    also `scatters`."""
    return EMITTERS and (mat_i[mat, MAT_KIND] == DIFFUSE_LIGHT
                         or (PRINCIPLED and mat_i[mat, MAT_KIND] == PRINCIPLED_KIND and mat_i[mat, MAT_EMISSION] >= 0))


@target.device
def scatters(mat_i, mat):
    """Whether material row `mat` scatters the light that reaches it. Every material does but the
    books' diffuse light, which absorbs it all: the path tracer ends a path at an emitter that
    does not scatter and goes on from one that does (a principled surface with an emission)."""
    return mat_i[mat, MAT_KIND] != DIFFUSE_LIGHT


@target.kernel
def emitting_rows(mat_i, out):
    """out[mat] = whether material row `mat` emits, as `emits` answers it: the flattening of the
    lights asks the interface, so an emitting material of a new kind is a light at once."""
    for mat in range(mat_i.shape[0]):
        out[mat] = emits(mat_i, mat)


@target.device
def emission_source(mat_i, mat_f, mat):
    """(texture row, factor) of what material row `mat` (one that `emits`) emits: its radiance at
    a point is that texture's value there times the factor, from both sides. One texture, so that
    the light category's sampler and power measure inline one texture lookup, not two (a second
    one cost every scene with a lamp 9 s of compiling)."""
    if PRINCIPLED and mat_i[mat, MAT_KIND] == PRINCIPLED_KIND and mat_i[mat, MAT_EMISSION] >= 0:
        return mat_i[mat, MAT_EMISSION], mat_f[mat, MAT_EMISSION_STRENGTH]
    return mat_i[mat, MAT_TEXTURE], 1.0


@target.device
def emitted_at(S, mat, color, u, v, p, front_face):
    """Radiance that material row `mat` (one that `emits`) sends back along a ray that hit it at
    p, (u, v), its colour there being `color` (`material_at`): for a principled material its
    emission texture there times its strength (KHR_materials_emissive_strength), from both
    sides as the books' light (its row is never `one_sided`, so the light category samples it
    two-sided too); for the others `emitted` of their colour, which asks the side."""
    if PRINCIPLED and S.mat_i[mat, MAT_KIND] == PRINCIPLED_KIND and S.mat_i[mat, MAT_EMISSION] >= 0:
        e = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, S.mat_i[mat, MAT_EMISSION], u, v, p)
        k = S.mat_f[mat, MAT_EMISSION_STRENGTH]
        return (e[0] * k, e[1] * k, e[2] * k)
    return emitted(S.mat_i, S.mat_f, mat, color, front_face)


@target.device
def emitted(mat_i, mat_f, mat, color, front_face):
    """Radiance that material row `mat` (one that `emits`) sends back along the ray that hit it.

    The books' diffuse light emits its colour from both sides; a one-sided one (`sides: front`,
    column `one_sided`) only from the face its normal points out of: a ray that hit its back
    (`front_face` False) gets black. The light category's sampler refuses the same points
    (lights.sample_area_light), so both ways of finding a light see the same emission.
    """
    if not front_face and one_sided(mat_i, mat):
        return (0.0, 0.0, 0.0)
    return color


@target.device
def one_sided(mat_i, mat):
    """Whether material row `mat` (one that `emits`) emits from its front face only: the face
    the shape's normal points out of (`sides: front`). Its back is black to every ray, and the
    light category samples no point of it from behind."""
    return mat_i[mat, MAT_ONE_SIDED] != 0


@target.device
def sample_bsdf(mat_i, mat_f, mat, color, params, d, n_front, tangent, front_face, key, dim):
    """Scatter the ray of direction d that hit material row `mat` (colour `color` and parameters
    `params` there, see `material_at`): (direction, weight, pdf, delta).

    - direction: of the scattered ray, not necessarily of unit length (the books' lambertian
      n + r is the next ray's direction as it is); (0, 0, 0) when the material absorbs the ray
      (a light, which only emits).
    - weight: the RGB factor of the path's throughput, f . cos / pdf, the albedo included. For
      the books' materials it is exactly the colour: f . cos and the pdf cancel analytically
      (cosine sampling for lambertian, the phase function for isotropic, the chosen lobe of a
      mirror or a dielectric), and are not divided, so rounding never changes it.
    - pdf: the density of the direction per solid angle (of its unit vector); 0 for a delta lobe.
    - delta: the lobe has no density, so it is never light-sampled and a light it finds counts
      in full. Mirrors and dielectrics are deltas. So is the books' fuzzed metal: it moves the
      mirror direction within a ball of radius `fuzz`, whose density over directions has no
      closed form; treating it as a delta keeps its images as they were.

    `n_front` is the unit shading normal on the side the ray came from; `tangent` a unit vector
    along the surface's dp/du, or NO_TANGENT (the frame of an anisotropic lobe); `front_face`
    whether that side is the outward one; `dim` the first random dimension this bounce may use
    (up to dim + 8).
    """
    zero = (0.0, 0.0, 0.0)
    kind = mat_i[mat, MAT_KIND]
    if kind == LAMBERTIAN:
        wi = lambertian_direction(n_front, random_unit_vector(key, dim))
        return wi, color, lambertian_value(n_front, unit(wi)), False
    if kind == METAL:
        fuzz = mat_f[mat, MAT_FUZZ]
        r = random_unit_vector(key, dim) if fuzz > 0.0 else zero
        return metal_direction(d, n_front, fuzz, r), color, 0.0, True
    if DIELECTRICS and kind == DIELECTRIC:
        return dielectric_direction(d, n_front, front_face, mat_f[mat, MAT_IOR], uniform(key, dim + 8)), color, 0.0, True
    if kind == ISOTROPIC:
        if PHASE_HG and mat_f[mat, MAT_G] != 0.0:
            # The sample's value over its density is exactly 1: the albedo is the whole weight.
            wi, pdf = hg_sample(mat_f[mat, MAT_G], unit(d), uniform(key, dim), uniform(key, dim + 1))
            return wi, color, pdf, False
        return random_unit_vector(key, dim), color, ISOTROPIC_DENSITY, False
    if MICROFACETS and kind >= CONDUCTOR:
        s, t = frame_of(n_front, tangent)
        wo = to_local(s, t, n_front, neg(unit(d)))
        wi, weight, pdf, delta = family_sample(kind, mat_i, mat_f, mat, color, params, front_face, wo, uniform(key, dim),
                                               uniform(key, dim + 1), uniform(key, dim + 2))
        if pdf == 0.0 and not delta:
            return zero, zero, 0.0, False
        return to_world(s, t, n_front, wi), weight, pdf, delta
    return zero, zero, 0.0, True


@target.device
def is_anisotropic(mat_i, mat, params):
    """Whether the lobe of material row `mat` at this hit is stretched along the surface (two GGX
    widths): it is then laid along the surface's dp/du, which the caller passes as `tangent`."""
    return MICROFACETS and mat_i[mat, MAT_KIND] >= CONDUCTOR and params[SLOT_ALPHA_U] != params[SLOT_ALPHA_V]


@target.device
def has_density(mat_i, mat, params):
    """Whether material row `mat` (parameters `params` at the hit) has a part with a density, which
    light sampling serves. Asked of the material, not of the lobe `sample_bsdf` chose: a material
    that mixes a delta lobe with others (a smooth coat over a diffuse base) must have its light
    sampled whichever lobe the bounce took, or the light estimate would miss the times the delta
    lobe was chosen. For the books' materials it is exactly `not delta`."""
    kind = mat_i[mat, MAT_KIND]
    if kind == LAMBERTIAN or kind == ISOTROPIC:
        return True
    if MICROFACETS and kind >= CONDUCTOR:
        return family_has_density(kind, params)
    return False


@target.device
def eval_bsdf(mat_i, mat_f, mat, color, params, d, n_front, tangent, front_face, wi):
    """f . cos of material row `mat` for light arriving from unit direction wi and leaving
    against d, as (tint, value) with f . cos = tint * value (see above); for a medium's
    material the phase function's value, which has no cosine. Non-negative, f reciprocal
    (unchanged when the light's way is reversed); 0 for a delta lobe, which no given pair of
    directions meets."""
    kind = mat_i[mat, MAT_KIND]
    if kind == LAMBERTIAN:
        return color, lambertian_value(n_front, wi)
    if kind == ISOTROPIC:
        if PHASE_HG and mat_f[mat, MAT_G] != 0.0:
            return color, hg_pdf(mat_f[mat, MAT_G], unit(d), wi)
        return color, ISOTROPIC_DENSITY
    if MICROFACETS and kind >= CONDUCTOR:
        # The whole of f . cos as the tint, and 1 (or 0 where it is black, which spares the
        # integrator a shadow ray).
        s, t = frame_of(n_front, tangent)
        f = family_eval(kind, mat_i, mat_f, mat, color, params, front_face, to_local(s, t, n_front, neg(unit(d))),
                        to_local(s, t, n_front, wi))
        return f, 1.0 if (f[0] > 0.0 or f[1] > 0.0 or f[2] > 0.0) else 0.0
    return color, 0.0


@target.device
def pdf_bsdf(mat_i, mat_f, mat, params, d, n_front, tangent, front_face, wi):
    """The density per solid angle with which `sample_bsdf` gives unit direction wi for a ray
    of direction d; 0 for a delta lobe."""
    kind = mat_i[mat, MAT_KIND]
    if kind == LAMBERTIAN:
        return lambertian_value(n_front, wi)
    if kind == ISOTROPIC:
        if PHASE_HG and mat_f[mat, MAT_G] != 0.0:
            return hg_pdf(mat_f[mat, MAT_G], unit(d), wi)
        return ISOTROPIC_DENSITY
    if MICROFACETS and kind >= CONDUCTOR:
        s, t = frame_of(n_front, tangent)
        return family_pdf(kind, mat_i, mat_f, mat, params, front_face, to_local(s, t, n_front, neg(unit(d))),
                          to_local(s, t, n_front, wi))
    return 0.0


@target.device
def is_zero(v):
    return v[0] == 0.0 and v[1] == 0.0 and v[2] == 0.0
