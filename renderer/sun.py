"""The sun of a `sun_sky` background as a light: its row of the light table, and the kernels that
sample its cone of directions and give their density.

The sun is a disc at infinity of angular radius alpha (the real sun's is 0.2666 degrees) and
uniform radiance L (sky.disc_radiance: the sun seen through the same atmosphere as the sky), toward
the unit direction s. A light sample draws a direction uniformly in the cone
{d : d . s >= cos alpha}, whose solid angle is 2 pi (1 - cos alpha) (`sample_sun_light`). It is not
a delta light: a BSDF-sampled ray that escapes within the cone meets the disc too (`sun_along`,
which lights.radiance_escaped asks), and the two ways are weighed by the power heuristic. The
irradiance on a surface facing the sun is E = pi L sin^2 alpha, and on one whose normal makes angle
theta with s (the whole disc above its horizon) E cos theta: the exact integral of a uniform cap
(sky.cap_irradiance).

A larger disc (`sun_size`) keeps the irradiance of the real one: its radiance is scaled by the
ratio of the caps' irradiances, so shadows soften and the scene stays as bright. The row's `power`
is the flux pi R^2 E the sun sends into a scene of bounding radius R (as environment.flux weighs a
map, and punctual.py parallel light).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Optional

import numpy as np

from . import target
from .environment import scene_radius
from .light_table import LIGHT_DIRECTION, LIGHT_F, LIGHT_I, LIGHT_RADIANCE, LIGHT_SIZE, SUN_LIGHT, light_vector
from .numerics.vec import dot, unit
from .shapes.spheres import frame_of
from .sky import MODEL_TO_UNITS, REAL_RADIUS, cap_irradiance, disc_radiance


class Sun(NamedTuple):
    """A sun's light, as its row holds it."""

    direction: tuple  # unit, from the scene toward the sun
    radiance: np.ndarray  # of the disc, linear RGB in the renderer's units
    cos_radius: float  # cosine of the disc's angular radius
    irradiance: float  # luminance of the irradiance on a surface facing it


def sun_of(bg) -> Optional[Sun]:
    """The sun of `sun_sky` background model `bg`, None where it has none (sun: false, strength 0)."""
    if not bg.sun or not bg.strength > 0.0:
        return None
    elevation_deg, _ = bg.sun_position()
    cos_radius = math.cos(math.radians(0.5 * float(bg.sun_size)))
    # The real disc's radiance, spread over the chosen disc with the same irradiance.
    real = disc_radiance(math.radians(elevation_deg), float(bg.turbidity))
    spread = cap_irradiance(math.cos(REAL_RADIUS)) / cap_irradiance(cos_radius)
    radiance = real * (spread * MODEL_TO_UNITS * float(bg.strength))
    luminance = float(0.2126 * radiance[0] + 0.7152 * radiance[1] + 0.0722 * radiance[2])
    if not luminance > 0.0:
        return None
    return Sun(bg.sun_direction(), radiance, cos_radius, luminance * cap_irradiance(cos_radius))


def sun_rows(graph, flat) -> tuple[np.ndarray, np.ndarray]:
    """(light_i, light_f): the SUN_LIGHT row of the sun of a `sun_sky` background, none for any
    other background (or graph None), with its `power` pi R^2 E."""
    bg = None if graph is None else graph.background
    sun = sun_of(bg) if getattr(bg, "type", None) == "sun_sky" else None
    if sun is None:
        return LIGHT_I.array(0), LIGHT_F.array(0)
    power = math.pi * scene_radius(flat) ** 2 * sun.irradiance
    return (LIGHT_I.array(1, kind=SUN_LIGHT, instance=-1, primitive=-1, tree_leaf=-1),
            LIGHT_F.array(1, direction=sun.direction, radiance=sun.radiance, size=sun.cos_radius, power=power))


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


@target.device
def sample_sun_light(S, light, pmf, p, time, u1, u2):
    """A direction to sun row `light`'s disc, uniform in the cone it subtends: (ok, the direction
    (a light at infinity), the same unit direction, inf, its solid angle density times `pmf`,
    the disc's radiance). Not a delta: BSDF-sampled rays meet the disc too."""
    wi, pdf = sample_sun_cone(light_vector(S, light, LIGHT_DIRECTION), S.light_f[light, LIGHT_SIZE], u1, u2)
    return True, wi, wi, math.inf, pdf * pmf, light_vector(S, light, LIGHT_RADIANCE)


@target.device
def pdf_sun_light(S, light, pmf, p, x, n, time):
    """The density `sample_sun_light` gives the unit direction x, times `pmf`: 0 outside the disc."""
    return sun_cone_pdf(light_vector(S, light, LIGHT_DIRECTION), S.light_f[light, LIGHT_SIZE], x) * pmf


@target.device
def sun_along(S, light, d):
    """What a ray along d (any length) that meets nothing receives from sun row `light`: the
    disc's radiance where d falls inside it, and the density `sample_sun_light` gives d without
    the choice of the light; nothing, and 0, elsewhere."""
    w = unit(d)
    pdf = sun_cone_pdf(light_vector(S, light, LIGHT_DIRECTION), S.light_f[light, LIGHT_SIZE], w)
    if pdf > 0.0:
        return light_vector(S, light, LIGHT_RADIANCE), pdf
    return (0.0, 0.0, 0.0), 0.0
