"""The forecast's arithmetic (renderer/forecast.py) on synthetic noise curves: fast, no kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.film import Film
from renderer.forecast import (Forecast, ForecastTracker, Reading, chi2_quantile, forecast, noise_after, noise_interval,
                               pooled_interval, samples_for_noise, scaled_to, timing_spread, unbiased_noise)


def reading(noise=0.1, low=0.09, high=0.11, samples=16, per=0.5, spread=0.0):
    return Reading(samples, noise, low, high, per, spread)


def test_samples_and_noise_follow_one_over_the_square_root():
    assert samples_for_noise(16, 0.1, 0.05) == pytest.approx(64)
    assert samples_for_noise(16, 0.04, 0.05) == pytest.approx(10.24)  # reached before the pilot's end
    assert samples_for_noise(16, math.inf, 0.05) == math.inf
    assert noise_after(16, 0.1, 64) == pytest.approx(0.05)
    assert noise_after(16, 0.1, 0) == math.inf


def test_a_noise_target_forecasts_samples_and_seconds_with_the_pilots_range():
    f = forecast(reading(), cap=1_000_000, noise_target=0.01)
    assert f.stop == "noise"
    assert f.samples == pytest.approx(1600) and f.seconds == pytest.approx(800)
    assert f.samples_low == pytest.approx(16 * 81) and f.samples_high == pytest.approx(16 * 121)
    assert f.seconds_low == pytest.approx(16 * 81 * 0.5) and f.seconds_high == pytest.approx(16 * 121 * 0.5)
    assert f.noise == f.noise_low == f.noise_high == 0.01
    assert f.left(300) == pytest.approx(500) and f.left(900) == 0.0


def test_the_timing_spread_widens_the_seconds_not_the_samples():
    f = forecast(reading(spread=0.1), cap=1_000_000, noise_target=0.01)
    assert f.samples == pytest.approx(1600) and f.samples_low == pytest.approx(16 * 81)
    assert f.seconds_low == pytest.approx(16 * 81 * 0.45) and f.seconds_high == pytest.approx(16 * 121 * 0.55)


def test_the_cap_comes_first_and_the_noise_then_is_above_the_target():
    f = forecast(reading(), cap=400, noise_target=0.01)
    assert f.stop == "samples" and f.samples == f.samples_high == 400
    assert f.seconds == pytest.approx(200)
    assert f.noise == pytest.approx(0.1 * math.sqrt(16 / 400))
    assert f.noise_low >= 0.01 and f.noise_high == pytest.approx(0.11 * math.sqrt(16 / 400))


def test_a_time_budget_forecasts_the_noise_at_its_end():
    f = forecast(reading(spread=0.2), cap=1_000_000, time_budget=100.0)
    assert f.stop == "time"
    assert f.samples == pytest.approx(200) and f.seconds == pytest.approx(100)
    assert f.seconds_high == pytest.approx(100)  # a budget bounds the time
    assert f.samples_low == pytest.approx(100 / 0.6) and f.samples_high == pytest.approx(100 / 0.4)
    assert f.noise == pytest.approx(0.1 * math.sqrt(16 / 200))
    assert f.noise_low == pytest.approx(0.09 * math.sqrt(16 / 250)) and f.noise_high == pytest.approx(0.11 * math.sqrt(16 / (100 / 0.6)))


def test_a_target_reached_before_the_budget_stops_the_render_on_noise():
    f = forecast(reading(), cap=1_000_000, noise_target=0.05, time_budget=1000.0)
    assert f.stop == "noise" and f.samples == pytest.approx(64) and f.seconds == pytest.approx(32)


def test_a_target_the_pilot_passed_forecasts_fewer_samples_but_not_below_the_least():
    f = forecast(reading(noise=0.04, low=0.035, high=0.045), cap=1_000_000, noise_target=0.05, least=8)
    assert f.stop == "noise" and f.samples == pytest.approx(10.24) and f.samples_low == 8


def test_the_chi_square_quantile_is_close_to_the_tables():
    # Tables: chi2(0.025, 10) = 3.247, chi2(0.975, 10) = 20.483, chi2(0.975, 100) = 129.56
    assert chi2_quantile(0.025, 10) == pytest.approx(3.247, rel=0.01)
    assert chi2_quantile(0.975, 10) == pytest.approx(20.483, rel=0.01)
    assert chi2_quantile(0.975, 100) == pytest.approx(129.56, rel=0.002)


def test_the_pooled_interval_is_narrow_over_many_even_pixels_and_wide_over_a_few_bright_ones():
    even_low, even_high = pooled_interval(np.ones(10_000), dof=15)
    assert 0.99 < even_low < 1 < even_high < 1.01
    few = np.r_[np.full(3, 1e4), np.ones(10_000)]  # three pixels hold three quarters of the variance
    few_low, few_high = pooled_interval(few, dof=15)
    assert few_low < 0.9 and few_high > 1.15


def noisy_film(rng, samples, sigma, width=40, height=30, bright=None):
    """A film of Gaussian samples around 10 with standard deviation `sigma` (per pixel if an array):
    far enough from 0 that the squared means barely overstate the signal. Grey: the three channels
    of a sample are the same, as they nearly are in a render (one path carries all three)."""
    sigma = np.broadcast_to(np.asarray(sigma, float), (height, width))[:, :, None]
    x = 10.0 + sigma * rng.standard_normal((samples, height, width, 1)).repeat(3, axis=3)
    return Film(x.sum(axis=0), np.square(x).sum(axis=0), samples)


def test_the_noise_interval_covers_the_true_noise_at_its_rate():
    """Gaussian films whose true relative RMS error is known: the interval's coverage is near 95%."""
    rng = np.random.default_rng(7)
    sigma = rng.uniform(0.5, 2.0, (30, 40))
    true = math.sqrt(np.mean(np.square(sigma)) / 16) / 10  # each pixel's mean is 10, its error sigma / 4
    covered = 0
    for _ in range(200):
        noise, low, high, *_ = noise_interval(noisy_film(rng, 16, sigma))
        covered += low <= true <= high
    assert 180 <= covered <= 199  # 95% of 200 is 190, binomial sd 3


def test_a_tracker_waits_for_the_pilot_then_forecasts_from_the_film():
    rng = np.random.default_rng(3)
    tracker = ForecastTracker(cap=1_000_000, start_samples=0, noise_target=0.01, clock=lambda: 0.0)
    assert tracker.update(noisy_film(rng, 8, 5.0), 0.8, 8, 0.8) is None  # 8 samples in 0.8 s: no pilot yet
    film = noisy_film(rng, 16, 5.0)
    f = tracker.update(film, 1.6, 8, 0.8)
    measured = noise_interval(film)
    assert measured.noise == pytest.approx(unbiased_noise(0.5 / 4), rel=0.05)  # samples spread 5 around 10, 16 of them
    assert 1.0 < measured.stop_factor < 1.1  # 600 pixels: the interval's upper end is a few per cent up
    assert isinstance(f, Forecast) and f.stop == "noise"
    assert f.samples == pytest.approx(16 * (measured.noise * measured.stop_factor / 0.01) ** 2)
    assert f.seconds == pytest.approx(f.samples * 0.1)
    assert f.seconds_low < f.seconds < f.seconds_high


def test_a_resumed_film_counts_only_the_time_of_this_render():
    rng = np.random.default_rng(4)
    tracker = ForecastTracker(cap=1_000_000, start_samples=100, noise_target=0.01, clock=lambda: 0.0)
    film = noisy_film(rng, 116, 5.0)
    f = tracker.update(film, 1.6, 16, 1.6)  # 16 samples of this render in 1.6 s
    measured = noise_interval(film)
    need = 116 * (measured.noise * measured.stop_factor / 0.01) ** 2  # about 116 * 21 = 2400 samples in all
    assert f.samples == pytest.approx(need) and f.seconds == pytest.approx((need - 116) * 0.1 + 1.6)


def test_the_tracker_times_the_samples_still_to_render_by_the_latter_half_of_the_render():
    """As pixels stop (adaptive sampling), a sample index costs less: the first passes' speed would overstate the rest."""
    tracker = ForecastTracker(cap=1_000_000, start_samples=0, noise_target=0.001, clock=lambda: 0.0)
    x = 10.0 + 5.0 * np.random.default_rng(5).standard_normal((32, 20, 30, 1)).repeat(3, axis=3)
    films = {n: Film(x[:n].sum(axis=0), np.square(x[:n]).sum(axis=0), n) for n in (8, 16, 24, 32)}
    for samples, seconds in ((8, 1.6), (16, 3.2), (24, 4.0), (32, 4.8)):  # 0.2 s a sample, then 0.1
        tracker.update(films[samples], seconds, 8, 0.8)
    assert tracker.recent_sample_seconds() == pytest.approx(0.1)
    measured = noise_interval(films[16])  # once the pilot was done, at 16
    need = 16 * (measured.noise * measured.stop_factor / 0.001) ** 2
    assert tracker.forecast.seconds == pytest.approx(4.8 + (need - 32) * 0.1)
    assert tracker.forecast.left(4.8) == pytest.approx((need - 32) * 0.1)


def test_the_unbiased_noise_takes_the_noise_out_of_the_signal():
    # sum mean^2 = 100 holds sum se^2 = 4 of noise: the noise is 2/sqrt(96), not 2/10
    assert unbiased_noise(0.2) == pytest.approx(2 / math.sqrt(96))
    assert unbiased_noise(0.001) == pytest.approx(0.001, rel=1e-6)
    assert unbiased_noise(0.9) == pytest.approx(0.9 * math.sqrt(2)) and unbiased_noise(math.inf) == math.inf


def test_timing_spread_and_a_smaller_pilot():
    assert timing_spread([0.1]) == 0.25
    assert timing_spread([0.1, 0.1, 0.1]) == 0.05
    assert 0.05 < timing_spread([0.1, 0.2, 0.1, 0.2]) <= 0.5
    assert scaled_to(reading(per=0.5), 4.0).sample_seconds == 2.0


def test_the_forecast_is_said_in_words():
    from rt.progress import forecast_sentence, percent, spoken_seconds

    assert [spoken_seconds(s) for s in (0.42, 45.2, 130, 2400, 5000)] == ["0.4 s", "45 s", "2 min 10 s", "40 min", "1 h 23 min"]
    assert (percent(0.01), percent(0.0052), percent(0.123)) == ("1%", "0.52%", "12%")
    f = Forecast("noise", 1600, 1296, 1936, 130.0, 110.0, 160.0, 0.01, 0.01, 0.01)
    assert forecast_sentence(f, 0.01) == ("about 2 min 10 s to 1% noise (1 min 50 s to 2 min 40 s, 95% range), "
                                          "about 1,600 samples per pixel")
    f = Forecast("time", 200, 167, 250, 100.0, 100.0, 100.0, 0.028, 0.023, 0.034)
    assert forecast_sentence(f) == "about 2.8% noise at the end of the time budget (2.3% to 3.4%), in about 1 min 40 s"
    f = Forecast("samples", 400, 400, 400, 200.0, 180.0, 220.0, 0.02, 0.018, 0.022, "rare bright paths dominate.")
    assert forecast_sentence(f, 0.01) == (
        "about 2% noise at 400 samples per pixel (1.8% to 2.2%), in about 3 min 20 s (3 min to 3 min 40 s, 95% range): "
        "the sample cap comes before the 1% target; rare bright paths dominate, so it may take longer")


def test_a_dry_run_pilots_the_image_at_its_own_size_unless_even_four_samples_take_too_long():
    from rt.dry_run import LEAST_PILOT_WIDTH, LONGEST_PILOT, pilot_size

    assert pilot_size(200, 100, 1e-7) == (200, 3.0)  # fast: the usual 3 s
    width, seconds = pilot_size(600, 600, 2e-6)  # 4 samples take 2.9 s: a little longer, at its own size
    assert width == 600 and seconds == pytest.approx(1.3 * 4 * 2e-6 * 360_000)
    width, seconds = pilot_size(4000, 3000, 2e-6)  # 4 samples would take 125 s
    assert LEAST_PILOT_WIDTH <= width < 4000 and seconds == LONGEST_PILOT
    assert 1.3 * 4 * 2e-6 * width * (width * 0.75) == pytest.approx(LONGEST_PILOT, rel=0.01)


def test_an_effects_cost_is_said_in_words():
    from rt.effect_costs import Cost, Measure, Variant, compare

    with_it = Measure(sample_seconds=0.018, variance=169.0, mean=0.5, mean_error=0.001, samples=100)
    without = Measure(sample_seconds=0.010, variance=100.0, mean=0.52, mean_error=0.001, samples=180)
    cost = compare(Variant("defocus", "a pinhole camera: aperture 0", None), with_it, without)
    assert (cost.time, cost.noise) == (pytest.approx(1.8), pytest.approx(1.3))
    assert cost.time_to_noise == pytest.approx(1.8 * 1.69)
    assert cost.bias == pytest.approx(0.04) and cost.bias_error == pytest.approx(math.hypot(0.001, 0.001) / 0.5)
    assert cost.sentence() == ("defocus (a pinhole camera: aperture 0): time per sample x1.80, noise x1.30 (so x3.04 the time "
                               "to the same noise), bias +4.0% if removed (+/- 0.28%)")
    within = compare(Variant("motion blur", "closed", None), with_it, Measure(0.010, 100.0, 0.5005, 0.001, 180))
    assert "no bias seen if removed (within +/- 0.85%)" in within.sentence()
    dark = compare(Variant("environment map", "a black background instead", None), with_it, Measure(0.008, 0.0, 0.0, 0.0, 200))
    assert dark.sentence() == ("environment map (a black background instead): time per sample x2.25; it is the scene's only "
                               "light (the image is black without it)")
    assert isinstance(dark, Cost)


def test_a_dry_run_refuses_a_cluster_and_a_resume_in_one_sentence(tmp_path, capsys):
    from rt.render_job import RenderOptions, Stop, prepare

    scene = tmp_path / "s.yaml"
    scene.write_text("shapes: [{type: sphere, center: [0, 0, -2], radius: 1}]\n")
    for extra, name in (({"cluster": "local"}, "--cluster"), ({"resume": tmp_path / "run.npz"}, "--resume")):
        with pytest.raises(Stop):
            prepare(RenderOptions(scene=scene, output=tmp_path / "s.png", dry_run=True, **extra))
        assert capsys.readouterr().err == (f"error: --dry-run forecasts a fresh render in this process: it cannot be "
                                           f"combined with {name}\n")


def test_each_variant_of_explain_takes_away_its_own_effect_and_no_other(tmp_path):
    """The scene graphs --explain renders (rt/effect_costs.py), checked by the effects rt validate reports: no render."""
    from renderer.compile import compile_scene
    from rt.effect_costs import variants
    from scenefmt.effects import summarize
    from scenefmt.validation import load_source

    scene = tmp_path / "all.yaml"
    scene.write_text("""
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40, aperture: 0.2}
image: {width: 16, max_depth: 12}
shutter: {open: 0, close: 1}
background: {type: sky}
materials:
  gold: {type: conductor, metal: Au, roughness: 0.3}
  red: {type: plastic, albedo: [0.9, 0.1, 0.1], roughness: 0.2}
  grey: {type: lambertian, albedo: [0.5, 0.5, 0.5]}
media: {fog: {type: constant, density: 2.0}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: grey}
  - {type: sphere, center: [-1, 0.5, 0], radius: 0.5, material: gold}
  - {type: moving_sphere, center0: [1, 0.5, 0], center1: [1, 0.7, 0], radius: 0.5, material: red}
  - {type: sphere, center: [0, 0.5, -1], radius: 0.5, interior: fog}
""")
    graph = load_source(scene).graph
    on = {e.key for e in summarize(graph).effects if e.on}
    found = {v.effect: v for v in variants(graph, 12)}
    assert list(found) == ["path depth", "media", "defocus", "motion blur", "glossy materials"]
    assert found["path depth"].max_depth == 4 and found["path depth"].graph is graph
    taken = {"media": {"media"}, "defocus": {"defocus"}, "motion blur": {"motion"},
             "glossy materials": {"conductors", "plastics"}}
    for name, keys in taken.items():
        variant = found[name].graph
        assert {e.key for e in summarize(variant).effects if e.on} == on - keys, name
        compile_scene(variant)  # the renderer flattens it
    assert {e.key for e in summarize(graph).effects if e.on} == on  # the scene itself is untouched


def test_a_dry_run_times_its_pilot_by_the_latter_half_of_its_samples():
    from rt.dry_run import latter_half_speed

    assert latter_half_speed([(1, 0.5), (4, 0.4), (16, 1.6)]) == pytest.approx(0.1)  # the first pass's start-up left out
    assert latter_half_speed([(8, 0.8), (8, 1.6)]) == pytest.approx(0.2)
    assert latter_half_speed([(16, 1.6)]) == pytest.approx(0.1)


def test_a_noise_target_stops_on_the_estimates_upper_end():
    f = forecast(Reading(16, 0.1, 0.09, 0.11, 0.5, 0.0, None, 1.1), cap=1_000_000, noise_target=0.01)
    assert f.stop == "noise" and f.samples == pytest.approx(16 * 11 ** 2)  # the upper end, 1.1 times the noise, at 1%
    assert f.noise == pytest.approx(0.01 / 1.1)
    # the low end takes the factor as 1 (it falls toward the noise as the estimate firms up), the high end keeps it
    assert f.samples_low == pytest.approx(16 * 9 ** 2) and f.samples_high == pytest.approx(16 * 12.1 ** 2)
