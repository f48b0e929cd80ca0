"""Adaptive sampling's session side (renderer/adaptive_plan.py) and its outputs, without Numba.

A numpy executor stands in for the kernels: each pixel draws its samples from its own seeded
generator keyed by (pixel, sample) and stops by the same rule as adaptive.pixel_converged, so
the session's pilot, threshold, checkpoints and stops are checked in a second.
"""

import math

import numpy as np
import pytest

from renderer.adaptive_plan import (BATCHES, CHECK_GROWTH, FLOOR, GUARD_SHARE, MARGIN, PILOT, TAIL, is_checkpoint,
                                    neighbourhood_guard, next_checkpoint, pixel_mean_variance, predicted_error,
                                    threshold_for)
from renderer.executor import KernelTime, Step
from renderer.film import Film
from renderer.sample_counts import sample_count_image
from renderer.sampling import Sampling, uniform_sampling
from renderer.session import render_progressively
from renderer.state import RenderKey, load_state, save_state

W, H = 12, 8


def sample(pixel: int, s: int, sigma: np.ndarray) -> float:
    """Sample s of a pixel: mean 1, spread sigma[pixel], the same whatever the passes."""
    rng = np.random.default_rng([pixel, s])
    return 1.0 + sigma[pixel] * rng.standard_normal()


def converged(film: Film, row: int, col: int, n: int, sampling: Sampling) -> bool:
    """adaptive.pixel_converged's rule in numpy."""
    squares = film.total_sq[row, col].sum()
    peak2 = float(np.dot(film.peak[row, col], film.peak[row, col]))
    if peak2 > sampling.tail * squares and peak2 > 3 * sampling.threshold ** 2 * n ** 3:
        return False
    counts = np.array([[n]])
    se2 = pixel_mean_variance(film.batch[row:row + 1, col:col + 1], counts)[0, 0]
    if sampling.guard.size:
        se2 = max(se2, sampling.guard[row, col] / n)
    return se2 <= sampling.threshold ** 2 * n


class NumpyPasses:
    """An adaptive executor in numpy: passes of `per_step` samples over the pixels not done."""

    can_switch_kernel = False
    stops_on_time_before_first_step = True

    def __init__(self, sigma, per_step=5):
        self.sigma = sigma
        self.per_step = per_step
        self.sampling = uniform_sampling()
        self.set = []  # every sampling set, in order
        self.targets = []  # every step's target

    def start(self, film, features, notify=None):
        self.film = film
        return KernelTime()

    def set_sampling(self, sampling):
        self.set.append((self.film.samples if hasattr(self, "film") else None, sampling))
        self.sampling = sampling

    def advance(self, plan, should_stop=None):
        film = self.film
        self.targets.append(plan.target)
        n = min(self.per_step, plan.target - film.samples)
        for row in range(H):
            for col in range(W):
                if film.done[row, col]:
                    continue
                for s in range(film.samples, film.samples + n):
                    v = sample(row * W + col, s, self.sigma)
                    film.counts[row, col] = s + 1
                    film.total[row, col] += v
                    film.total_sq[row, col] += v * v
                    film.batch[row, col, s % BATCHES] += v
                    if 3 * v * v > float(np.dot(film.peak[row, col], film.peak[row, col])):
                        film.peak[row, col] = v
                    t = self.sampling
                    if t.threshold > 0 and (s + 1) % BATCHES == 0 and s + 1 >= t.floor and converged(film, row, col, s + 1, t):
                        film.done[row, col] = 1
                        break
        film.samples += n
        return Step(n, n * W * H, 0, 1e-3)

    def switch_kernel(self, features, notify=None):
        raise NotImplementedError

    def close(self):
        pass


def sigmas():
    # A quiet left half and a noisy right half.
    sigma = np.full(W * H, 0.05)
    sigma.reshape(H, W)[:, W // 2:] = 0.6
    return sigma


def test_checkpoints_are_whole_rounds_growing_from_the_pilot():
    checks = [PILOT]
    while checks[-1] < 2000:
        checks.append(next_checkpoint(checks[-1]))
    assert all(c % BATCHES == 0 for c in checks)
    assert all(b > a for a, b in zip(checks, checks[1:]))
    assert all(b <= math.ceil(a * CHECK_GROWTH / BATCHES) * BATCHES + BATCHES for a, b in zip(checks, checks[1:]))
    assert [s for s in range(1, checks[-1] + 1) if is_checkpoint(s)] == checks
    assert FLOOR == PILOT + BATCHES


def test_the_batch_variance_is_the_spread_of_the_batch_means():
    rng = np.random.default_rng(3)
    values = rng.normal(size=(2, 3, 40, 3))  # 40 samples per pixel: 5 per batch
    batch = np.stack([values[:, :, k::BATCHES].sum(axis=2) for k in range(BATCHES)], axis=2)
    means = values.reshape(2, 3, 5, BATCHES, 3).mean(axis=2)  # sample s = 8 j + k is in batch k
    expected = means.var(axis=2, ddof=1).mean(axis=-1) / BATCHES
    got = pixel_mean_variance(batch, np.full((2, 3), 40))
    assert np.allclose(got, expected, rtol=1e-12)


def test_the_threshold_predicts_the_margin_of_the_target():
    sigma2 = np.array([0.0, 0.01, 0.04, 1.0, 4.0])
    film = Film.empty(5, 1)
    film.samples = PILOT
    film.counts[:] = PILOT
    film.total[:] = PILOT  # mean 1 in every channel
    # Batch sums whose spread gives each pixel the variance sigma2 of one sample.
    # Batch means 1 +- d: their variance 8 d^2 / 7 over 8 batches is d^2 / 7 for the mean.
    d = np.sqrt((BATCHES - 1) * sigma2[:, None] / PILOT) * np.array([1, -1] * (BATCHES // 2), float)
    film.batch[0] = ((1.0 + d) * (PILOT / BATCHES))[:, :, None]
    se2 = pixel_mean_variance(film.batch, film.counts)
    assert np.allclose(se2[0] * PILOT, sigma2, rtol=1e-9)
    threshold = threshold_for(film, 0.05, 100_000)
    signal = 1.0 - float(np.mean(se2))
    assert predicted_error(se2[0] * PILOT, threshold, FLOOR, 100_000) == pytest.approx((MARGIN * 0.05) ** 2 * signal, rel=0.05)
    # A target that even the cap cannot reach: no pixel stops.
    assert threshold_for(film, 1e-6, 1000) == 0.0


def test_the_session_pilots_then_spends_samples_where_the_noise_is():
    sigma = sigmas()
    executor = NumpyPasses(sigma)
    film = Film.empty(W, H)
    result = render_progressively(executor, film, target=5000, kernel="general", noise_target=0.02, adaptive=True)
    # The rule is set once, when every pixel holds the pilot, and kept in the film.
    assert len(executor.set) == 1 and executor.set[0][0] == PILOT
    threshold, floor, tail, guard = film.stopping
    assert (threshold, floor, tail) == (executor.sampling.threshold, FLOOR, TAIL) and threshold > 0
    assert guard.shape == (H, W) and executor.sampling.guard is not None
    # No step went past the pilot before the rule was set, nor past a checkpoint.
    assert all(t == PILOT for t, s in zip(executor.targets, range(len(executor.targets))) if t <= PILOT)
    assert all(is_checkpoint(t) for t in executor.targets)
    assert result.stats.stop_reason == "noise" and result.stats.pixels_done is not None
    counts = film.counts
    # (The quiet column beside the noisy half is guarded by its neighbours' spread.)
    quiet, noisy = counts[:, : W // 2 - 1], counts[:, W // 2:]
    assert FLOOR <= quiet.min() and quiet.max() < noisy.min()
    # Samples in proportion to the spread: about 12 times as many on the noisy half.
    assert 6 < noisy.mean() / quiet.mean() < 16
    # The image's true error (mean 1 everywhere) is near the margin of the target.
    error = math.sqrt(float(np.mean(np.square(film.mean() - 1.0))))
    assert error < 0.02 * 1.3


def test_the_same_render_split_by_a_resume_gives_the_same_film(tmp_path):
    sigma = sigmas()
    whole = Film.empty(W, H)
    render_progressively(NumpyPasses(sigma, per_step=7), whole, target=5000, kernel="general", noise_target=0.02,
                         adaptive=True)
    part = Film.empty(W, H)
    steps = []
    # Stopped after 20 steps of 3 samples (the rule depends on the cap: the same cap is kept).
    render_progressively(NumpyPasses(sigma, per_step=3), part, target=5000, kernel="general", noise_target=0.02,
                         adaptive=True, progress=lambda stats: steps.append(1), should_stop=lambda: len(steps) >= 20)
    assert PILOT < part.samples < whole.samples and part.stopping is not None and part.stopping[0] > 0
    key = RenderKey("x", W, H, 5, 1)
    save_state(tmp_path / "s.npz", part, key)
    resumed = load_state(tmp_path / "s.npz", key)
    assert resumed.stopping[:3] == part.stopping[:3] and np.array_equal(resumed.stopping[3], part.stopping[3])
    render_progressively(NumpyPasses(sigma, per_step=11), resumed, target=5000, kernel="general", noise_target=0.02,
                         adaptive=True)
    assert resumed.samples == whole.samples
    for name in ("total", "total_sq", "batch", "counts", "done"):
        assert np.array_equal(getattr(resumed, name), getattr(whole, name)), name


def test_without_adaptive_every_pixel_takes_every_sample():
    film = Film.empty(W, H)
    executor = NumpyPasses(sigmas())
    render_progressively(executor, film, target=48, kernel="general", noise_target=1e-4)
    assert executor.set == [] and film.stopping is None and (film.counts == 48).all()


def test_a_state_with_a_broken_stopping_rule_is_refused(tmp_path):
    import json
    import zipfile

    film = Film.empty(2, 2)
    film.samples = 8
    film.counts[:] = 8
    film.stopping = (0.1, FLOOR, TAIL, np.full((2, 2), 0.5))
    key = RenderKey("x", 2, 2, 5, 1)
    save_state(tmp_path / "s.npz", film, key)
    loaded = load_state(tmp_path / "s.npz", key).stopping
    assert loaded[:3] == (0.1, FLOOR, TAIL) and np.array_equal(loaded[3], np.full((2, 2), 0.5))
    with zipfile.ZipFile(tmp_path / "s.npz") as z:
        members = {n: z.read(n) for n in z.namelist()}
    meta = json.loads(str(np.load(tmp_path / "s.npz")["meta"]))
    meta["stopping"] = [float("nan"), 3, 2.0]
    arrays = {n[:-4]: np.load(tmp_path / "s.npz")[n[:-4]] for n in members if n != "meta.npy"}
    np.savez(tmp_path / "bad.npz", **arrays, meta=np.array(json.dumps(meta)))
    with pytest.raises(ValueError, match="stopping rule"):
        load_state(tmp_path / "bad.npz", key)
    # A rule without its guard, and a negative guard.
    del meta["stopping"]
    np.savez(tmp_path / "bad.npz", **arrays, meta=np.array(json.dumps(meta)))
    with pytest.raises(ValueError, match="come only together"):
        load_state(tmp_path / "bad.npz", key)
    meta["stopping"] = [0.1, FLOOR, TAIL]
    arrays["guard"] = -arrays["guard"] - 1
    np.savez(tmp_path / "bad.npz", **arrays, meta=np.array(json.dumps(meta)))
    with pytest.raises(ValueError, match="not finite or are negative"):
        load_state(tmp_path / "bad.npz", key)


def test_the_sample_count_image():
    counts = np.array([[40, 80], [160, 0]])
    raw = sample_count_image(counts, raw=True)
    assert raw.shape == (2, 2, 3) and np.array_equal(raw[:, :, 1], counts)
    grey = sample_count_image(counts, raw=False)
    assert grey.max() == 1.0 and grey[1, 0, 0] == 1.0 and grey[0, 0, 0] == pytest.approx(1 / 16)
    assert not sample_count_image(np.zeros((2, 2), np.int64), raw=False).any()


def test_the_guard_is_a_share_of_the_noisiest_neighbour():
    sigma2 = np.zeros((5, 6))
    sigma2[2, 3] = 8.0
    guard = neighbourhood_guard(sigma2)
    assert guard.flags.c_contiguous and guard.dtype == np.float64
    assert np.array_equal(guard > 0, np.pad(np.ones((3, 3), bool), ((1, 1), (2, 1))))
    assert guard.max() == GUARD_SHARE * 8.0


def test_a_quiet_pixel_beside_noisy_ones_is_judged_by_their_spread_too():
    # Column 5 is noisy; column 4, beside it, is as quiet as the rest (as a pixel at a lamp's
    # edge whose pilot samples all hit the lamp looks).
    sigma = np.full(W * H, 0.05)
    sigma.reshape(H, W)[:, 5] = 1.0
    executor = NumpyPasses(sigma)
    film = Film.empty(W, H)
    render_progressively(executor, film, target=5000, kernel="general", noise_target=0.02, adaptive=True)
    guard = film.stopping[3]
    assert (guard[:, 4] > 0.1 * 1.0 * GUARD_SHARE).all() and (guard[:, 1] < 0.01).all()
    assert film.counts[:, 4].min() > film.counts[:, 1].max()


def test_the_forecast_of_an_adaptive_render_counts_the_samples_its_rule_will_take():
    """Once the rule is fixed, the forecast says the samples the pixels are expected to end with (not
    a uniform render's), and the render's mean samples come within its range (NumpyPasses: noisy half,
    quiet half)."""
    from renderer.adaptive_plan import predicted_counts

    seen = []
    executor = NumpyPasses(sigmas())
    film = Film.empty(W, H)

    def keep(stats):
        if film.stopping is not None and stats.forecast is not None and not seen:
            seen.append((stats.forecast, predicted_counts(film).copy()))

    result = render_progressively(executor, film, target=5000, kernel="general", noise_target=0.02, adaptive=True,
                                  progress=keep)
    assert seen, "no forecast after the stopping rule was fixed"
    forecast, predicted = seen[0]
    assert forecast.samples == pytest.approx(float(predicted.mean()))
    assert predicted.min() >= FLOOR and predicted[:, W // 2:].mean() > 4 * predicted[:, : W // 2 - 1].mean()
    took = float(film.counts.mean())
    assert result.stats.stop_reason == "noise"
    assert 0.6 * forecast.samples <= took <= 1.2 * forecast.samples, (forecast.samples, took)
