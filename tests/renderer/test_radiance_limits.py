"""The colour limits of scenefmt.bounds are enough: the brightest scene a file may describe renders
finite pixels and a finite noise figure (before, an emission of 1e300 was accepted and
gave infinite pixels and a NaN noise figure with exit status 0)."""

from __future__ import annotations

import numpy as np
import pytest

from renderer.film import estimate_noise
from renderer.render import render
from scenefmt import bounds
from scenefmt.diagnostics import SceneError
from scenefmt.validation import loads

BRIGHTEST = f"""
image: {{width: 6, height: 4, samples_per_pixel: 4, max_depth: 50}}
background: [{bounds.MAX_RADIANCE:g}, {bounds.MAX_RADIANCE:g}, {bounds.MAX_RADIANCE:g}]
materials:
  light: {{type: diffuse_light, emit: [{bounds.MAX_RADIANCE:g}, 0, {bounds.MAX_RADIANCE:g}]}}
  white: {{type: lambertian, albedo: [1, 1, 1]}}
  mirror: {{type: metal, albedo: [1, 1, 1], fuzz: 0.2}}
shapes:
  - {{type: sphere, center: [0, 0, -3], radius: 1, material: light}}
  - {{type: sphere, center: [2, 0, -3], radius: 1, material: white}}
  - {{type: box, min: [-4, -2, -6], max: [4, -1.5, 0], material: mirror}}
"""


@pytest.mark.slow
def test_the_brightest_scene_allowed_renders_finite_pixels_and_noise():
    result = render(loads(BRIGHTEST).graph)
    mean = result.film.mean()
    assert np.isfinite(mean).all() and mean.max() >= bounds.MAX_RADIANCE * 0.5
    assert np.isfinite(result.film.total_sq).all()
    assert np.isfinite(estimate_noise(result.film).relative_rms)


def test_one_step_beyond_is_refused():
    with pytest.raises(SceneError):
        loads(BRIGHTEST.replace(f"emit: [{bounds.MAX_RADIANCE:g}", f"emit: [{bounds.MAX_RADIANCE * 10:g}"))
