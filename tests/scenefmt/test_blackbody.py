"""The colour of a black body (scenefmt.blackbody) against published values.

- CIE illuminant A is Planck's radiator at 2856 K with c2 = 1.435e-2 m K (CIE 15:2004), whose
  chromaticity is published as (0.44757, 0.40745); with today's c2 that is the same spectrum at
  2856 x c2 / 1.435e-2 K.
- Kim et al.'s cubic fit of the Planckian locus (US patent 7,024,034, as Wikipedia's "Planckian
  locus" gives it), made from the tabulated CIE 1931 functions, over 1667-25000 K.

Our matching functions are Wyman, Sloan and Shirley's analytic fit; its chromaticities of black
bodies stay within 0.002 of the locus from 2500 K up and within 0.0035 below (the fit is worst in
the red, where the coolest bodies put their light), which the tolerances below state.
"""

import math

import pytest

from scenefmt.blackbody import (MAX_KELVIN, MIN_KELVIN, chromaticity, luminance, matching_functions, temperature_rgb,
                                temperature_xyz)


def kim_locus(t: float) -> tuple[float, float]:
    """Kim et al.'s approximation of the Planckian locus's (x, y), 1667 <= t <= 25000 K."""
    if t <= 4000:
        x = -0.2661239e9 / t ** 3 - 0.2343589e6 / t ** 2 + 0.8776956e3 / t + 0.179910
    else:
        x = -3.0258469e9 / t ** 3 + 2.1070379e6 / t ** 2 + 0.2226347e3 / t + 0.240390
    if t <= 2222:
        y = -1.1063814 * x ** 3 - 1.34811020 * x ** 2 + 2.18555832 * x - 0.20219683
    elif t <= 4000:
        y = -0.9549476 * x ** 3 - 1.37418593 * x ** 2 + 2.09137015 * x - 0.16748867
    else:
        y = 3.0817580 * x ** 3 - 5.87338670 * x ** 2 + 3.75112997 * x - 0.37001483
    return x, y


@pytest.mark.parametrize("kelvin", [1667, 2000, 2200, 2700, 3000, 3500, 4000, 5000, 5500, 6504, 8000, 10000, 15000, 25000])
def test_the_locus_is_kims_within_the_fits_error(kelvin):
    x, y = chromaticity(kelvin)
    kx, ky = kim_locus(kelvin)
    tol = 0.002 if kelvin >= 2500 else 0.0035
    assert abs(x - kx) <= tol and abs(y - ky) <= tol, ((x, y), (kx, ky))


def test_illuminant_a():
    x, y = chromaticity(2856 * 1.438776877e-2 / 1.435e-2)
    assert abs(x - 0.44757) <= 0.002 and abs(y - 0.40745) <= 0.002, (x, y)


def test_the_matching_functions_peak_where_the_cie_tables_do():
    """The tabulated y-bar peaks at 555 nm with value 1.0002; x-bar at 599 nm (1.0622); z-bar at 446 nm (1.7826)."""
    ys = {nm: matching_functions(nm) for nm in range(380, 781)}
    assert abs(max(ys, key=lambda nm: ys[nm][1]) - 555) <= 5 and ys[555][1] == pytest.approx(1.0, abs=0.01)
    assert abs(max(ys, key=lambda nm: ys[nm][0]) - 599) <= 3 and ys[599][0] == pytest.approx(1.0622, abs=0.03)
    assert abs(max(ys, key=lambda nm: ys[nm][2]) - 446) <= 8 and max(v[2] for v in ys.values()) == pytest.approx(1.7826, abs=0.06)


@pytest.mark.parametrize("kelvin", [MIN_KELVIN, 1900, 2700, 4000, 6504, 10000, MAX_KELVIN])
def test_every_colour_has_luminance_one_and_no_negative_part(kelvin):
    rgb = temperature_rgb(kelvin)
    assert min(rgb) >= 0.0 and all(math.isfinite(c) for c in rgb)
    assert luminance(rgb) == pytest.approx(1.0, rel=1e-12)
    assert temperature_xyz(kelvin)[1] == 1.0


def test_6504_kelvin_is_nearly_white_and_warm_is_red_cold_is_blue():
    r, g, b = temperature_rgb(6504)
    assert max(abs(r - 1), abs(g - 1), abs(b - 1)) < 0.05, (r, g, b)
    r, g, b = temperature_rgb(2700)
    assert r > 1.8 and 0.7 < g < 0.9 and b < 0.3, (r, g, b)  # a warm bulb: red-orange
    r, g, b = temperature_rgb(20000)
    assert b > 1.5 and r < 0.8, (r, g, b)


def test_colours_change_smoothly_with_temperature():
    reds = [temperature_rgb(t)[0] for t in range(1000, 40001, 500)]
    blues = [temperature_rgb(t)[2] for t in range(1000, 40001, 500)]
    assert all(a > b for a, b in zip(reds, reds[1:])) and all(a <= b for a, b in zip(blues, blues[1:]))


@pytest.mark.parametrize("kelvin", [999.9, 40000.1, 0, -5, float("nan")])
def test_outside_the_range_is_one_clear_error(kelvin):
    with pytest.raises(ValueError, match="between 1000 and 40000 kelvin"):
        temperature_rgb(kelvin)


def test_3000_kelvin_is_the_published_orange():
    """Mitchell Charity's blackbody pages (vendian.org, "Different blackbody colors on the web") give
    3000 K as xy (0.4369, 0.4041) and, in sRGB with D65 white scaled so its largest channel is 1,
    the pixel #ffbb71: our colour, encoded the same way, is within 4 of 255 on each channel."""
    x, y = chromaticity(3000)
    assert abs(x - 0.4369) <= 0.002 and abs(y - 0.4041) <= 0.002
    rgb = temperature_rgb(3000)
    top = max(rgb)

    def encode(c):
        return 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055

    pixel = [round(255 * encode(c / top)) for c in rgb]
    assert all(abs(a - b) <= 4 for a, b in zip(pixel, (0xFF, 0xBB, 0x71))), pixel
