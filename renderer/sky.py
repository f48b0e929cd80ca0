"""A clear atmosphere, evaluated in numpy when flattening: the sky of Hosek and Wilkie (2012, RGB
version) and the sun's disc seen through it; and the environment map of a `sun_sky` background.

The model gives the sky's radiance in a direction at angle theta from the zenith and gamma from
the sun as a product of two factors fitted to a full simulation of multiple scattering:

    F(theta, gamma) = (1 + A exp(B / (cos theta + 0.01)))
                      x (C + D exp(E gamma) + F cos^2 gamma + G chi(I, gamma) + H sqrt(cos theta)),
    chi(g, gamma) = (1 + cos^2 gamma) / (1 + g^2 - 2 g cos gamma)^(3/2),

times a mean radiance L_M, per colour channel. The first factor darkens the zenith against the
horizon; the second is the glow about the sun: an exponential peak (D, E), Rayleigh's cos^2 (F),
a Henyey-Greenstein-like forward lobe of the aerosols (G, I) and a zenith gradient (H). Each of the
nine coefficients and L_M is stored (sky_data.py) at six control points of a quintic Bezier curve
in x = (elevation / 90 deg)^(1/3), for ground albedo 0 and 1 and turbidity 1..10; between those the
model blends linearly.

The sun's disc (`disc_radiance`) is the sun's extraterrestrial spectrum, a black body at 5778 K
(whose radiance, over the sun's solid angle, gives the solar constant within 2%), attenuated along
the air mass of the sun's elevation (Kasten and Young 1989) by Rayleigh scattering (Leckner's
optical depth, 0.008735 lambda^-4.08 with lambda in micrometres) and by aerosols (Angstrom's law
with exponent 1.3 and Preetham's coefficient beta = 0.04608 T - 0.04586 of the turbidity T), then
integrated against the CIE 1931 observer into linear sRGB. Ozone and water vapour are left out (a
few percent in the visible). Against Hosek and Wilkie's own solar model (as Mitsuba 3's sunsky
evaluates it) this agrees within 10% for a sun above 45 degrees at turbidity 2 and 3, and is
darker and redder for a low sun or thick haze (half of theirs at 10 degrees): our extinction is
the textbook one, theirs is fitted to a simulation that also counts light scattered forward into
the disc. sun.py makes the disc a light.

Units: the RGB fit gives radiance in the units of the authors' spectral model integrated against
the CIE observer, W/(m^2 sr) per channel such that 683 x luminance is cd/m^2 (the disc's are the
same); `MODEL_TO_UNITS` turns them into the renderer's units, where a white floor under the midday
sun and sky is near 1.
"""

from __future__ import annotations

import math

import numpy as np

from scenefmt.blackbody import matching_functions

from . import sky_data


def _blend(table: np.ndarray, elevation: float, turbidity: float, albedo: float) -> np.ndarray:
    """table[channel, albedo, turbidity - 1, control point, ...] at the sun's elevation (radians,
    0..pi/2), a turbidity in [1, 10] and a ground albedo in [0, 1]: Bezier in elevation, linear in
    turbidity and albedo. (channel, ...)"""
    x = (max(0.0, min(elevation, 0.5 * math.pi)) / (0.5 * math.pi)) ** (1.0 / 3.0)
    weights = np.array([math.comb(5, k) * (1.0 - x) ** (5 - k) * x ** k for k in range(6)])
    curve = np.tensordot(table, weights, axes=([3], [0])) if table.ndim == 4 else np.einsum("catkp,k->catp", table, weights)
    low = min(max(int(math.floor(turbidity)), 1), 10)
    high = min(low + 1, 10)
    t = turbidity - low if high > low else 0.0
    by_turbidity = (1.0 - t) * curve[:, :, low - 1] + t * curve[:, :, high - 1]
    return (1.0 - albedo) * by_turbidity[:, 0] + albedo * by_turbidity[:, 1]


def coefficients(elevation: float, turbidity: float, albedo: float) -> tuple[np.ndarray, np.ndarray]:
    """The model's nine coefficients A..I per channel (3, 9) and its mean radiance L_M (3,) for a
    sun at `elevation` radians above the horizon."""
    return _blend(sky_data.PARAMS, elevation, turbidity, albedo), _blend(sky_data.RADIANCE, elevation, turbidity, albedo)


def radiance(cos_theta: np.ndarray, cos_gamma: np.ndarray, elevation: float, turbidity: float, albedo: float) -> np.ndarray:
    """The sky's RGB radiance (..., 3) in the model's units toward directions at cos_theta from the
    zenith (>= 0: the model covers the upper hemisphere only) and cos_gamma from the sun."""
    c, lm = coefficients(elevation, turbidity, albedo)
    ct = np.maximum(np.asarray(cos_theta, np.float64), 0.0)[..., None]
    cg = np.clip(np.asarray(cos_gamma, np.float64), -1.0, 1.0)[..., None]
    gamma = np.arccos(cg)
    a, b, cc, d, e, f, g, h, i = (c[:, k] for k in range(9))
    chi = (1.0 + cg * cg) / (1.0 + i * i - 2.0 * i * cg) ** 1.5
    value = (1.0 + a * np.exp(b / (ct + 0.01))) * (cc + d * np.exp(e * gamma) + f * cg * cg + g * chi + h * np.sqrt(ct))
    return value * lm


# --- the sun's disc seen through the same atmosphere --------------------------------------------

# Wavelengths (nm) at which the sun's spectrum is integrated: the visible, in 5 nm steps.
WAVELENGTHS = np.arange(380.0, 781.0, 5.0)
SUN_TEMPERATURE = 5778.0  # K: the black body that matches the sun's surface
# CIE XYZ to linear sRGB (D65 white), as the sky model's RGB fit uses.
XYZ_TO_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                        [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])
REAL_RADIUS = math.radians(0.2666)  # the real sun's angular radius


def observer(nm: np.ndarray) -> np.ndarray:
    """The CIE 1931 2-degree colour matching functions (x-bar, y-bar, z-bar) at wavelengths `nm`
    (..., 3): the analytic fit scenefmt.blackbody gives for colour temperatures."""
    return np.array([matching_functions(float(w)) for w in np.ravel(nm)]).reshape(np.shape(nm) + (3,))


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


# --- the map ----------------------------------------------------------------------------------

# The renderer's unit of radiance in cd/m^2: 100000 lux (a clear midday) on a white lambertian
# floor gives it radiance 100000/pi cd/m^2, which renders as 1.
UNIT_CD_PER_M2 = 100000.0 / math.pi
# The model's radiance (its Y channel times 683 is luminance in cd/m^2) in the renderer's unit.
MODEL_TO_UNITS = 683.0 / UNIT_CD_PER_M2
# The map's size: texels across (once around) and down (pole to pole). 512 x 256 texels of 0.7
# degrees keep the horizontal irradiance within 0.1% of a 4096 x 2048 map's for suns from 5 to 90
# degrees and turbidity 2 to 8 (docs/lights.md); each texel averages 2 x 2 points, so the sharp
# glow about a low sun is not aliased.
MAP_WIDTH, MAP_HEIGHT = 512, 256
SUBSAMPLES = 2
BAND_ROWS = 16


def texel_directions(width: int, height: int, sub: int) -> np.ndarray:
    """Unit directions (height, width, sub * sub, 3) of sub x sub points inside each texel of a
    width x height equirectangular map, in the format's mapping (environment.py: theta = pi v from
    +y, phi = 2 pi u, (-sin theta sin phi, cos theta, sin theta cos phi))."""
    offsets = (np.arange(sub) + 0.5) / sub
    v = (np.arange(height)[:, None] + offsets[None, :]).ravel() / height
    u = (np.arange(width)[:, None] + offsets[None, :]).ravel() / width
    theta = np.pi * v.reshape(height, sub)
    phi = 2.0 * np.pi * u.reshape(width, sub)
    st, ct = np.sin(theta)[:, None, :, None], np.cos(theta)[:, None, :, None]
    sp, cp = np.sin(phi)[None, :, None, :], np.cos(phi)[None, :, None, :]
    d = np.stack(np.broadcast_arrays(-st * sp, ct, st * cp), axis=-1)
    return d.reshape(height, width, sub * sub, 3)


def sky_map(sun: tuple, elevation: float, turbidity: float, albedo: float, width: int = MAP_WIDTH,
            height: int = MAP_HEIGHT, sub: int = SUBSAMPLES) -> np.ndarray:
    """(height, width, 3) float64: the sky's radiance in the model's units over the upper
    hemisphere for a sun toward unit `sun` at `elevation` radians, each texel the mean of sub x sub
    points; 0 below the horizon (sky_background adds the ground)."""
    out = np.zeros((height, width, 3))
    d = texel_directions(width, height, sub)
    # Bands of rows, so that the model's temporaries stay a few megabytes (scenefmt.bounds counts them).
    for first in range(0, (height + 1) // 2, BAND_ROWS):  # the upper half: the lower is below the horizon
        band = d[first:first + BAND_ROWS]
        cos_theta = band[..., 1]
        value = radiance(cos_theta, band @ np.asarray(sun, np.float64), elevation, turbidity, albedo)
        value = np.where((cos_theta >= 0.0)[..., None], np.maximum(value, 0.0), 0.0)
        out[first:first + BAND_ROWS] = value.mean(axis=2)
    return out


def horizontal_irradiance(rgb: np.ndarray) -> np.ndarray:
    """The irradiance (3,) a level surface facing up receives from an equirectangular map of
    radiance `rgb` (texel centres' cosines; the map's lower half sends nothing upward)."""
    h, w = rgb.shape[:2]
    theta = np.pi * (np.arange(h) + 0.5) / h
    weight = np.maximum(np.cos(theta), 0.0) * np.sin(theta) * (np.pi / h) * (2.0 * np.pi / w)
    return (rgb * weight[:, None, None]).sum(axis=(0, 1))


def sun_on_ground(bg) -> np.ndarray:
    """The irradiance (3,), in the renderer's units, that the sun of `sun_sky` background model `bg`
    gives level ground (0 without a sun): the real disc's, whatever `sun_size` (a larger disc keeps it)."""
    if not bg.sun:
        return np.zeros(3)
    elevation = math.radians(bg.sun_position()[0])
    return (disc_radiance(elevation, float(bg.turbidity)) * cap_irradiance(math.cos(REAL_RADIUS))
            * (MODEL_TO_UNITS * float(bg.strength) * math.sin(elevation)))


def sun_sky_map(bg) -> np.ndarray:
    """The environment map (MAP_HEIGHT, MAP_WIDTH, 3) float32, in the renderer's units, of `sun_sky`
    background model `bg` (scenefmt.sky.SunSkyBackground): the sky above the horizon (without the
    sun's disc, which is a light of its own: sun.py), and below it a level lambertian ground of
    reflectance `ground_albedo` lit by the sky and the sun. Black without a sky."""
    if not bg.sky or not bg.strength > 0.0:
        return np.zeros((1, 2, 3), np.float32)
    elevation_deg, _ = bg.sun_position()
    rgb = sky_map(bg.sun_direction(), math.radians(elevation_deg), float(bg.turbidity), float(bg.ground_albedo))
    rgb *= MODEL_TO_UNITS * float(bg.strength)
    ground = float(bg.ground_albedo) / math.pi * (horizontal_irradiance(rgb) + sun_on_ground(bg))
    below = (np.arange(rgb.shape[0]) + 0.5) / rgb.shape[0] > 0.5
    rgb[below] = ground
    return np.ascontiguousarray(rgb, dtype=np.float32)
