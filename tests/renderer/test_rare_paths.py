"""The rare-path prior (renderer/rare_paths.py): which scenes can hide light from every estimate made of
their samples, and when the sentence that says so lapses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from renderer.compile import compile_scene, with_width
from renderer.film import Film
from renderer.rare_paths import RADIANCE_RATIO, TRUSTED_SAMPLES, image_mean, rare_path_prior
from scenefmt.validation import load, loads

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def prior_of(name: str):
    return rare_path_prior(compile_scene(with_width(load(SCENES / f"{name}.yaml").graph, 8)))


def test_the_sun_of_the_sky_map_behind_glass_and_a_mirror_is_a_prior():
    prior = prior_of("sky_spheres")
    assert prior is not None and prior.peak_radiance == pytest.approx(900.0, rel=0.05)
    sentence = prior.warning(image_mean=0.65, samples=16)
    assert sentence is not None and "glass or mirrors" in sentence and "16 samples per pixel" in sentence
    assert prior.warning(image_mean=0.65, samples=TRUSTED_SAMPLES) is None  # it lapses where the estimate holds
    assert prior.warning(image_mean=0.0, samples=16) is None  # a black image says nothing


@pytest.mark.parametrize("name", ["cornell_box", "weekend_glass", "cornell_smoke", "simple_light"])
def test_scenes_without_a_sharp_surface_and_a_light_have_none(name):
    assert prior_of(name) is None


@pytest.mark.parametrize("name,mean", [("cornell_knot", 0.176), ("final_scene", 0.448), ("cornell_conductor", 0.167)])
def test_a_lamp_not_far_above_the_image_says_nothing(name, mean):
    """Glass or a mirror under a lamp 16 to 95 times the image's mean (the means of their converged
    references at 48 px): their rare paths are not rare enough to hide; no sentence."""
    prior = prior_of(name)
    assert prior is not None and prior.peak_radiance < RADIANCE_RATIO * mean
    assert prior.warning(image_mean=mean, samples=16) is None


def test_a_small_bright_lamp_over_glass_is_a_prior_and_a_dim_one_is_not():
    text = """
image: {width: 8, samples_per_pixel: 4}
materials:
  glass: {type: dielectric, ior: 1.5}
  floor: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
  lamp: {type: diffuse_light, emit: [LAMP, LAMP, LAMP]}
shapes:
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: glass}
  - {type: quad, q: [-4, 0, -4], u: [8, 0, 0], v: [0, 0, 8], material: floor}
  - {type: quad, q: [-1, 2.5, 0], u: [0.1, 0, 0], v: [0, 0, 0.1], material: lamp}
"""
    bright = rare_path_prior(compile_scene(loads(text.replace("LAMP", "160")).graph))
    assert bright is not None and bright.light == "an emitter" and bright.warning(0.13, 64) is not None
    dim = rare_path_prior(compile_scene(loads(text.replace("LAMP", "4")).graph))
    assert dim.warning(0.13, 64) is None


def test_the_image_mean_is_the_films():
    film = Film(np.full((2, 3, 3), 8.0), np.zeros((2, 3, 3)), 4)
    assert image_mean(film) == 2.0 and image_mean(Film.empty(3, 2)) == 0.0
