"""Scattering: lambertian, metal, dielectric and isotropic; diffuse lights only emit."""

import math

from numba import njit

from ..layout import DIELECTRIC, ISOTROPIC, LAMBERTIAN, METAL
from .rng import uniform
from .vec import add, dot, madd, scale, unit


@njit(inline="always", cache=True, error_model="numpy")
def random_unit_vector(key, dim):
    """Uniform on the sphere from two numbers: z uniform in [-1, 1], azimuth uniform."""
    z = 1.0 - 2.0 * uniform(key, dim)
    phi = 2.0 * math.pi * uniform(key, dim + 1)
    r = math.sqrt(max(0.0, 1.0 - z * z))
    return (r * math.cos(phi), r * math.sin(phi), z)


@njit(inline="always", cache=True, error_model="numpy")
def reflect(v, n):
    return madd(v, n, -2.0 * dot(v, n))


@njit(inline="always", cache=True, error_model="numpy")
def schlick(cosine, ratio):
    r0 = (1.0 - ratio) / (1.0 + ratio)
    r0 = r0 * r0
    return r0 + (1.0 - r0) * (1.0 - cosine) ** 5


@njit(inline="always", cache=True, error_model="numpy")
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
    if kind == DIELECTRIC:
        ratio = 1.0 / ior if front_face else ior
        ud = unit(d)
        cos_theta = min(-dot(ud, n_front), 1.0)
        sin_theta = math.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
        if ratio * sin_theta > 1.0 or schlick(cos_theta, ratio) > uniform(key, dim):
            return reflect(ud, n_front)
        perp = scale(madd(ud, n_front, cos_theta), ratio)
        parallel = scale(n_front, -math.sqrt(abs(1.0 - dot(perp, perp))))
        return add(perp, parallel)
    if kind == ISOTROPIC:
        return random_unit_vector(key, dim)
    return (0.0, 0.0, 0.0)


@njit(inline="always", cache=True, error_model="numpy")
def is_zero(v):
    return v[0] == 0.0 and v[1] == 0.0 and v[2] == 0.0


