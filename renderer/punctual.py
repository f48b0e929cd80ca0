"""Point, spot and directional lights: the lights that are no shape (scenefmt/lights.py), their
rows of the light table and their samplers.

All three are deltas: a point (or a direction) that no BSDF-sampled ray can meet. So each is
reached only by a light sample, whose "density" is the probability of its choice (the pmf and
share the selection gave) and whose radiance is what arrives at the shading point; `sample_li`
says `delta_light`, and the integrator gives the sample its full weight (no MIS), and `pdf_li`
answers 0 for them. docs/lights.md states the conventions.

- POINT_LIGHT: intensity I (W/sr, `radiance` column) at `position`: I / d^2 arrives. With a
  radius r > 0 (`size`) it is a sphere of radiance I / (pi r^2) (so that its intensity is I in
  every direction), sampled uniformly in the cone it subtends (shapes/spheres.sample_cone);
  no camera or BSDF ray sees the sphere, so its sample too takes the delta flag. From inside
  the sphere the light falls back to its centre, a point.
- SPOT_LIGHT: a point whose intensity I on its axis (`direction`) is scaled by Mitsuba 3's
  profile: 1 within the beam angle, falling linearly in angle to 0 at the cutoff angle.
- DIRECTIONAL_LIGHT: irradiance E (`radiance` column) along the unit `direction` toward the
  light; the shadow ray runs to infinity.

`power` (what the selection weighs) is the luminance of the flux each sends: 4 pi I for a
point, I times the profile's solid angle for a spot, pi R^2 E for parallel light into a scene
of bounding radius R (as environment.flux weighs a map).
"""

from __future__ import annotations

import math

import numpy as np

from . import target
from .environment import scene_radius
from .light_table import (DIRECTIONAL_LIGHT, LIGHT_BEAM, LIGHT_COS_CUTOFF, LIGHT_CUTOFF, LIGHT_DIRECTION, LIGHT_F, LIGHT_I,
                          LIGHT_POSITION, LIGHT_RADIANCE, LIGHT_SIZE, POINT_LIGHT, SPOT_LIGHT, light_vector)
from .numerics.vec import dot, scale, sub
from .shapes.spheres import cone_from, sample_cone


def _luminance(rgb) -> float:
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]


def punctual_rows(graph, flat) -> tuple[np.ndarray, np.ndarray]:
    """(light_i, light_f) rows of the scene's point, spot and directional lights (`graph.lights`,
    none for graph None), in file order, with `power` filled in; a light that sends nothing has
    no row (it could never be chosen)."""
    lights = [] if graph is None else [light for light in graph.lights if light.type in ("point", "spot", "directional")]
    rows_i, rows_f = [], []
    radius = scene_radius(flat) if any(light.type == "directional" for light in lights) else 1.0
    for light in lights:
        if light.type == "point":
            intensity = light.intensity_rgb()
            kind, power = POINT_LIGHT, 4.0 * math.pi * _luminance(intensity)
            row = LIGHT_F.row(position=light.position, radiance=intensity, size=light.radius, power=power)
        elif light.type == "spot":
            intensity = light.intensity_rgb()
            kind, power = SPOT_LIGHT, light.solid_angle() * _luminance(intensity)
            cutoff, beam = math.radians(light.cutoff_angle), math.radians(light.beam)
            row = LIGHT_F.row(position=light.position, direction=light.axis(), radiance=intensity,
                              cos_cutoff=math.cos(cutoff), cutoff=cutoff, beam=beam, power=power)
        else:
            irradiance = light.irradiance_rgb()
            kind, power = DIRECTIONAL_LIGHT, math.pi * radius ** 2 * _luminance(irradiance)
            row = LIGHT_F.row(direction=light.toward_light(), radiance=irradiance, power=power)
        if power > 0.0 and math.isfinite(power):
            rows_i.append(LIGHT_I.row(kind=kind, instance=-1, primitive=-1, strategy=0, tree_leaf=-1))
            rows_f.append(row)
    if not rows_i:
        return LIGHT_I.array(0), LIGHT_F.array(0)
    return np.array(rows_i, np.int32), np.array(rows_f, np.float64)


# --- the kernels ------------------------------------------------------------------------------


@target.device
def spot_profile(S, light, cos_t):
    """Mitsuba 3's spot profile at angle theta from the axis (cos_t its cosine): 1 within the
    beam, (cutoff - theta) / (cutoff - beam) between beam and cutoff, 0 beyond."""
    if cos_t <= S.light_f[light, LIGHT_COS_CUTOFF]:
        return 0.0
    theta = math.acos(min(1.0, cos_t))
    beam = S.light_f[light, LIGHT_BEAM]
    cutoff = S.light_f[light, LIGHT_CUTOFF]
    if theta <= beam:
        return 1.0
    if theta >= cutoff:  # also where beam == cutoff: no ramp
        return 0.0
    return (cutoff - theta) / (cutoff - beam)


@target.device
def _toward_point(c, p):
    """(ok, unit direction from p to c, distance, squared distance)."""
    to = sub(c, p)
    d2 = dot(to, to)
    if not d2 > 0.0:
        return False, to, 0.0, 0.0
    d = math.sqrt(d2)
    return True, scale(to, 1.0 / d), d, d2


@target.device
def sample_point_light(S, light, pmf, p, time, u1, u2):
    """Point light row `light` seen from p: (ok, point on it, unit direction from p, distance,
    pmf (times the cone's solid angle density for a light with a radius, seen from outside it),
    radiance arriving: I / d^2 for a point, I / (pi r^2) for a sphere). Not ok at the light itself."""
    zero = (0.0, 0.0, 0.0)
    c = light_vector(S, light, LIGHT_POSITION)
    i = light_vector(S, light, LIGHT_RADIANCE)
    r = S.light_f[light, LIGHT_SIZE]
    if r > 0.0:
        dist2, outside = cone_from(p, c, r)
        if outside:
            x, _, pdf = sample_cone(p, c, r, dist2, u1, u2)
            ok, wi, d, _ = _toward_point(x, p)
            k = 1.0 / (math.pi * r * r)
            return ok, x, wi, d, pdf * pmf, (i[0] * k, i[1] * k, i[2] * k)
    ok, wi, d, d2 = _toward_point(c, p)
    if not ok:
        return False, c, zero, 0.0, 0.0, zero
    k = 1.0 / d2
    return True, c, wi, d, pmf, (i[0] * k, i[1] * k, i[2] * k)


@target.device
def sample_spot_light(S, light, pmf, p, time, u1, u2):
    """Spot light row `light` seen from p: (ok, its position, unit direction from p, distance,
    pmf, radiance arriving: I profile(theta) / d^2, theta the angle between the axis and p). Not
    ok at the light itself or outside its cone (nothing arrives: no shadow ray is needed)."""
    zero = (0.0, 0.0, 0.0)
    c = light_vector(S, light, LIGHT_POSITION)
    ok, wi, d, d2 = _toward_point(c, p)
    if not ok:
        return False, c, zero, 0.0, 0.0, zero
    axis = light_vector(S, light, LIGHT_DIRECTION)
    f = spot_profile(S, light, -dot(wi, axis))
    if not f > 0.0:
        return False, c, wi, d, 0.0, zero
    i = light_vector(S, light, LIGHT_RADIANCE)
    k = f / d2
    return True, c, wi, d, pmf, (i[0] * k, i[1] * k, i[2] * k)


@target.device
def sample_directional_light(S, light, pmf, p, time, u1, u2):
    """Directional light row `light`: (True, the direction toward the light (a light at infinity
    gives a direction where others give a point), the same as wi, inf, pmf, its irradiance E:
    a surface facing the light receives E, one at angle theta E cos theta, which the BSDF's
    cosine supplies)."""
    wi = light_vector(S, light, LIGHT_DIRECTION)
    return True, wi, wi, math.inf, pmf, light_vector(S, light, LIGHT_RADIANCE)
