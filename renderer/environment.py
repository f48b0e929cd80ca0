"""The environment map: an image background's texels, the tables that sample it by brightness,
their flattening, and the kernels that look it up and sample it.

The map is equirectangular (scenefmt.scene.ImageBackground): texel (col, row) of a W x H image
covers u in [col, col + 1) / W and v in [row, row + 1) / H, and (u, v) is the direction

    theta = pi v (from +y), phi = 2 pi u:  (-sin theta sin phi, cos theta, sin theta cos phi)

in the map's frame, turned about +y by `rotate` into the world. Radiance is constant over a
texel (the nearest texel, no filtering), so the sampler below can follow it exactly.

Sampling (pbrt's 2-D piecewise-constant distribution): each texel gets the weight
f = luminance x sin(theta at its row's centre), since a row near a pole covers less solid
angle. A row is chosen from the marginal cdf over rows, then a texel within it from that row's
conditional cdf, both by binary search, and the point is uniform inside the texel. The density
in (u, v) is p(u, v) = f / mean(f), and per solid angle, with d omega = 2 pi^2 sin(theta) du dv,

    pdf(omega) = p(u, v) / (2 pi^2 sin theta).

The map is a kind of light (lights.py, ENVIRONMENT_LIGHT): with `integrator: mis` the one
light-selection step there sends a light sample to it with probability `choose`, its share of
the power, from the flux it sends a scene of bounding radius R (`flux`: pi R^2 times its
radiance integrated over the sphere). A map with no light (black, or strength 0) is not a
light: it is never sampled, and its (zero) radiance is found only by BSDF rays.
"""

from __future__ import annotations

import math

import numpy as np
from . import target

from .background import BACKGROUND_IMAGE, IMAGE_BACKGROUND
from .columns import Column, Layout
from .numerics.cdf import pmf_and_cdf, search_cdf

# A row's or texel's own probability is its cdf less the one before (no column of its own: on a
# large map that column would be a fifth of the map's memory).
ENV_ROW_F = Layout("env_row_f", "float64", [
    Column("cdf", 1, "probability of choosing this row or one above it, by luminance x sin(theta) (the last row is 1)"),
])
ENV_TEXEL_F = Layout("env_texel_f", "float64", [
    Column("cdf", 1, "probability, within its row, of choosing this texel or one left of it"),
    Column("density", 1, "p(u, v): the density of a sample in the unit square of (u, v) over this texel"),
])
(ENV_ROW_CDF,) = ENV_ROW_F.offsets("cdf")
ENV_TEXEL_CDF, ENV_TEXEL_DENSITY = ENV_TEXEL_F.offsets("cdf", "density")
ENV_WIDTH, ENV_HEIGHT, ENV_COS, ENV_SIN = IMAGE_BACKGROUND.offsets("width", "height", "cos_rotate", "sin_rotate")

TWO_PI_SQUARED = 2.0 * math.pi * math.pi


# --- flattening -------------------------------------------------------------------------------


def no_environment() -> dict[str, np.ndarray]:
    """The tables of a scene whose background is not an image."""
    return {"env_rgb": np.zeros((0, 3), np.float32), "env_row_f": ENV_ROW_F.array(0), "env_texel_f": ENV_TEXEL_F.array(0)}


def tables(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """env_row_f, env_texel_f and the radiance integrated over the sphere of directions (its
    luminance) of an (h, w, 3) map of linear radiance."""
    h, w = rgb.shape[:2]
    sin_row = np.sin(np.pi * (np.arange(h) + 0.5) / h)
    f = (0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]).astype(np.float64) * sin_row[:, None]
    row_sum = f.sum(axis=1)
    total = float(row_sum.sum())
    rows, texels = ENV_ROW_F.array(h), ENV_TEXEL_F.array(h * w)
    if not total > 0.0:
        return rows, texels, 0.0
    rows[:, ENV_ROW_CDF] = pmf_and_cdf(row_sum, total)[1]
    # A row without light is never chosen; its conditional is uniform only to stay finite.
    safe = np.where(row_sum > 0.0, row_sum, 1.0)[:, None]
    pmf = np.where(row_sum[:, None] > 0.0, f / safe, 1.0 / w)
    cdf = np.cumsum(pmf, axis=1)
    cdf[:, -1] = 1.0
    texels[:, ENV_TEXEL_CDF] = cdf.ravel()
    texels[:, ENV_TEXEL_DENSITY] = (f * (h * w / total)).ravel()
    return rows, texels, total * TWO_PI_SQUARED / (h * w)


def scene_radius(flat) -> float:
    """Half the diagonal of the box around every instance (1 for an empty scene)."""
    if len(flat.tlas_f) == 0:
        return 1.0
    from .trees import TLAS_HI, TLAS_LO

    size = flat.tlas_f[0, TLAS_HI:TLAS_HI + 3] - flat.tlas_f[0, TLAS_LO:TLAS_LO + 3]
    radius = 0.5 * float(np.linalg.norm(size))
    return radius if math.isfinite(radius) and radius > 0.0 else 1.0


def flux(flat, radiance: float) -> float:
    """The flux a map of `radiance` integrated over the sphere sends into flat scene `flat`:
    pi R^2 times it, for the scene's bounding radius R (lights.map_share weighs it)."""
    return math.pi * scene_radius(flat) ** 2 * radiance


def environment_tables(flat, graph) -> tuple[dict[str, np.ndarray], float]:
    """The background row and environment tables of `flat`, and the map's radiance integrated
    over the sphere (for lights.light_tables); nothing and 0 for a background that is not an image
    or a sun and sky (whose sky is computed into a map here: sky.sun_sky_map)."""
    from scenefmt.scene import ImageBackground
    from scenefmt.sky import SunSkyBackground

    from .textures import load_image_texels

    bg = graph.background
    if isinstance(bg, SunSkyBackground):
        from .sky import sun_sky_map

        rgb, turn = sun_sky_map(bg), 0.0
    elif isinstance(bg, ImageBackground):
        texels = load_image_texels(graph.environment_path, "srgb")  # float images as stored, 8-bit ones as sRGB
        rgb = np.ascontiguousarray(texels * np.float32(bg.strength), dtype=np.float32)
        turn = math.radians(bg.rotate)
    else:
        return {}, 0.0
    h, w = rgb.shape[:2]
    rows, texel_f, power = tables(rgb)
    row = IMAGE_BACKGROUND.row(kind=float(BACKGROUND_IMAGE), width=float(w), height=float(h), cos_rotate=math.cos(turn),
                               sin_rotate=math.sin(turn), sun=-1.0)
    return {"background": np.array(row, np.float64), "env_rgb": rgb.reshape(-1, 3), "env_row_f": rows, "env_texel_f": texel_f}, power


# --- the kernels ------------------------------------------------------------------------------


@target.device
def environment_radiance(bg, env_rgb, env_texel_f, d):
    """The map's radiance arriving along direction d (any length, pointing away from the scene),
    and the solid angle density with which `sample_environment` gives that direction (the
    choice of the map not included: lights.pdf_li adds it)."""
    w, h = int(bg[ENV_WIDTH]), int(bg[ENV_HEIGHT])
    c, s = bg[ENV_COS], bg[ENV_SIN]
    # Into the map's frame: the turn about +y undone.
    x = c * d[0] - s * d[2]
    y = d[1]
    z = s * d[0] + c * d[2]
    r = math.sqrt(x * x + z * z)
    theta = math.atan2(r, y)
    phi = math.atan2(-x, z)
    if phi < 0.0:
        phi += 2.0 * math.pi
    col = min(max(int(phi * (w / (2.0 * math.pi))), 0), w - 1)
    row = min(max(int(theta * (h / math.pi)), 0), h - 1)
    k = row * w + col
    density = env_texel_f[k, ENV_TEXEL_DENSITY]
    sin_t = r / math.sqrt(r * r + y * y) if r > 0.0 else 0.0
    if density <= 0.0:
        pdf = 0.0
    elif sin_t > 0.0:
        pdf = density / (TWO_PI_SQUARED * sin_t)
    else:
        pdf = math.inf  # exactly at a pole: a set of no measure
    return (float(env_rgb[k, 0]), float(env_rgb[k, 1]), float(env_rgb[k, 2])), pdf


@target.device
def sample_environment(bg, env_rgb, env_row_f, env_texel_f, u1, u2):
    """A direction drawn from the map by brightness: (ok, unit direction, solid angle density
    without the choice of the map, radiance). Not ok for a draw exactly at a pole."""
    zero = (0.0, 0.0, 0.0)
    w, h = int(bg[ENV_WIDTH]), int(bg[ENV_HEIGHT])
    # The row from the marginal cdf, then the texel from its row's conditional cdf; the place
    # of u within the chosen interval is reused as the position inside the texel.
    row = search_cdf(env_row_f, ENV_ROW_CDF, 0, h, u1)
    below = env_row_f[row - 1, ENV_ROW_CDF] if row > 0 else 0.0
    pmf = env_row_f[row, ENV_ROW_CDF] - below
    fv = min(max((u1 - below) / pmf, 0.0), 1.0) if pmf > 0.0 else 0.5
    k = search_cdf(env_texel_f, ENV_TEXEL_CDF, row * w, w, u2)
    below = env_texel_f[k - 1, ENV_TEXEL_CDF] if k > row * w else 0.0
    pmf = env_texel_f[k, ENV_TEXEL_CDF] - below
    fu = min(max((u2 - below) / pmf, 0.0), 1.0) if pmf > 0.0 else 0.5
    col = k - row * w
    theta = math.pi * (row + fv) / h
    phi = 2.0 * math.pi * (col + fu) / w
    sin_t = math.sin(theta)
    density = env_texel_f[k, ENV_TEXEL_DENSITY]
    if not (sin_t > 0.0 and density > 0.0):
        return False, zero, 0.0, zero
    xm, y, zm = -sin_t * math.sin(phi), math.cos(theta), sin_t * math.cos(phi)
    c, s = bg[ENV_COS], bg[ENV_SIN]
    d = (c * xm + s * zm, y, -s * xm + c * zm)
    return True, d, density / (TWO_PI_SQUARED * sin_t), (float(env_rgb[k, 0]), float(env_rgb[k, 1]), float(env_rgb[k, 2]))
