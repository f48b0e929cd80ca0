"""A noise target stops on the upper end of the error's 95% interval, and not while the estimate
warns that rare bright samples make it untrustworthy (renderer/session.py NoiseTarget).

The render session runs with an executor that replays fixed samples into every array of the film
(sums, squares, batches, peaks, counts), as the kernels fill them: no Numba, a few milliseconds.
"""

import numpy as np

from renderer.config import BATCHES
from renderer.error_estimate import VarianceTrend
from renderer.executor import KernelTime, Step
from renderer.film import Film, estimate_noise
from renderer.session import render_progressively


class ReplayPasses:
    """Adds the samples x[s] (N, h, w, 3) in order, `per_step` a step."""

    can_switch_kernel = False
    stops_on_time_before_first_step = True

    def __init__(self, x, per_step=4):
        self.x, self.per_step = x, per_step

    def start(self, film, features, notify=None):
        self.film = film
        return KernelTime()

    def advance(self, plan, should_stop=None):
        film = self.film
        n = min(self.per_step, plan.target - film.samples)
        for s in range(film.samples, film.samples + n):
            sample = self.x[s]
            film.total += sample
            film.total_sq += sample * sample
            film.batch[:, :, s % BATCHES] += sample
            larger = np.square(sample).sum(axis=2) > np.square(film.peak).sum(axis=2)
            film.peak[larger] = sample[larger]
            film.counts += 1
        film.samples += n
        return Step(n, rays=n, bad_samples=0, seconds=1e-6)

    def switch_kernel(self, features, notify=None):
        return KernelTime()

    def close(self):
        pass


def samples(n=160, spikes=((2, 3), (9, 12), (13, 5)), at=(1, 4, 6)):
    """A grey 16x16 image of 1 +- 0.1 whose three pixels each hold one sample of 4 early on: rare
    bright samples that dominate the variance at first and matter less as samples pile up."""
    rng = np.random.default_rng(2)
    x = np.repeat(rng.normal(1.0, 0.1, (n, 16, 16, 1)), 3, axis=3)
    for (row, col), s in zip(spikes, at):
        x[s, row, col] = 4.0
    return x


def test_a_noise_target_waits_while_the_warning_holds_then_stops_on_the_intervals_upper_end():
    x = samples()
    film = Film.empty(16, 16)
    result = render_progressively(ReplayPasses(x), film, target=160, kernel="general", noise_target=0.1)
    assert result.stats.stop_reason == "noise"
    stopped = film.samples
    # At 16 samples the interval was already under the target, but the estimate warned.
    early = Film.empty(16, 16)
    render_progressively(ReplayPasses(x), early, target=16, kernel="general")
    before = estimate_noise(early)
    assert before.high <= 0.1 and before.warning is not None and before.suspect[2, 3]
    assert stopped > 16
    after = estimate_noise(film)
    assert after.warning is None and after.high == result.stats.noise_high <= 0.1


def test_without_rare_samples_it_stops_as_soon_as_the_upper_end_is_below_the_target():
    x = samples(spikes=(), at=())
    film = Film.empty(16, 16)
    result = render_progressively(ReplayPasses(x), film, target=160, kernel="general", noise_target=0.01)
    assert result.stats.stop_reason == "noise"
    est = estimate_noise(film)
    assert est.warning is None and est.high <= 0.01 < est.high * 1.3  # stopped within a step of it


def test_the_trend_warns_when_the_spread_per_sample_grows():
    trend = VarianceTrend()
    for n in (8, 16, 32):
        trend.add(n, 0.1 / np.sqrt(n))  # a sound estimate: the spread per sample stays level
    assert trend.warning() is None
    trend.add(64, 0.1)  # five times the spread per sample of 16 samples before
    assert "rare bright paths are still being found" in trend.warning()
    assert "from 16 to 64 samples per pixel" in trend.warning()
