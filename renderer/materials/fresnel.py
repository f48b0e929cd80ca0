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


@target.device
def _conductor_channel(cos_i, eta, k):
    """The exact unpolarised reflectance of one channel at a conductor of complex relative index
    eta + i k, for cos_i in [0, 1]. The closed form of the Fresnel equations with a complex
    index split into real arithmetic (as in Mitsuba 3's fresnel_conductor): a^2 + b^2 is
    |n^2 - sin^2|, `a` the real part of sqrt(n^2 - sin^2)."""
    c2 = cos_i * cos_i
    s2 = 1.0 - c2
    t = eta * eta - k * k - s2
    a2pb2 = math.sqrt(max(0.0, t * t + 4.0 * eta * eta * k * k))
    a = math.sqrt(max(0.0, 0.5 * (a2pb2 + t)))
    term1 = a2pb2 + c2
    term2 = 2.0 * cos_i * a
    den_s = term1 + term2
    if den_s <= 0.0:
        # Only for eta = k = 0 at grazing incidence: no physical material; reflect all.
        return 1.0
    rs = (term1 - term2) / den_s
    term3 = a2pb2 * c2 + s2 * s2
    term4 = term2 * s2
    den_p = term3 + term4
    rp = rs * (term3 - term4) / den_p if den_p > 0.0 else rs
    # Clamped: where the index is (nearly) 1 + 0i the differences above round to about -1e-17.
    return min(1.0, max(0.0, 0.5 * (rs + rp)))


@target.device
def fresnel_conductor(cos_i, eta_rgb, k_rgb):
    """RGB reflectance of a smooth conductor, exact (no Schlick): `eta_rgb` and `k_rgb` the real
    and imaginary parts of the metal's index relative to the incident medium's, per channel.
    `cos_i` is clamped to [0, 1]; at grazing incidence (0) every channel reflects 1."""
    c = min(1.0, max(0.0, cos_i))
    return (_conductor_channel(c, eta_rgb[0], k_rgb[0]),
            _conductor_channel(c, eta_rgb[1], k_rgb[1]),
            _conductor_channel(c, eta_rgb[2], k_rgb[2]))


@target.device
def schlick(f0_rgb, cos):
    """Schlick's approximation F0 + (1 - F0)(1 - cos)^5 per channel, `cos` clamped to [0, 1]: the
    reflectance at normal incidence raised to 1 at grazing incidence."""
    c = 1.0 - min(1.0, max(0.0, cos))
    c2 = c * c
    w = c2 * c2 * c
    return (f0_rgb[0] + (1.0 - f0_rgb[0]) * w,
            f0_rgb[1] + (1.0 - f0_rgb[1]) * w,
            f0_rgb[2] + (1.0 - f0_rgb[2]) * w)
