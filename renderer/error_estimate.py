"""How far a render is from the converged image, with a stated confidence, and when not to trust it.

Numpy only; works on a film's arrays (renderer/film.py keeps the entry points `estimate_noise`
and `relative_noise`). The film holds, per pixel, the sums of its samples split into BATCHES
interleaved batches (sample s belongs to batch s % BATCHES). The batch means of a pixel are
independent estimates of it whatever the sampler does within a batch (a stratified sequence makes
neighbouring samples of one batch negatively correlated, and the per-sample variance then
overstates the error), so their scatter is the honest measure of the error of the pixel's mean.

The figures, all of them relative to the image's own RMS value as `relative_rms` always was:

- per pixel: the variance of its mean from the scatter of its batch means (BATCHES - 1 degrees
  of freedom; the per-sample variance below one full round of batches), its standard error
  (`error`) and a one-sided upper bound of it at the confidence (`error_high`, chi-square);
- for the image: the relative RMS error `relative_rms` and an interval [`low`, `high`] that
  covers the realised error of this very render at the confidence. Two things spread it: the
  estimate's own uncertainty (few degrees of freedom per pixel, and more when batch means scatter
  with heavy tails), and the realised error's own spread (the squared error is a sum of one
  chi-square per pixel; when a few pixels hold most of the variance it is a sum of few). Each is
  a scaled chi-square with an effective number of degrees of freedom, so their ratio is an F
  variable, whose quantiles bound the error;
- a `warning` and the `suspect` pixels where single samples hold most of a pixel's variance (rare
  bright paths: caustics, a small lamp seen through glass): there the variance is estimated from a
  handful of events, the ones not yet found are missing from it, and no interval is honest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .quantiles import chi2_quantile, f_quantile

CONFIDENCE = 0.95
# A pixel is suspect when its single largest sample holds more than this share of the pixel's
# sum of squared deviations and lies so far from the others that light-tailed (Gaussian) samples
# would put one there with probability below PEAK_ALPHA.
PEAK_SHARE = 0.5
PEAK_ALPHA = 1e-6
# The warning fires when suspect pixels hold this share of the image's estimated variance or more
# and make the image's variance estimate this uncertain (coefficient of variation) or more.
SUSPECT_SHARE = 0.1
SUSPECT_CV = 0.15


@dataclass
class NoiseEstimate:
    """How far the image is likely to be from the converged one, from the samples' own spread.

    `relative_rms` is sqrt(sum of squared standard errors) / sqrt(sum of squared pixel values)
    over all pixels and channels: the expected RMS error relative to the image's RMS value.
    [`low`, `high`] holds the realised relative RMS error of this render at `confidence` (two-sided),
    unless `warning` says why it cannot be trusted.
    """

    relative_rms: float
    worst_pixel: tuple[int, int]  # (x, y) of the pixel with the largest standard error
    worst_relative: float  # that pixel's standard error relative to its own value
    error: np.ndarray  # (h, w) standard error of each pixel's mean, averaged over channels
    low: float = 0.0
    high: float = float("inf")
    confidence: float = CONFIDENCE
    warning: Optional[str] = None  # one sentence when the estimate cannot be trusted
    # (h, w) bool: pixels whose single largest sample holds most of their variance and lies beyond
    # what light tails give; the warning is about them. Set whether or not the image warns (the
    # edge of a lamp seen directly makes many, each holding little of the image's error).
    suspect: Optional[np.ndarray] = None
    error_high: Optional[np.ndarray] = None  # (h, w) upper bound of each pixel's standard error at `confidence`
    effective_pixels: float = 0.0  # pixels whose realised errors the image's error is a sum of, in effect
    estimate_dof: float = 0.0  # degrees of freedom of the image's variance estimate, in effect
    batched: bool = False  # whether the variance came from batch means (else from single samples)
    extra: dict = field(default_factory=dict)  # figures behind the warning, for studies and tests


@dataclass
class PixelVariance:
    """Each pixel's variance of its mean and how well it is known."""

    var: np.ndarray  # (h, w, 3) variance of the pixel's mean, per channel
    dof: np.ndarray  # (h, w) degrees of freedom of `var` (0: unknown, fewer than 2 samples)
    var_of_var: np.ndarray  # (h, w) the variance of var summed over channels (its own uncertainty)
    batched: bool


def _film_counts(film) -> np.ndarray:
    """Samples each pixel holds: `film.samples` for all unless adaptive sampling stopped some
    (as film.mean reads them)."""
    counts, done = getattr(film, "counts", None), getattr(film, "done", None)
    if counts is None or done is None or np.shape(counts) != film.total.shape[:2] or not np.any(done):
        return np.full(film.total.shape[:2], int(film.samples), np.int64)
    return np.asarray(counts)


def _batches_of(film) -> Optional[np.ndarray]:
    """The film's batch sums (h, w, B, 3), if it keeps them (a film made from sums alone has none)."""
    batch = getattr(film, "batch", None)
    if batch is None or np.ndim(batch) != 4 or batch.shape[:2] != film.total.shape[:2] or batch.shape[2] < 2:
        return None
    return batch


def _channels(a: np.ndarray) -> np.ndarray:
    """The sum over the last axis of 3 channels (quicker than a reduction over so short an axis)."""
    return a[..., 0] + a[..., 1] + a[..., 2]


def sample_variance(total: np.ndarray, total_sq: np.ndarray, counts: np.ndarray) -> PixelVariance:
    """The variance of each pixel's mean from the spread of its single samples (N - 1 degrees of
    freedom): honest for independent samples only, and what a film without batches offers."""
    n = counts.astype(np.float64)[:, :, None]
    ok = n >= 2
    safe = np.where(ok, n, 2.0)
    var = np.where(ok, np.maximum(total_sq - total * (total / safe), 0.0) / (safe - 1.0) / safe, np.inf)
    dof = np.where(counts >= 2, counts - 1.0, 0.0)
    summed = _channels(var)
    var_of_var = np.where(dof > 0, 2.0 * summed * summed / np.maximum(dof, 1.0), np.inf)
    return PixelVariance(var, dof, var_of_var, False)


def batch_variance(batch: np.ndarray, total: np.ndarray, counts: np.ndarray) -> PixelVariance:
    """The variance of each pixel's mean from the scatter of its batch means.

    Sample s of a pixel belongs to batch s % B, so a pixel of N samples has N // B + 1 samples in
    its first N % B batches and N // B in the others. With unequal batches the between-batch sum of
    squares sum_b n_b (m_b - m)^2 still has expectation (B - 1) sigma^2 for samples of variance
    sigma^2 (one-way analysis of variance), so it is weighted by the batch sizes; B - 1 degrees of
    freedom. Its own variance is estimated from how the batches' terms scatter (their fourth
    moment), so that one batch holding a rare huge sample counts as the few degrees of freedom it
    is; never below the Gaussian 2 v^2 / (B - 1).
    """
    h, w, B, _ = batch.shape
    n = counts.astype(np.float64)
    rounds, extra = np.divmod(counts, B)
    mean = total / n[:, :, None]
    var = np.zeros((h, w, 3))
    sum_g = np.zeros((h, w))
    sum_g2 = np.zeros((h, w))
    # One batch at a time: a reduction over the batch axis of an (h, w, B, 3) array is slow.
    for b in range(B):
        n_b = (rounds + (b < extra)).astype(np.float64)
        dev = batch[:, :, b, :] / n_b[:, :, None] - mean
        dev *= dev
        dev *= (n_b / n)[:, :, None]  # this batch's term of the weighted sum of squares
        var += dev
        g = _channels(dev)  # channels together: they are mostly the same paths
        sum_g += g
        sum_g2 += g * g
    var /= B - 1
    summed = sum_g / (B - 1)
    spread = np.maximum(sum_g2 - sum_g * sum_g / B, 0.0) / (B - 1)  # the scatter of the batches' terms
    var_of_var = np.maximum(B * spread / (B - 1) ** 2, 2.0 * summed * summed / (B - 1))
    dof = np.full((h, w), B - 1.0)
    return PixelVariance(var, dof, var_of_var, True)


def pixel_variance(film) -> PixelVariance:
    """Batch variance where every pixel has a sample in every batch and the batches hold every
    sample of the film (a state saved before batches has none), else the per-sample one."""
    counts = _film_counts(film)
    batch = _batches_of(film)
    if batch is not None and counts.min() >= batch.shape[2]:
        held = batch[:, :, 0, :].copy()
        for b in range(1, batch.shape[2]):
            held += batch[:, :, b, :]
        if np.all(np.abs(held - film.total) <= 1e-9 * (np.abs(film.total) + 1.0)):
            return batch_variance(batch, film.total, counts)
    return sample_variance(film.total, film.total_sq, counts)


def _outlier_distance(count: int) -> float:
    """How far (squared, in standard deviations of the other samples) the largest of `count`
    Gaussian samples lies from the others' mean with probability PEAK_ALPHA: a new sample's
    squared distance over the others' variance is (1 + 1/(N-1)) F(1, N-2) distributed, and the
    largest of N is beyond a point about N times as often as one sample."""
    if count < 3:
        return math.inf
    return (1.0 + 1.0 / (count - 1)) * f_quantile(1.0 - PEAK_ALPHA / count, 1.0, count - 2.0)


def peak_outliers(film, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(share, outlier) per pixel: the share of the pixel's sum of squared deviations (channels
    together) that goes when its largest sample (`film.peak`) is left out, and whether that
    sample lies further from the others than light-tailed samples would put it (always when the
    others are all equal and it is not). Zero and False where the film keeps no peak or the pixel
    has fewer than 3 samples."""
    shape = film.total.shape[:2]
    peak = getattr(film, "peak", None)
    if peak is None or np.shape(peak) != film.total.shape:
        return np.zeros(shape), np.zeros(shape, bool)
    T, Q = film.total, film.total_sq
    # A film made from sums alone keeps zero peaks: a pixel whose peak is not its largest sample
    # (zero where samples were not, or more than all its squares) has none to judge by.
    peak_norm, squares = _channels(peak * peak), _channels(Q)
    ok = (counts >= 3) & (peak_norm > 0) & (peak_norm <= squares * (1.0 + 1e-9))
    n = np.where(ok, counts, 3).astype(np.float64)[:, :, None]
    squares_all = _channels(np.maximum(Q - T * T / n, 0.0))
    T1, Q1, n1 = T - peak, Q - peak * peak, n - 1.0
    squares_rest = _channels(np.maximum(Q1 - T1 * T1 / n1, 0.0))
    spread_rest = squares_rest / (n1[:, :, 0] - 1.0)
    gap = _channels(np.square(peak - T1 / n1))
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(squares_all > 0, np.clip(1.0 - squares_rest / squares_all, 0.0, 1.0), 0.0)
    values = np.unique(counts[ok])
    limit = np.zeros(shape)  # where not ok the answer is False whatever the limit
    if values.size:
        limits = np.array([_outlier_distance(int(c)) for c in values])
        limit[ok] = limits[np.searchsorted(values, counts[ok])]
    outlier = ok & (gap > 0) & (gap > limit * spread_rest)
    return np.where(ok, share, 0.0), outlier


def _interval(V: float, S: float, k_real: float, k_est: float, confidence: float) -> tuple[float, float]:
    """Bounds of the realised relative RMS error: squared error / estimated variance ~ F(k_real, k_est)."""
    if V <= 0:
        return 0.0, 0.0
    tail = 0.5 * (1.0 - confidence)
    lo = f_quantile(tail, k_real, k_est)
    hi = f_quantile(1.0 - tail, k_real, k_est)
    return math.sqrt(V * lo / S), math.sqrt(V * hi / S)


def estimate(film, confidence: float = CONFIDENCE) -> NoiseEstimate:
    """The error estimate of a film (see the module's docstring); a film of fewer than 2 samples
    per pixel has none (inf). Never NaN: pixels and figures that cannot be known are inf."""
    h, w = film.total.shape[:2]
    counts = _film_counts(film)
    if counts.size == 0 or counts.min() < 2:
        inf_map = np.full((h, w), np.inf)
        return NoiseEstimate(float("inf"), (0, 0), float("inf"), inf_map, float("inf"), float("inf"), confidence,
                             None, np.zeros((h, w), bool), inf_map.copy())
    pv = pixel_variance(film)
    mean = film.total / counts[:, :, None]
    error = np.sqrt(pv.var).mean(axis=2)
    # One-sided upper bound of each pixel's variance: dof * var / the chi-square's lower quantile.
    dofs = np.unique(pv.dof) if not pv.batched else pv.dof[:1, 0]
    bounds = np.array([d / chi2_quantile(1.0 - confidence, d) for d in dofs])
    bound = bounds[0] if dofs.size == 1 else bounds[np.searchsorted(dofs, pv.dof)][:, :, None]
    error_high = np.sqrt(pv.var * bound).mean(axis=2)

    v = _channels(pv.var)  # per pixel, channels together (their errors share paths)
    V = float(v.sum())
    signal = float(np.square(mean).sum())
    relative = math.sqrt(V / signal) if signal > 0 else (0.0 if V == 0 else float("inf"))
    y, x = np.unravel_index(int(np.argmax(error)), error.shape)
    value = float(mean[y, x].mean())
    worst_relative = float(error[y, x] / value) if value > 0 else (0.0 if error[y, x] == 0 else float("inf"))

    # Effective counts: pixels behind the realised error (their estimated variances squared are
    # inflated by the estimate's own noise, 1 + 2/dof on average), and the degrees of freedom of
    # the variance estimate itself.
    v2 = float(np.sum(v * v / (1.0 + 2.0 / pv.dof)))
    vv = float(pv.var_of_var.sum())
    k_real = V * V / v2 if v2 > 0 else 1.0
    k_est = 2.0 * V * V / vv if vv > 0 else 1.0
    # The converged image's sum of squares: the film's less the noise in it (kept above a quarter of it).
    truth = max(signal - V, 0.25 * signal)
    low, high = _interval(V, truth, k_real, k_est, confidence) if signal > 0 else (relative, relative)
    low, high = min(low, relative), max(high, relative)

    share, outlier = peak_outliers(film, counts)
    suspect = (share > PEAK_SHARE) & outlier & (v > 0)
    suspect_var = float(v[suspect].sum())
    suspect_share = suspect_var / V if V > 0 else 0.0
    suspect_cv = math.sqrt(float(pv.var_of_var[suspect].sum())) / V if V > 0 else 0.0
    warning = None
    if suspect_share >= SUSPECT_SHARE and suspect_cv >= SUSPECT_CV:
        warning = heavy_tail_sentence(v, suspect, suspect_share)
    extra = {"suspect_share": suspect_share, "suspect_cv": suspect_cv, "cv": math.sqrt(vv) / V if V > 0 else 0.0}
    return NoiseEstimate(relative, (int(x), int(y)), worst_relative, error, low, high, confidence, warning, suspect,
                         error_high, k_real, k_est, pv.batched, extra)


def heavy_tail_sentence(v: np.ndarray, suspect: np.ndarray, share: float) -> str:
    """The warning, for the user: how much, how many pixels, and where (the suspect pixel whose
    variance is largest)."""
    count = int(suspect.sum())
    y, x = np.unravel_index(int(np.argmax(np.where(suspect, v, -1.0))), v.shape)
    pixels = "1 pixel" if count == 1 else f"{count} pixels"
    return (f"rare bright paths dominate {100 * share:.0f}% of the estimated error in {pixels} (around x {x}, y {y}): "
            "the error may be several times larger than estimated")


# The trend across a render: the relative noise squared times the samples (the image's spread per
# sample) stays level when the error falls as n^-1/2. When it grows by TREND_GROWTH or more over a
# factor TREND_SPAN of samples, rare bright paths are still being found. (Measured at 48 pixels:
# sky_spheres' grew 2 to 95 times from 8 to 32 samples; the Cornell box, final_scene and the smoke
# box moved at most 1.29 times, and mostly under 1.1.)
TREND_FROM = 8
TREND_SPAN = 4
TREND_GROWTH = 2.0


class VarianceTrend:
    """The image's spread per sample as a render goes on, from the cheap relative noise of the
    progress display; `warning()` says when it has grown as no sound estimate would."""

    def __init__(self):
        self.seen: list[tuple[int, float]] = []  # (samples per pixel, samples * relative noise^2)

    def add(self, samples: int, noise: float) -> None:
        if samples >= TREND_FROM and math.isfinite(noise) and noise > 0 and (not self.seen or samples > self.seen[-1][0]):
            self.seen.append((samples, samples * noise * noise))

    def growth(self) -> tuple[float, int, int]:
        """(how many times the spread grew, from, to samples) over the latest span of TREND_SPAN
        or more; (1, 0, 0) before there is one."""
        if not self.seen:
            return 1.0, 0, 0
        n, spread = self.seen[-1]
        earlier = [(m, s) for m, s in self.seen if m * TREND_SPAN <= n]
        if not earlier:
            return 1.0, 0, 0
        m, s = earlier[-1]
        return spread / s, m, n

    def warning(self) -> Optional[str]:
        ratio, m, n = self.growth()
        if ratio < TREND_GROWTH:
            return None
        return (f"the estimated error fell more slowly than samples were added (the spread per sample grew {ratio:.1f} "
                f"times from {m} to {n} samples per pixel): rare bright paths are still being found, so the error may be "
                "several times larger than estimated")
