"""Materials: their table, their flattening, and what each answers the path tracer.

Every material answers the same questions, in the spirit of pbrt's BxDF interface, and the
integrator (`tracing/integrator.trace`) asks only these and names no material:

- `color_at`: its texture's colour at a hit (the albedo, or a light's radiance), evaluated once;
- `emits` / `emitted`: whether it emits, and the radiance it sends back along the ray;
- `sample_bsdf`: a scattered direction, the throughput weight f . cos / pdf, the density per
  solid angle, and whether the lobe is a delta (no density: never light-sampled);
- `eval_bsdf`: f . cos for a given pair of directions, as colour times number;
- `pdf_bsdf`: the density `sample_bsdf` gives a direction, for multiple importance sampling;
- `reads_uv`: whether the hit's (u, v) is needed at all.

Each dispatches by kind to the material's own functions below. Lambertian and isotropic have a
density, so light sampling and MIS serve them; metal and dielectric are deltas; a diffuse
light emits and absorbs. Adding a material means a model in `scenefmt/materials.py`, a type
code, its parameters in `MATERIAL_F`, a case in `material_rows` and a case in each of the functions
above that it answers differently from "black, delta".

The direction of each material is a function of its random inputs (`lambertian_direction`,
`metal_direction`, `dielectric_direction`), so tests can check each on chosen inputs;
`sample_bsdf` draws those inputs.
"""

import math

from . import target

from .columns import Column, Layout
from .kernel_flags import DIELECTRICS, EMITTERS, IMAGE
from .numerics.rng import uniform
from .numerics.vec import add, dot, madd, scale, unit
from .textures import texture_value

# Type codes.
LAMBERTIAN = 0
METAL = 1
DIELECTRIC = 2
DIFFUSE_LIGHT = 3
ISOTROPIC = 4
CODES = {"lambertian": LAMBERTIAN, "metal": METAL, "dielectric": DIELECTRIC, "diffuse_light": DIFFUSE_LIGHT,
         "isotropic": ISOTROPIC}

MATERIAL_I = Layout("mat_i", "int32", [
    Column("kind", 1, "type code: LAMBERTIAN, METAL, DIELECTRIC, DIFFUSE_LIGHT or ISOTROPIC"),
    Column("texture", 1, "texture row of the albedo (emission for a light); a solid white one for a dielectric"),
    Column("reads_uv", 1, "1 if that texture reads surface (u, v): the kernels compute (u, v) only then"),
])
MATERIAL_F = Layout("mat_f", "float64", [
    Column("fuzz", 1, "metal: radius of the sphere the mirror direction is moved within (0 = a perfect mirror)"),
    Column("ior", 1, "dielectric: index of refraction, inside over outside"),
])
MAT_KIND, MAT_TEXTURE, MAT_READS_UV = MATERIAL_I.offsets("kind", "texture", "reads_uv")
MAT_FUZZ, MAT_IOR = MATERIAL_F.offsets("fuzz", "ior")


def material_rows(model, texture: int) -> tuple[list, list]:
    """The (MATERIAL_I, MATERIAL_F) rows of a material model whose texture is row `texture`
    (`reads_uv` is filled in once every texture is known, see compile.py)."""
    ints = MATERIAL_I.row(kind=CODES[model.type], texture=texture)
    floats = MATERIAL_F.row(fuzz=getattr(model, "fuzz", 0.0), ior=getattr(model, "ior", 1.0))
    return ints, floats


def phase_function(texture: int) -> tuple[list, list]:
    """The rows of the isotropic material that scatters inside a medium of albedo `texture`."""
    return MATERIAL_I.row(kind=ISOTROPIC, texture=texture), MATERIAL_F.row(fuzz=0.0, ior=1.0)


@target.device
def random_unit_vector(key, dim):
    """Uniform on the sphere (Marsaglia 1972): a point in the unit disk lifted to the sphere.

    Up to three tries of dimensions (dim, dim+1), (dim+2, dim+3), (dim+4, dim+5), which avoids
    sin and cos on the common path; the rare fourth case (1% of calls) uses z and an azimuth.
    """
    for k in range(3):
        x = 2.0 * uniform(key, dim + 2 * k) - 1.0
        y = 2.0 * uniform(key, dim + 2 * k + 1) - 1.0
        s = x * x + y * y
        if 0.0 < s < 1.0:
            f = 2.0 * math.sqrt(1.0 - s)
            return (x * f, y * f, 1.0 - 2.0 * s)
    z = 1.0 - 2.0 * uniform(key, dim + 6)
    phi = 2.0 * math.pi * uniform(key, dim + 7)
    r = math.sqrt(max(0.0, 1.0 - z * z))
    return (r * math.cos(phi), r * math.sin(phi), z)


@target.device
def reflect(v, n):
    return madd(v, n, -2.0 * dot(v, n))


@target.device
def lambertian_direction(n_front, r):
    """The books' diffuse direction n + r for a uniform unit vector r: cosine-weighted about n.

    When r (nearly) cancels n the sum has no direction; the normal itself stands in for it.
    """
    out = add(n_front, r)
    if abs(out[0]) < 1e-8 and abs(out[1]) < 1e-8 and abs(out[2]) < 1e-8:
        out = n_front
    return out


@target.device
def metal_direction(d, n_front, fuzz, r):
    """The mirror direction of d moved by fuzz * r (r a uniform unit vector), never below the surface.

    A fuzzed direction that points below the surface is mirrored about the tangent plane (its
    normal component changes sign) rather than absorbed as in the books, so a metal of albedo 1
    reflects every ray whatever its fuzz: energy is conserved. In the rare case that the result
    lies in the tangent plane (or is zero) the unfuzzed mirror direction is used.
    """
    mirror = unit(reflect(d, n_front))
    out = madd(mirror, r, fuzz)
    below = dot(out, n_front)
    if below < 0.0:
        out = madd(out, n_front, -2.0 * below)
    if not dot(out, n_front) > 0.0:
        out = mirror
    return out


@target.device
def fresnel_dielectric(cos_i, eta):
    """(reflectance, cosine of the refracted angle) at a smooth dielectric interface.

    `cos_i` in [0, 1] is the cosine of the angle of incidence, `eta` the index on the incident
    side over the index on the other. The exact unpolarised Fresnel equations, not Schlick's
    approximation: they give 0 when eta = 1 (no interface, nothing reflects) and 1 under total
    internal reflection, which is returned with a refracted cosine of 0.
    """
    sin2_t = eta * eta * max(0.0, 1.0 - cos_i * cos_i)
    if sin2_t >= 1.0:
        return 1.0, 0.0
    cos_t = math.sqrt(1.0 - sin2_t)
    # Both denominators are > 0 here: cos_i = cos_t = 0 would need sin2_t = eta^2 >= 1.
    a = eta * cos_i
    rs = (a - cos_t) / (a + cos_t)
    rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return 0.5 * (rs * rs + rp * rp), cos_t


@target.device
def lambertian_value(n_front, wi):
    """f . cos of the lambertian lobe per unit albedo for a unit direction wi: cos / pi above the
    surface, 0 below. It is also the cosine sampler's density, so the two are one expression."""
    return max(0.0, dot(wi, n_front)) / math.pi


# The isotropic phase function's value, and its sampler's density: uniform over the sphere.
ISOTROPIC_DENSITY = 1.0 / (4.0 * math.pi)


@target.device
def dielectric_direction(d, n_front, front_face, ior, u):
    """Reflected or refracted direction of d at a smooth dielectric, reflected with the Fresnel
    probability (u uniform in [0, 1) decides)."""
    eta = 1.0 / ior if front_face else ior
    ud = unit(d)
    cos_i = min(max(-dot(ud, n_front), 0.0), 1.0)
    reflectance, cos_t = fresnel_dielectric(cos_i, eta)
    if u < reflectance:
        return reflect(ud, n_front)
    # Snell's law in vector form: unit length for a unit ud.
    return madd(scale(ud, eta), n_front, eta * cos_i - cos_t)


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
