"""Fresnel reflectance at smooth interfaces."""

import math

from .. import target


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
