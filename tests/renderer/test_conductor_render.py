"""The rough conductor rendered through the whole path tracer (slow: compiles a render kernel).

- A furnace: a perfectly reflecting conductor of alpha 1, seen at normal incidence under a
  uniform white sky, has the albedo 1 - ln 2 (the closed form of test_conductor.py), whichever
  integrator and shadowing form renders it.
- Light sampling: a rough conductor floor under a small lamp renders the same with MIS (light
  sampling plus BSDF sampling) as with BSDF sampling alone, within noise, and MIS is the less
  noisy of the two. This is where a bounce whose microfacet sample fails (reflected below the
  surface, lost by single-scattering GGX) must still do its light sample.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rt
from tests.renderer.stats import film_mean_and_se, z_limit

pytestmark = pytest.mark.slow

PERFECT = {"eta": [1, 1, 1], "k": [1e6, 1e6, 1e6]}


def furnace(alpha, shadowing):
    """A sphere so large that every pixel sees it at normal incidence (within 0.1 degree)."""
    return {
        "version": 1,
        "camera": {"look_from": [0, 0, 10], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 2},
        "image": {"width": 8, "aspect_ratio": "1:1", "samples_per_pixel": 1024, "max_depth": 4},
        "background": [1, 1, 1],
        "materials": {"m": {"type": "conductor", **PERFECT, "alpha": alpha, "shadowing": shadowing}},
        "shapes": [{"type": "sphere", "center": [0, 0, -100], "radius": 100, "material": "m"}],
    }


@pytest.mark.parametrize("integrator", ["mis", "path"])
@pytest.mark.parametrize("shadowing", ["correlated", "separable"])
def test_furnace_at_normal_incidence_is_one_minus_ln_2(integrator, shadowing):
    film = rt.render(furnace(1.0, shadowing), integrator=integrator, seed=5).film
    mean, se = film_mean_and_se(film)
    assert np.all(se > 0) and np.all(np.isfinite(film.total))
    expected = 1.0 - math.log(2.0)
    assert np.all(np.abs(mean - expected) <= z_limit(12) * se), (mean, se, (mean - expected) / se)


def test_furnace_of_a_glossy_conductor_loses_almost_nothing():
    film = rt.render(furnace(0.05, "correlated"), seed=6).film
    mean, _ = film_mean_and_se(film)
    assert np.all((mean > 0.99) & (mean <= 1.0 + 1e-9)), mean


def under_a_lamp(floor):
    return {
        "version": 1,
        "camera": {"look_from": [0, 2.5, 6], "look_at": [0, 0.5, 0], "up": [0, 1, 0], "vfov": 35},
        "image": {"width": 12, "aspect_ratio": "1:1", "samples_per_pixel": 1024, "max_depth": 2},
        "background": [0, 0, 0],
        "shapes": [
            {"type": "quad", "q": [-3, 0, -3], "u": [6, 0, 0], "v": [0, 0, 6], "material": floor},
            {"type": "quad", "q": [-0.5, 3, -0.5], "u": [1, 0, 0], "v": [0, 0, 1],
             "material": {"type": "diffuse_light", "emit": [8, 8, 8]}},
        ],
    }


def pixel_se(film):
    n = film.samples
    mean = film.total / n
    return np.sqrt(np.maximum(film.total_sq / n - mean * mean, 0.0) / (n - 1))


# Measured before integrator.trace took the light sample of a bounce whose microfacet sample failed (4,096 MIS and 32,768 BSDF-only samples a pixel): MIS 0.0514 against
# 0.0611 for the copper of alpha 0.5 (z = -30), 0.0243 against 0.0341 for the perfect conductor of
# alpha 1 (z = -41): the light samples of every bounce whose microfacet sample failed were lost.
@pytest.mark.parametrize("floor", [{"type": "conductor", "metal": "Cu", "alpha": 0.5},
                                   {"type": "conductor", **PERFECT, "alpha": 1.0}], ids=["copper", "perfect"])
def test_light_sampling_agrees_with_bsdf_sampling(floor):
    mis = rt.render(under_a_lamp(floor), integrator="mis", seed=3).film
    path = rt.render(under_a_lamp(floor), integrator="path", seed=4, spp=8192).film
    m1, s1 = film_mean_and_se(mis)
    m2, s2 = film_mean_and_se(path)
    z = (m1 - m2) / np.sqrt(s1 ** 2 + s2 ** 2)
    assert np.all(np.isfinite(mis.total)) and np.all(np.isfinite(path.total))
    assert np.all(np.abs(z) <= z_limit(3)), (m1, m2, z)


def test_light_sampling_makes_a_lamp_in_rough_metal_less_noisy():
    floor = {"type": "conductor", "metal": "Cu", "alpha": 0.15}
    mis = rt.render(under_a_lamp(floor), integrator="mis", seed=3, spp=256).film
    path = rt.render(under_a_lamp(floor), integrator="path", seed=4, spp=256).film
    lit = film_mean_and_se(path)[0][0] > 0
    assert lit
    ratio = np.median(pixel_se(mis)[..., 0] / np.maximum(pixel_se(path)[..., 0], 1e-12))
    assert ratio < 0.7, ratio
