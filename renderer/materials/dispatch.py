"""The material interface the integrator calls: each function dispatches by kind to the
material's own functions (see the package's docstring for the contract)."""

from .. import target

from ..kernel_flags import DIELECTRICS, EMITTERS, IMAGE
from ..numerics.rng import uniform
from ..numerics.vec import unit
from ..textures import texture_value
from .books import (ISOTROPIC_DENSITY, dielectric_direction, lambertian_direction, lambertian_value, metal_direction,
                    random_unit_vector)
from .table import DIELECTRIC, DIFFUSE_LIGHT, ISOTROPIC, LAMBERTIAN, METAL, MAT_FUZZ, MAT_IOR, MAT_KIND, MAT_READS_UV, MAT_TEXTURE


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
def emits(mat_i, mat):
    """Whether material row `mat` emits light (then `emitted` says how much). The path tracer
    ends a path at an emitter: the books' lights absorb all that reaches them (their
    `sample_bsdf` gives no direction), and asking was slower."""
    return EMITTERS and mat_i[mat, MAT_KIND] == DIFFUSE_LIGHT


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
def emitted(mat_i, mat_f, mat, color, front_face):
    """Radiance that material row `mat` (one that `emits`) sends back along the ray that hit it.

    The books' diffuse light emits its colour from both sides, so `front_face` is not read; a
    one-sided emitter would return black for a ray that hit its back.
    """
    return color


@target.device
def sample_bsdf(mat_i, mat_f, mat, color, d, n_front, front_face, key, dim):
    """Scatter the ray of direction d that hit material row `mat` (colour `color` there, see
    `color_at`): (direction, weight, pdf, delta).

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

    `n_front` is the unit normal on the side the ray came from; `front_face` whether that is
    the outward side; `dim` the first random dimension this bounce may use (up to dim + 8).
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
        return random_unit_vector(key, dim), color, ISOTROPIC_DENSITY, False
    return zero, zero, 0.0, True


@target.device
def eval_bsdf(mat_i, mat_f, mat, color, d, n_front, wi):
    """f . cos of material row `mat` for light arriving from unit direction wi and leaving
    against d, as (tint, value) with f . cos = tint * value (see above); for a medium's
    material the phase function's value, which has no cosine. Non-negative, f reciprocal
    (unchanged when the light's way is reversed); 0 for a delta lobe, which no given pair of
    directions meets."""
    kind = mat_i[mat, MAT_KIND]
    if kind == LAMBERTIAN:
        return color, lambertian_value(n_front, wi)
    if kind == ISOTROPIC:
        return color, ISOTROPIC_DENSITY
    return color, 0.0


@target.device
def pdf_bsdf(mat_i, mat_f, mat, d, n_front, wi):
    """The density per solid angle with which `sample_bsdf` gives unit direction wi for a ray
    of direction d; 0 for a delta lobe."""
    kind = mat_i[mat, MAT_KIND]
    if kind == LAMBERTIAN:
        return lambertian_value(n_front, wi)
    if kind == ISOTROPIC:
        return ISOTROPIC_DENSITY
    return 0.0


@target.device
def is_zero(v):
    return v[0] == 0.0 and v[1] == 0.0 and v[2] == 0.0
