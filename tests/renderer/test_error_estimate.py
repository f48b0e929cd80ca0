"""The error estimate with its confidence, and its warning, on films of known distributions.

Each film is made from an array of single samples whose true mean is known, split into the
interleaved batches the kernels keep (sample s in batch s % BATCHES), with each pixel's largest
sample as its peak. Fixed seeds: every outcome is deterministic, and the tolerances are the
binomial spread of a coverage rate (or the noise of an average) at about four standard deviations.
"""

import math
from typing import Optional

import numpy as np
import pytest

from renderer.error_estimate import estimate
from renderer.film import Film, estimate_noise
from renderer.quantiles import chi2_quantile, f_quantile

B = 8  # renderer.config.BATCHES


def film_of(x: np.ndarray, start: int = 0, stopped: Optional[np.ndarray] = None) -> Film:
    """The film of single samples x (N, h, w, 3): sums, squares, batch sums, peak and counts.
    `stopped` (h, w) holds, where > 0, the samples after which adaptive sampling stopped a pixel."""
    n = x.shape[0]
    index = np.arange(start, start + n)[:, None, None]
    held = np.ones(x.shape[:3], bool) if stopped is None else (index - start < np.where(stopped > 0, stopped, n))
    x = np.where(held[..., None], x, 0.0)
    batch = np.stack([np.where((index % B == b)[..., None], x, 0.0).sum(axis=0) for b in range(B)], axis=2)
    largest = np.square(x).sum(axis=3).argmax(axis=0)
    peak = np.take_along_axis(x, largest[None, :, :, None], axis=0)[0]
    counts = held.sum(axis=0).astype(np.int64)
    done = (counts < n).astype(np.uint8)
    return Film(x.sum(axis=0), (x * x).sum(axis=0), n, batch, peak, counts, done)


def realised(film: Film, truth: np.ndarray) -> float:
    """The relative RMS error of the film's image against the true image."""
    return math.sqrt(np.sum((film.total / film.samples - truth) ** 2) / np.sum(truth**2))


def test_the_quantiles_are_the_tabulated_ones():
    assert chi2_quantile(0.05, 7) == pytest.approx(2.16735, rel=1e-5)
    assert chi2_quantile(0.975, 1) == pytest.approx(5.02389, rel=1e-5)
    assert f_quantile(0.975, 2, 14) == pytest.approx(4.85670, rel=1e-5)
    assert f_quantile(0.025, 10, 20) == pytest.approx(0.29252, rel=1e-4)
    # Huge effective counts stay quick and near 1.
    assert 1.0 < f_quantile(0.975, 5e5, 3.5e6) < 1.01


def gaussian_image(rng, n, h=6, w=8):
    """Samples of an image whose pixels differ in value and noise (a few pixels far noisier)."""
    mean = rng.uniform(0.2, 1.0, (h, w, 1)) * np.array([1.0, 0.8, 0.6])
    sigma = rng.uniform(0.1, 0.5, (h, w, 1)) * np.array([1.0, 0.9, 0.7])
    sigma[rng.random((h, w)) < 0.1] *= 6.0
    # The channels share most of their noise, as a pixel's colours share its paths.
    z = 0.8 * rng.standard_normal((n, h, w, 1)) + 0.6 * rng.standard_normal((n, h, w, 3))
    return mean, mean + sigma * z


@pytest.mark.parametrize("n", [16, 21])
def test_the_interval_covers_the_realised_error_at_its_rate(n):
    """Gaussian samples, 21 of them in unequal batches too: the 95% interval holds the film's true
    error in 95% of 200 films (binomial sd 1.5%), and the estimate never warns."""
    rng = np.random.default_rng(n)
    covered = warned = 0
    for _ in range(200):
        truth, x = gaussian_image(rng, n)
        film = film_of(x)
        est = estimate_noise(film)
        covered += est.low <= realised(film, truth) <= est.high
        warned += est.warning is not None
    assert 0.90 <= covered / 200 <= 0.99
    assert warned == 0


def test_unequal_batches_weigh_their_sizes():
    """13 samples: five batches of 2 and three of 1; the variance of the mean is still unbiased."""
    rng = np.random.default_rng(3)
    x = rng.normal(1.0, 0.5, (13, 40, 40, 3))
    est = estimate(film_of(x))
    assert est.batched
    expected = 0.5 / math.sqrt(13)
    # The mean of 1600 pixels' standard errors (chi with 7 dof: mean 0.964 of the truth, sd 0.27 each).
    assert float(est.error.mean()) == pytest.approx(0.964 * expected, rel=0.04)


def test_pixels_stopped_early_are_judged_by_their_own_samples():
    """Adaptive sampling stopped half the pixels at 16 samples (two rounds), the others went on to 48."""
    rng = np.random.default_rng(4)
    x = rng.normal(1.0, 0.5, (48, 40, 40, 3))
    stopped = np.where(rng.random((40, 40)) < 0.5, 16, 0)
    est = estimate(film_of(x, stopped=stopped))
    assert est.batched
    for held, pixels in ((16, stopped > 0), (48, stopped == 0)):
        # chi with 7 dof: mean 0.964 of the truth, sd 0.27 per pixel; about 800 pixels each.
        assert float(est.error[pixels].mean()) == pytest.approx(0.964 * 0.5 / math.sqrt(held), rel=0.05)
    assert 0.0 < est.low < est.relative_rms < est.high < math.inf and est.warning is None


def test_each_pixels_upper_bound_holds_at_its_rate():
    rng = np.random.default_rng(5)
    x = rng.normal(1.0, 0.5, (32, 50, 50, 3))
    x[..., 1:] = x[..., :1]  # grey: one error per pixel
    est = estimate(film_of(x))
    truth = 0.5 / math.sqrt(32)
    held = float(np.mean(est.error_high >= truth))
    assert 0.93 <= held <= 0.97  # one-sided 95% over 2500 pixels (sd 0.4%)
    assert np.all(est.error_high >= est.error)


def stratified_image(rng, n, h=10, w=10):
    """Samples of f(u) = u^2 with each batch's samples stratified over [0, 1): within a batch they
    are negatively correlated, batches are independent (true pixel value 1/3)."""
    per = n // B
    x = np.empty((n, h, w, 3))
    for b in range(B):
        strata = (np.arange(per)[:, None, None] + rng.random((per, h, w))) / per
        x[b::B] = (strata**2)[..., None]
    return np.full((h, w, 3), 1.0 / 3.0), x


def test_stratified_batches_stay_honest_where_single_samples_overstate():
    rng = np.random.default_rng(7)
    estimated, per_sample, actual, covered = [], [], [], 0
    for _ in range(80):
        truth, x = stratified_image(rng, 64)
        film = film_of(x)
        est = estimate(film)
        error = realised(film, truth)
        estimated.append(est.relative_rms**2)
        actual.append(error**2)
        plain = Film(film.total, film.total_sq, film.samples)  # batches left empty: the per-sample variance
        per_sample.append(estimate(plain).relative_rms**2)
        covered += est.low <= error <= est.high
    # Batch means: the mean squared estimate matches the mean squared error (80 films of 100 pixels).
    assert np.mean(estimated) == pytest.approx(np.mean(actual), rel=0.1)
    # Single samples take the stratified samples for independent ones: far too pessimistic.
    assert np.mean(per_sample) > 4 * np.mean(actual)
    assert 0.90 <= covered / 80 <= 1.0


def heavy_image(rng, n, h=16, w=16, p=1e-3, spike=1000.0):
    """A grey image of 1 +- 0.1 whose samples are, once in 1/p, a rare huge value (a caustic)."""
    x = rng.normal(1.0, 0.1, (n, h, w, 1)) + spike * (rng.random((n, h, w, 1)) < p)
    return np.repeat(x, 3, axis=3)


def test_rare_huge_samples_raise_the_warning_and_name_the_pixels():
    """About four rare huge samples in a 16-sample image: the image's variance rests on them."""
    rng = np.random.default_rng(11)
    seen = fired = 0
    for _ in range(30):
        x = heavy_image(rng, 16)
        spikes = (x[..., 0] > 100).sum(axis=0)
        if not spikes.any():
            continue
        seen += 1
        est = estimate(film_of(x))
        if est.warning is not None:
            fired += 1
            assert "rare bright paths dominate" in est.warning and "several times larger" in est.warning
            # The pixels named are those whose one huge sample holds their variance.
            assert np.array_equal(est.suspect, spikes == 1)
    assert seen >= 25 and fired >= seen - 1


@pytest.mark.parametrize("n, p", [(16, 1e-3), (256, 1e-3), (16, 1e-2), (256, 1e-4)])
def test_under_rare_huge_samples_the_interval_holds_or_the_warning_fires(n, p):
    """From about 4 to 40 rare samples in an image whose true relative error is about 0.4: either
    the interval (widened by how unevenly the batches scatter) holds the true error, or the
    warning says it cannot be trusted, in at least 90% of 30 films."""
    rng = np.random.default_rng(int(n / p))
    spike = 0.4 / (math.sqrt(p / n) - 0.4 * p)
    truth = np.full((16, 16, 3), 1.0 + spike * p)
    kept = 0
    for _ in range(30):
        film = film_of(heavy_image(rng, n, p=p, spike=spike))
        est = estimate(film)
        kept += est.warning is not None or est.low <= realised(film, truth) <= est.high
    assert kept >= 27


@pytest.mark.parametrize("kind", ["gaussian", "uniform", "light edge"])
@pytest.mark.parametrize("n", [16, 64, 256])
def test_light_tails_never_warn(kind, n):
    """Light-tailed pixels, including one that is either a lamp (15) or a wall (0.7) depending on
    where in it a sample falls (the edge of a light seen directly: rare-ish bright samples in many
    pixels, which the image's estimate averages honestly)."""
    rng = np.random.default_rng(13)
    for _ in range(6):
        if kind == "gaussian":
            x = rng.normal(1.0, 0.3, (n, 16, 16, 3))
        elif kind == "uniform":
            x = rng.random((n, 16, 16, 3))
        else:
            cover = rng.random((1, 16, 16, 1))
            x = np.where(rng.random((n, 16, 16, 1)) < cover, 15.0, 0.7) * np.ones(3)
        assert estimate(film_of(x)).warning is None


def test_films_without_batches_or_with_few_samples_give_figures_never_nan():
    rng = np.random.default_rng(17)
    x = rng.normal(1.0, 0.2, (5, 4, 4, 3))
    est = estimate(film_of(x))  # fewer samples than batches: single samples' variance
    assert not est.batched and 0 < est.low <= est.relative_rms <= est.high < math.inf
    old = Film(x.sum(axis=0), (x * x).sum(axis=0), 5)  # a film without batches (an old state)
    assert not estimate(old).batched and math.isfinite(estimate(old).high)
    one = estimate(film_of(x[:1]))
    assert one.relative_rms == math.inf and one.warning is None
    flat = estimate(film_of(np.ones((16, 4, 4, 3))))
    assert (flat.relative_rms, flat.low, flat.high, flat.warning) == (0.0, 0.0, 0.0, None)
    black = estimate(film_of(np.zeros((16, 4, 4, 3))))
    assert black.relative_rms == 0.0 and not np.isnan(black.error_high).any()
