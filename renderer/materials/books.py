"""The books' materials: lambertian, metal (with fuzz), dielectric and the isotropic phase
function, each as a function of its random inputs so that tests can check it on chosen inputs."""

import math

from .. import target

from ..numerics.rng import uniform
from ..numerics.vec import add, dot, madd, scale, unit
from .fresnel import fresnel_dielectric


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
