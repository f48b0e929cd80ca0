"""Materials: their table, their flattening, and how each scatters a ray.

Lambertian, metal, dielectric and isotropic scatter; diffuse lights only emit (the path
tracer reads their texture as emission). Adding a material means a model in
`scenefmt/materials.py`, a type code, its parameters in `MATERIAL_F`, a case in `flatten`
and a case in `scatter`.

The direction of each material is a function of its random inputs (`lambertian_direction`,
`metal_direction`, `fresnel_dielectric`), so tests can check each on chosen inputs; `scatter`
draws those inputs and dispatches by kind.
"""

import math

from numba import njit

from .columns import Column, Layout
from .kernel_flags import DIELECTRICS
from .kernels.rng import uniform
from .kernels.vec import add, dot, madd, scale, unit

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


def flatten(model, texture: int) -> tuple[list, list]:
    """The (MATERIAL_I, MATERIAL_F) rows of a material model whose texture is row `texture`
    (`reads_uv` is filled in once every texture is known, see compile.py)."""
    ints = MATERIAL_I.row(kind=CODES[model.type], texture=texture)
    floats = MATERIAL_F.row(fuzz=getattr(model, "fuzz", 0.0), ior=getattr(model, "ior", 1.0))
    return ints, floats


def phase_function(texture: int) -> tuple[list, list]:
    """The rows of the isotropic material that scatters inside a medium of albedo `texture`."""
    return MATERIAL_I.row(kind=ISOTROPIC, texture=texture), MATERIAL_F.row(fuzz=0.0, ior=1.0)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
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


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def reflect(v, n):
    return madd(v, n, -2.0 * dot(v, n))


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def lambertian_direction(n_front, r):
    """The books' diffuse direction n + r for a uniform unit vector r: cosine-weighted about n.

    When r (nearly) cancels n the sum has no direction; the normal itself stands in for it.
    """
    out = add(n_front, r)
    if abs(out[0]) < 1e-8 and abs(out[1]) < 1e-8 and abs(out[2]) < 1e-8:
        out = n_front
    return out


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
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


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
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


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def scatter(mat_i, mat_f, mat, d, n_front, front_face, key, dim):
    """Direction of the ray scattered by material row `mat`, or (0, 0, 0) when it absorbs.

    `n_front` is the unit normal on the side the ray came from; `dim` is the first of the
    random dimensions this bounce may use.
    """
    kind = mat_i[mat, MAT_KIND]
    fuzz = mat_f[mat, MAT_FUZZ]
    ior = mat_f[mat, MAT_IOR]
    if kind == LAMBERTIAN:
        return lambertian_direction(n_front, random_unit_vector(key, dim))
    if kind == METAL:
        return metal_direction(d, n_front, fuzz, random_unit_vector(key, dim) if fuzz > 0.0 else (0.0, 0.0, 0.0))
    if DIELECTRICS and kind == DIELECTRIC:
        eta = 1.0 / ior if front_face else ior
        ud = unit(d)
        cos_i = min(max(-dot(ud, n_front), 0.0), 1.0)
        reflectance, cos_t = fresnel_dielectric(cos_i, eta)
        if uniform(key, dim + 8) < reflectance:
            return reflect(ud, n_front)
        # Snell's law in vector form: unit length for a unit ud.
        return madd(scale(ud, eta), n_front, eta * cos_i - cos_t)
    if kind == ISOTROPIC:
        return random_unit_vector(key, dim)
    return (0.0, 0.0, 0.0)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def is_zero(v):
    return v[0] == 0.0 and v[1] == 0.0 and v[2] == 0.0
