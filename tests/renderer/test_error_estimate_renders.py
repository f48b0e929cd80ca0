"""The error estimate and its warning on real renders (48 pixels wide, the general kernel).

The warning must fire where rare, very bright paths carry the light (the sky's small sun seen
through a glass sphere; a small lamp's caustic under a glass ball) and stay silent on the
scenes whose estimate holds (the Cornell box). A noise target does not stop on an estimate the
warning says is untrustworthy. Tuned on renders at 16 to 256 samples (docs/error_estimate.md).
"""

from pathlib import Path

import pytest

import rt
from renderer.compile import with_width
from renderer.film import estimate_noise
from renderer.render import render
from scenefmt.validation import load, loads

pytestmark = pytest.mark.slow

SCENES = Path(__file__).resolve().parents[2] / "scenes"

# A small, bright lamp over a matte floor, seen directly and through a glass ball: the floor
# under the ball is lit by a caustic that only rare paths (floor -> glass -> lamp) find.
CAUSTIC = """
camera: {look_from: [0, 1.6, 4.2], look_at: [0, 0.35, 0], vfov: 32}
image: {width: 48, aspect_ratio: 1.5, samples_per_pixel: 16, max_depth: 12}
background: [0.05, 0.05, 0.06]
materials:
  floor: {type: lambertian, albedo: [0.6, 0.6, 0.6]}
  glass: {type: dielectric, ior: 1.5}
  lamp: {type: diffuse_light, emit: [800, 800, 800]}
shapes:
  - {type: sphere, center: [0, -1000, 0], radius: 1000, material: floor}
  - {type: sphere, center: [0, 0.5, 0.3], radius: 0.5, material: glass}
  - {type: sphere, center: [0.3, 2.2, -0.6], radius: 0.04, material: lamp}
"""


def small(stem):
    return with_width(load(SCENES / f"{stem}.yaml").graph, 48)


@pytest.mark.parametrize("seed", [1, 4])
def test_the_warning_fires_on_sky_spheres_at_16_samples(seed):
    """Seeds 1 and 4 found caustic paths in their 16 samples (seeds 2 and 3 found none: no trace
    of them is in those films, and their estimate cannot know; docs/error_estimate.md)."""
    estimate = estimate_noise(render(small("sky_spheres"), samples=16, seed=seed, kernel="general").film)
    assert estimate.warning is not None and "rare bright paths dominate" in estimate.warning
    assert estimate.suspect.any()


def test_the_warning_fires_on_a_caustic_under_glass():
    """At 64 samples (3 of seeds 1-4 warn; at 16 samples none has found the caustic yet)."""
    estimate = estimate_noise(render(loads(CAUSTIC).graph, samples=64, seed=1, kernel="general").film)
    assert estimate.warning is not None and estimate.suspect.any()


@pytest.mark.parametrize("spp", [16, 64])
def test_the_cornell_box_gets_an_interval_and_no_warning(spp):
    result = render(small("cornell_box"), samples=spp, seed=3, kernel="general")
    estimate = estimate_noise(result.film)
    assert estimate.batched and estimate.warning is None and result.stats.noise_warning is None
    assert 0 < estimate.low < estimate.relative_rms < estimate.high < 2 * estimate.relative_rms


def test_a_noise_target_does_not_stop_while_the_warning_holds():
    """sky_spheres reaches a 60% figure within a few dozen samples, but its warning holds: the
    render goes on to its cap, and the image says why."""
    image = rt.render(SCENES / "sky_spheres.yaml", width=48, spp=48, noise=0.6, seed=1, kernel="general")
    assert image.stats.stop_reason == "samples" and image.samples == 48
    assert image.noise_warning is not None
    low, high = image.noise_interval
    assert low <= image.noise <= high
