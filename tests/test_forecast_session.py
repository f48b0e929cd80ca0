"""The forecast inside the render session (renderer/session.py, renderer/forecast.py): when it
appears, how close its samples come to where a render stops, and that under a noise target the
kernel switch waits for it. A pure-numpy executor of Gaussian samples: no kernel, fast."""

from __future__ import annotations

import numpy as np
import pytest

from renderer.executor import KernelTime, Step
from renderer.film import Film
from renderer.session import render_progressively
from renderer.variants import GENERAL, KernelFeatures

NEEDED = KernelFeatures(motion=False, defocus=False, media=False)


class GaussianPasses:
    """Adds `per_step` samples of 1 + N(0, sigma^2) to every pixel of a grey film per step."""

    can_switch_kernel = True
    stops_on_time_before_first_step = True

    def __init__(self, per_step=4, sigma=1.0, seed=1):
        self.per_step, self.sigma = per_step, sigma
        self.rng = np.random.default_rng(seed)
        self.calls = []

    def start(self, film, features, notify=None):
        self.film = film
        return KernelTime()

    def advance(self, plan, should_stop=None):
        film = self.film
        n = min(self.per_step, plan.target - film.samples)
        x = 1.0 + self.sigma * self.rng.standard_normal((n, film.height, film.width, 1)).repeat(3, axis=3)
        film.total += x.sum(axis=0)
        film.total_sq += np.square(x).sum(axis=0)
        film.samples += n
        self.calls.append(("advance", film.samples))
        return Step(n, rays=n, bad_samples=0, seconds=1e-4)

    def switch_kernel(self, features, notify=None):
        self.calls.append(("switch", self.film.samples))
        return KernelTime()

    def close(self):
        pass


def test_the_forecast_appears_after_the_pilot_and_foresees_where_the_render_stops():
    seen = []
    result = render_progressively(GaussianPasses(), Film.empty(30, 20), target=1_000_000, kernel="general",
                                  noise_target=0.02, progress=lambda stats: seen.append((stats.samples, stats.forecast)))
    assert all(f is None for n, f in seen if n < 16)
    first = next(f for n, f in seen if n >= 16)
    assert first is not None and first.stop == "noise"
    stopped = result.film.samples  # the noise of N(0, 1) samples around 1 is 1 / sqrt(n): about 2,500
    assert result.stats.stop_reason == "noise"
    assert first.samples_low <= stopped <= first.samples_high
    assert first.samples == pytest.approx(stopped, rel=0.1)
    assert result.stats.forecast.samples == pytest.approx(stopped, rel=0.02)  # refined to the end


def test_under_a_noise_target_the_kernel_switch_waits_for_the_pilots_forecast(monkeypatch):
    import renderer.session as session

    monkeypatch.setattr(session, "worth_specialising", lambda seconds: True)
    monkeypatch.setattr(session, "first_kernel", lambda needed, choice: GENERAL)
    executor = GaussianPasses()
    result = render_progressively(executor, Film.empty(8, 8), target=1_000_000, needed=NEEDED, kernel="auto",
                                  noise_target=0.05)
    switches = [n for kind, n in executor.calls if kind == "switch"]
    assert switches == [16]  # not after the first pass, whose noise is of 4 samples
    assert result.stats.features == NEEDED


def test_a_time_budget_forecasts_the_noise_at_its_end():
    result = render_progressively(GaussianPasses(per_step=8), Film.empty(30, 20), target=64, kernel="general",
                                  time_budget=60.0)
    f = result.stats.forecast
    assert f is not None and f.stop == "samples" and f.samples == 64  # the cap comes long before the minute
    assert f.noise_low <= 1 / 8 <= f.noise_high  # N(0, 1) around 1: 1 / sqrt(64)
