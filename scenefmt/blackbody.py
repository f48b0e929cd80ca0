"""The colour of a black body at a temperature, for `temperature:` on any emitter.

`temperature_rgb(kelvin)` is the linear sRGB colour (Rec. 709 primaries, D65 white, the
renderer's colour space) of Planck's radiator at that temperature, scaled so that its luminance
(0.2126 R + 0.7152 G + 0.0722 B, which is CIE Y) is 1. An emitter given a temperature and an
amount (a radiance, an intensity, a power, an irradiance) sends that amount as luminance in this
colour.

How: Planck's spectral radiance is integrated against the CIE 1931 2-degree colour matching
functions from 360 to 830 nm in 1 nm steps, giving XYZ; XYZ goes to linear sRGB by the standard
matrix (IEC 61966-2-1). The matching functions are not tabulated here but taken from the
multi-lobe analytic fit of Wyman, Sloan and Shirley, "Simple Analytic Approximations to the CIE
XYZ Color Matching Functions" (JCGT 2013): each function is a sum of two or three piecewise
Gaussians. The chromaticities of black bodies it gives agree with published values of the
Planckian locus to within 0.002 in x and y from 2500 K up, 0.0035 below
(tests/scenefmt/test_blackbody.py). A black body below about 1900 K, or far above 6500 K, lies outside the sRGB gamut
(too red, or too blue): the negative component is clipped to 0 and the colour rescaled to
luminance 1, so it is the nearest colour the renderer can show, not an exact one.

Pure Python, no numpy: `rt validate` and the models use it.
"""

from __future__ import annotations

import math
from functools import lru_cache

# The range of temperatures accepted, in kelvin: candle flame to a clear blue sky.
MIN_KELVIN = 1000.0
MAX_KELVIN = 40000.0

# Planck's second radiation constant h c / k, in metre kelvin (CODATA 2018).
_C2 = 1.438776877e-2

# The lobes of the fit (weight, centre nm, width below the centre, width above), per function.
_X_LOBES = ((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2))
_Y_LOBES = ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1))
_Z_LOBES = ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8))

# CIE XYZ to linear sRGB (D65).
_XYZ_TO_RGB = ((3.2404542, -1.5371385, -0.4985314),
               (-0.9692660, 1.8760108, 0.0415560),
               (0.0556434, -0.2040259, 1.0572252))
LUMINANCE = (0.2126, 0.7152, 0.0722)


def _lobes(wavelength: float, lobes) -> float:
    total = 0.0
    for weight, centre, below, above in lobes:
        t = (wavelength - centre) / (below if wavelength < centre else above)
        total += weight * math.exp(-0.5 * t * t)
    return total


def matching_functions(wavelength_nm: float) -> tuple[float, float, float]:
    """(x-bar, y-bar, z-bar) of the CIE 1931 2-degree observer at a wavelength in nm (the fit)."""
    return (_lobes(wavelength_nm, _X_LOBES), _lobes(wavelength_nm, _Y_LOBES), _lobes(wavelength_nm, _Z_LOBES))


def planck(wavelength_nm: float, kelvin: float) -> float:
    """Planck's spectral radiance at a wavelength, up to a constant factor (only the shape matters
    here): lambda^-5 / (exp(c2 / (lambda T)) - 1)."""
    lam = wavelength_nm * 1e-9
    return 1.0 / (lam ** 5 * math.expm1(_C2 / (lam * kelvin)))


def check_temperature(kelvin: float) -> None:
    """ValueError, in one sentence, unless `kelvin` is a temperature this module gives a colour for."""
    if not (isinstance(kelvin, (int, float)) and MIN_KELVIN <= kelvin <= MAX_KELVIN):
        raise ValueError(f"a colour temperature must be between {MIN_KELVIN:g} and {MAX_KELVIN:g} kelvin, found {kelvin!r}")


def temperature_xyz(kelvin: float) -> tuple[float, float, float]:
    """CIE XYZ of a black body at `kelvin`, scaled to Y = 1."""
    check_temperature(kelvin)
    x = y = z = 0.0
    for nm in range(360, 831):
        e = planck(float(nm), float(kelvin))
        xb, yb, zb = matching_functions(float(nm))
        x += e * xb
        y += e * yb
        z += e * zb
    return x / y, 1.0, z / y


def chromaticity(kelvin: float) -> tuple[float, float]:
    """CIE 1931 (x, y) of a black body at `kelvin`."""
    x, y, z = temperature_xyz(kelvin)
    return x / (x + y + z), y / (x + y + z)


@lru_cache(maxsize=256)
def temperature_rgb(kelvin: float) -> tuple[float, float, float]:
    """The linear sRGB colour of a black body at `kelvin` (MIN_KELVIN..MAX_KELVIN), of luminance
    1: negative components (outside the gamut) clipped to 0 before the luminance is set."""
    xyz = temperature_xyz(kelvin)
    rgb = [max(0.0, sum(m * c for m, c in zip(row, xyz))) for row in _XYZ_TO_RGB]
    lum = sum(w * c for w, c in zip(LUMINANCE, rgb))
    return (rgb[0] / lum, rgb[1] / lum, rgb[2] / lum)


def luminance(rgb) -> float:
    """The luminance of a linear sRGB colour."""
    return LUMINANCE[0] * rgb[0] + LUMINANCE[1] * rgb[1] + LUMINANCE[2] * rgb[2]
