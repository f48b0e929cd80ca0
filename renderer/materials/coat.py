"""The dielectric coat of a plastic: what it reflects, lets through, and sends back down.

A plastic (`plastic.py`) is a diffuse base under a clear coat of relative index eta = index of
the coat over that of the outside (eta > 1 for a real coat; 1 is no coat at all). Light that
reaches the base crossed the coat once on its way in and must cross it again on its way out;
the part the coat's inner side reflects back goes down to the base again, bounces, and so on.
Summing those bounces gives the base's albedo a / (1 - R_in a) (the `nonlinear` form) or, to
keep a texture's colours as they were painted, a / (1 - R_in), where R_in is the coat's
reflectance for light arriving from inside, averaged over a cosine-weighted hemisphere (the base
scatters diffusely). As in Mitsuba 3:

- a smooth coat: its Fresnel reflectance for a direction (`coat_reflectance`), and for R_in
  `inner_diffuse_reflectance`, exact (tabulated finely over the ior, see coat_tables.py) where
  Mitsuba uses a polynomial fit (0.08% high at ior 1.5, so that its white plastic returns 1.001
  of the light); 0 without a coat;
- a rough (GGX) coat: its transmittance per direction and R_in precomputed by integrating over
  the visible normals (`coat_tables.py`, read here from `coat_table_data.py`) and interpolated
  linearly in (ior, roughness = sqrt(alpha), cosine). The tables are isotropic: an anisotropic
  coat is looked up at alpha = sqrt(alpha_x alpha_y). Outside the tables' range (ior 1 to 3,
  alpha up to 1) the nearest entry is used.
"""

import math

from .. import target

from .coat_table_data import (COSINE_COUNT, COSINE_FIRST, COSINE_STEP, INTERNAL_REFLECTANCE, IOR_COUNT, IOR_FIRST,
                              IOR_STEP, ROUGHNESS_COUNT, ROUGHNESS_FIRST, ROUGHNESS_STEP, SMOOTH_INTERNAL_REFLECTANCE,
                              SMOOTH_IOR_COUNT, SMOOTH_IOR_FIRST, SMOOTH_IOR_STEP, TRANSMITTANCE)
from .fresnel import fresnel_dielectric


@target.device
def _cell(x, first, step, count):
    """(index, fraction) of x on a grid of `count` points first + k step, for linear
    interpolation between points index and index + 1; x outside is clamped to the ends."""
    t = (x - first) / step
    if not t > 0.0:
        return 0, 0.0
    if t >= count - 1:
        return count - 2, 1.0
    i = int(t)
    return i, t - i


@target.device
def coat_reflectance(cos_o, eta):
    """Fresnel reflectance of a smooth coat of relative index eta (coat over outside) for light
    from outside at cosine cos_o (clamped to [0, 1]). 0 for eta = 1, where there is no interface
    (even at grazing incidence, where the Fresnel equations are 0 / 0)."""
    if eta == 1.0:
        return 0.0
    return fresnel_dielectric(min(1.0, max(0.0, cos_o)), 1.0 / eta)[0]


@target.device
def inner_diffuse_reflectance(eta):
    """A smooth coat's reflectance for light from inside, averaged over a cosine-weighted
    hemisphere (total internal reflection included), for eta >= 1: the exact values tabulated
    every 0.01 of the ior up to 5, interpolated linearly (the function is concave, so between
    grid points this errs low, by less than 1e-4: a white plastic never returns more than it
    receives), clamped above 5 and 0 at eta = 1. For a coat less dense than the outside
    (eta < 1, no total internal reflection inside) Mitsuba's fit, d'Eon and Irving (2011), a
    polynomial in eta accurate to 0.2%."""
    if eta == 1.0:
        return 0.0
    if eta < 1.0:
        return ((((-1.36881 * eta + 4.98554) * eta - 7.80989) * eta + 6.75335) * eta - 3.4793) * eta + 0.919317
    i, f = _cell(eta, SMOOTH_IOR_FIRST, SMOOTH_IOR_STEP, SMOOTH_IOR_COUNT)
    return (1.0 - f) * SMOOTH_INTERNAL_REFLECTANCE[i] + f * SMOOTH_INTERNAL_REFLECTANCE[i + 1]


@target.device
def coat_transmittance(eta, alpha, cos_o):
    """Fraction of light from outside at cosine cos_o that a GGX coat of width alpha and relative
    index eta lets through, not masked on its way in (see coat_tables.transmittance): the table
    interpolated trilinearly. 1 - it is what the coat's specular lobe reflects, plus the
    single-scattering loss."""
    i, fi = _cell(eta, IOR_FIRST, IOR_STEP, IOR_COUNT)
    j, fj = _cell(math.sqrt(max(0.0, alpha)), ROUGHNESS_FIRST, ROUGHNESS_STEP, ROUGHNESS_COUNT)
    k, fk = _cell(cos_o, COSINE_FIRST, COSINE_STEP, COSINE_COUNT)
    total = 0.0
    for di in range(2):
        wi = fi if di else 1.0 - fi
        for dj in range(2):
            wj = fj if dj else 1.0 - fj
            row = TRANSMITTANCE[i + di, j + dj]
            total += wi * wj * ((1.0 - fk) * row[k] + fk * row[k + 1])
    return total


@target.device
def coat_internal_reflectance(eta, alpha):
    """R_in of a GGX coat: its reflectance seen from inside averaged over a cosine-weighted
    hemisphere (see coat_tables.internal_reflectance), interpolated bilinearly."""
    i, fi = _cell(eta, IOR_FIRST, IOR_STEP, IOR_COUNT)
    j, fj = _cell(math.sqrt(max(0.0, alpha)), ROUGHNESS_FIRST, ROUGHNESS_STEP, ROUGHNESS_COUNT)
    r = INTERNAL_REFLECTANCE
    return ((1.0 - fi) * ((1.0 - fj) * r[i, j] + fj * r[i, j + 1])
            + fi * ((1.0 - fj) * r[i + 1, j] + fj * r[i + 1, j + 1]))
