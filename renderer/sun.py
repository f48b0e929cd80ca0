"""The sun of a `sun_sky` background: its disc's radiance and colour when flattening, and the
kernels that sample its cone of directions and give their density.

The sun is a disc at infinity of angular radius alpha (the real sun's is 0.2666 degrees) and
uniform radiance L, toward the unit direction s. A light sample draws a direction uniformly in
the cone {d : d . s >= cos alpha}, whose solid angle is 2 pi (1 - cos alpha); it is not a delta
light, since a BSDF-sampled ray that escapes within the cone meets the disc too, and the two ways
are weighed by the power heuristic (lights.py: `sample_sun_light`, `pdf_sun_light`,
`radiance_escaped`). The irradiance on a surface facing the sun is E = pi L sin^2 alpha, and on
one whose normal makes angle theta with s (the whole disc above its horizon) E cos theta: the
exact integral of a uniform cap (`cap_irradiance`).

The disc's radiance is the sun's extraterrestrial spectrum, a black body at 5778 K (whose
radiance, over the sun's solid angle, gives the solar constant within 2%), attenuated along the
air mass of the sun's elevation (Kasten and Young 1989) by Rayleigh scattering (Leckner's optical
depth, 0.008735 lambda^-4.08 with lambda in micrometres) and by aerosols (Angstrom's law with
exponent 1.3 and Preetham's coefficient beta = 0.04608 T - 0.04586 of the turbidity T), then
integrated against the CIE 1931 observer (the analytic fit of Wyman, Sloan and Shirley 2013) into
linear sRGB, in the sky model's units (sky.py). Ozone and water vapour are left out (a few percent
in the visible). Against Hosek and Wilkie's own solar model (as Mitsuba 3's sunsky evaluates it)
this agrees within 10% for a sun above 45 degrees at turbidity 2 and 3, and is darker and redder
for a low sun or thick haze (half of theirs at 10 degrees): our extinction is the textbook one,
theirs is fitted to a simulation that also counts light scattered forward into the disc.

A larger disc (`sun_size`) keeps the irradiance of the real one: its radiance is scaled by the
ratio of the solid angles, so shadows soften and the scene stays as bright.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import target
from .numerics.vec import dot
from .shapes.spheres import frame_of
from .sky import MODEL_TO_UNITS

# Wavelengths (nm) at which the sun's spectrum is integrated: the visible, in 5 nm steps.
WAVELENGTHS = np.arange(380.0, 781.0, 5.0)
SUN_TEMPERATURE = 5778.0  # K: the black body that matches the sun's surface
# CIE XYZ to linear sRGB (D65 white), as the sky model's RGB fit uses.
XYZ_TO_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                        [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])
REAL_RADIUS = math.radians(0.2666)  # the real sun's angular radius


def observer(nm: np.ndarray) -> np.ndarray:
    """The CIE 1931 2-degree colour matching functions (x-bar, y-bar, z-bar) at wavelengths `nm`,
    by the multi-lobe piecewise Gaussian fit of Wyman, Sloan and Shirley (2013): (..., 3)."""
    def lobe(x, mean, left, right):
        width = np.where(x < mean, left, right)
        return np.exp(-0.5 * ((x - mean) / width) ** 2)

    x = 1.056 * lobe(nm, 599.8, 37.9, 31.0) + 0.362 * lobe(nm, 442.0, 16.0, 26.7) - 0.065 * lobe(nm, 501.1, 20.4, 26.2)
    y = 0.821 * lobe(nm, 568.8, 46.9, 40.5) + 0.286 * lobe(nm, 530.9, 16.3, 31.1)
    z = 1.217 * lobe(nm, 437.0, 11.8, 36.0) + 0.681 * lobe(nm, 459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1)


def black_body(nm: np.ndarray, kelvin: float) -> np.ndarray:
    """Planck's spectral radiance, W / (m^2 sr nm), at wavelengths `nm`."""
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    metres = nm * 1e-9
    return 2.0 * h * c * c / metres ** 5 / np.expm1(h * c / (metres * k * kelvin)) * 1e-9


def air_mass(elevation: float) -> float:
    """The relative optical path through the atmosphere toward a sun `elevation` radians high
    (Kasten and Young 1989: 1 at the zenith, about 38 at the horizon)."""
    degrees = max(0.0, math.degrees(elevation))
    return 1.0 / (math.sin(math.radians(degrees)) + 0.50572 * (degrees + 6.07995) ** -1.6364)


def disc_radiance(elevation: float, turbidity: float) -> np.ndarray:
    """The real sun's disc radiance (3,) in linear sRGB in the sky model's units (sky.py: Y x 683
    is cd/m^2), seen through the atmosphere at `elevation` radians above the horizon."""
    micrometres = WAVELENGTHS / 1000.0
    depth = 0.008735 * micrometres ** -4.08 + max(0.0, 0.04608 * turbidity - 0.04586) * micrometres ** -1.3
    spectrum = black_body(WAVELENGTHS, SUN_TEMPERATURE) * np.exp(-air_mass(elevation) * depth)
    xyz = (spectrum[:, None] * observer(WAVELENGTHS)).sum(axis=0) * (WAVELENGTHS[1] - WAVELENGTHS[0])
    return np.maximum(XYZ_TO_SRGB @ xyz, 0.0)


def cap_irradiance(cos_radius: float) -> float:
    """The irradiance a disc of unit radiance and angular radius acos(cos_radius) gives a surface
    facing it: the cosine-weighted solid angle of the cap, pi sin^2."""
    return math.pi * (1.0 - cos_radius * cos_radius)


class Sun(NamedTuple):
    """A sun's light row, as lights.light_tables writes it."""

    direction: tuple  # unit, from the scene toward the sun
    radiance: np.ndarray  # of the disc, linear RGB in the renderer's units
    cos_radius: float  # cosine of the disc's angular radius
    irradiance: float  # luminance of the irradiance on a surface facing it


def sun_of(bg) -> Sun | None:
    """The sun of `sun_sky` background model `bg`, None where it has none (sun: false, strength 0)."""
    if not bg.sun or not bg.strength > 0.0:
        return None
    elevation_deg, _ = bg.sun_position()
    radius = math.radians(0.5 * float(bg.sun_size))
    cos_radius = math.cos(radius)
    # The real disc's radiance, spread over the chosen disc with the same irradiance.
    real = disc_radiance(math.radians(elevation_deg), float(bg.turbidity))
    spread = cap_irradiance(math.cos(REAL_RADIUS)) / cap_irradiance(cos_radius)
    radiance = real * (spread * MODEL_TO_UNITS * float(bg.strength))
    luminance = float(0.2126 * radiance[0] + 0.7152 * radiance[1] + 0.0722 * radiance[2])
    if not luminance > 0.0:
        return None
    return Sun(bg.sun_direction(), radiance, cos_radius, luminance * cap_irradiance(cos_radius))


# --- the kernels ------------------------------------------------------------------------------


@target.device
def sample_sun_cone(axis, cos_radius, u1, u2):
    """A direction uniform in the cone of half-angle acos(cos_radius) about unit `axis`, and the
    cone's solid angle density."""
    one_minus = 1.0 - cos_radius
    # 1 - cos(theta) uniform in [0, 1 - cos_radius], kept as a difference for a small cone.
    om = u1 * one_minus
    cos_t = 1.0 - om
    sin_t = math.sqrt(max(0.0, om * (2.0 - om)))
    phi = 2.0 * math.pi * u2
    e1, e2 = frame_of(axis)
    a, b = sin_t * math.cos(phi), sin_t * math.sin(phi)
    d = (a * e1[0] + b * e2[0] + cos_t * axis[0], a * e1[1] + b * e2[1] + cos_t * axis[1],
         a * e1[2] + b * e2[2] + cos_t * axis[2])
    return d, 1.0 / (2.0 * math.pi * one_minus)


@target.device
def sun_cone_pdf(axis, cos_radius, d):
    """The density `sample_sun_cone` gives unit direction d: uniform inside the cone, 0 outside."""
    if dot(axis, d) >= cos_radius:
        return 1.0 / (2.0 * math.pi * (1.0 - cos_radius))
    return 0.0
