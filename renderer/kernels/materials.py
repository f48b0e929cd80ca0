"""Scattering: lambertian, metal, dielectric and isotropic; diffuse lights only emit."""

import math

from numba import njit

from ..layout import DIELECTRIC, ISOTROPIC, LAMBERTIAN, METAL
from .features import DIELECTRICS
from .rng import uniform
from .vec import add, dot, madd, scale, unit


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
def schlick(cosine, ratio):
    r0 = (1.0 - ratio) / (1.0 + ratio)
    r0 = r0 * r0
    return r0 + (1.0 - r0) * (1.0 - cosine) ** 5


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def scatter(kind, fuzz, ior, d, n_front, front_face, key, dim):
    """Direction of the scattered ray, or (0, 0, 0) when the surface absorbs it.

    `n_front` is the unit normal on the side the ray came from; `dim` is the first of the
    random dimensions this bounce may use.
    """
    if kind == LAMBERTIAN:
        out = add(n_front, random_unit_vector(key, dim))
        if abs(out[0]) < 1e-8 and abs(out[1]) < 1e-8 and abs(out[2]) < 1e-8:
            out = n_front  # the random vector cancelled the normal
        return out
    if kind == METAL:
        out = unit(reflect(d, n_front))
        if fuzz > 0.0:
            out = madd(out, random_unit_vector(key, dim), fuzz)
        if dot(out, n_front) <= 0.0:
            return (0.0, 0.0, 0.0)  # fuzzed below the surface: absorbed
        return out
    if DIELECTRICS and kind == DIELECTRIC:
        ratio = 1.0 / ior if front_face else ior
        ud = unit(d)
        cos_theta = min(-dot(ud, n_front), 1.0)
        sin_theta = math.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
        if ratio * sin_theta > 1.0 or schlick(cos_theta, ratio) > uniform(key, dim + 8):
            return reflect(ud, n_front)
        perp = scale(madd(ud, n_front, cos_theta), ratio)
        parallel = scale(n_front, -math.sqrt(abs(1.0 - dot(perp, perp))))
        return add(perp, parallel)
    if kind == ISOTROPIC:
        return random_unit_vector(key, dim)
    return (0.0, 0.0, 0.0)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def is_zero(v):
    return v[0] == 0.0 and v[1] == 0.0 and v[2] == 0.0


