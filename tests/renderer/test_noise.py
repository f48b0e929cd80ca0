"""Noise estimates, budgets and resumable renders (what accuracy costs in time)."""

from pathlib import Path

import numpy as np
import pytest

from renderer.film import Film, estimate_noise, noise_map_image
from renderer.compile import with_width
from renderer.render import render
from renderer.state import RenderKey, load_state, save_state
from scenefmt.validation import load, loads

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

SCENES = Path(__file__).resolve().parents[2] / "scenes"


@pytest.mark.parametrize("stem", ["weekend_metal", "cornell_box", "cornell_smoke"])
def test_the_noise_estimate_agrees_with_the_actual_error(stem):
    """Sky-lit spheres, a Cornell box and smoke: estimated RMS error within 20% of the actual one.

    The actual error is the scatter between four seeds: with light sampling most of the error
    sits in the few pixels that hold a light's edge, so one seed's error is itself noisy.
    """
    graph = with_width(load(SCENES / f"{stem}.yaml").graph, 32)
    reference = render(graph, samples=4096, seed=11).film.mean()
    actual2, estimated2 = [], []
    for seed in range(1, 5):
        film = render(graph, samples=64, seed=seed).film
        actual2.append(np.sum((film.mean() - reference) ** 2) / np.sum(reference**2))
        estimated2.append(estimate_noise(film).relative_rms ** 2)
    assert np.sqrt(np.mean(estimated2)) == pytest.approx(np.sqrt(np.mean(actual2)), rel=0.2)


def test_the_estimate_of_known_gaussian_samples():
    rng = np.random.default_rng(0)
    samples = rng.normal(2.0, 0.5, (400, 5, 6, 3))
    film = Film(samples.sum(axis=0), (samples**2).sum(axis=0), 400)
    est = estimate_noise(film)
    # Standard error 0.5 / 20 = 0.025 on a value of 2: 1.25% relative.
    assert est.relative_rms == pytest.approx(0.0125, rel=0.05)
    assert est.error.shape == (5, 6)
    assert est.error[est.worst_pixel[1], est.worst_pixel[0]] == est.error.max()
    grey = noise_map_image(est)
    assert grey.shape == (5, 6, 3) and grey.min() >= 0.0 and grey.max() == 1.0


def test_one_sample_gives_no_estimate():
    film = Film(np.ones((2, 2, 3)), np.ones((2, 2, 3)), 1)
    assert estimate_noise(film).relative_rms == float("inf")


SMALL = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 24, aspect_ratio: 2, samples_per_pixel: 4, max_depth: 8, seed: 5}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}}
shapes: [{type: sphere, center: [0, -100, 0], radius: 100, material: m}, {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: m}]
"""


def key_of(graph, scene="abc"):
    return RenderKey(scene, graph.image.width, graph.image.pixel_height, graph.image.max_depth, graph.image.seed)


def test_a_resumed_render_equals_one_render_with_all_the_samples(tmp_path):
    graph = loads(SMALL).graph
    first = render(graph, samples=5).film
    save_state(tmp_path / "state.npz", first, key_of(graph))
    resumed = render(graph, samples=12, film=load_state(tmp_path / "state.npz", key_of(graph))).film
    whole = render(graph, samples=12).film
    assert resumed.samples == 12
    assert np.array_equal(resumed.total, whole.total) and np.array_equal(resumed.total_sq, whole.total_sq)


def test_a_state_of_another_scene_or_setting_is_refused(tmp_path):
    graph = loads(SMALL).graph
    save_state(tmp_path / "state.npz", render(graph, samples=2).film, key_of(graph))
    with pytest.raises(ValueError, match="it is of another scene \\(or of this one before a change to it\\)"):
        load_state(tmp_path / "state.npz", key_of(graph, scene="other"))
    other_seed = RenderKey("abc", graph.image.width, graph.image.pixel_height, graph.image.max_depth, 99)
    with pytest.raises(ValueError, match="seed 5 \\(now 99\\)"):
        load_state(tmp_path / "state.npz", other_seed)


def test_a_noise_target_stops_when_the_estimate_reaches_it():
    graph = loads(SMALL).graph
    result = render(graph, samples=100000, noise_target=0.05)
    assert result.stats.stop_reason == "noise"
    # It stops on the upper end of the error's 95% interval, so the figure itself is lower still.
    estimate = estimate_noise(result.film)
    assert estimate.high == result.stats.noise_high <= 0.05
    assert estimate.relative_rms < estimate.high and estimate.warning is None
    assert 8 <= result.film.samples < 100000


def test_a_time_budget_stops_the_render():
    graph = with_width(loads(SMALL).graph, 64)
    result = render(graph, samples=1_000_000, time_budget=0.5)
    assert result.stats.stop_reason == "time"
    assert 0 < result.film.samples < 1_000_000
    # The last pass is sized to the time left: the overrun is a fraction of a pass.
    assert result.stats.seconds < 0.5 + 0.5
