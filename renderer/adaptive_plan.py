"""Adaptive sampling, the session's side (numpy only): the pilot, the stopping threshold, and
when a render with a noise target may end.

With a noise target t (relative RMS error of the image), a render with adaptive sampling runs:

1. a uniform pilot of PILOT samples per pixel (no pixel stops);
2. from the pilot, the threshold of adaptive.pixel_converged: each pixel takes samples in
   proportion to its spread sigma_i (the split with the smallest image error for the samples
   spent), so pixel i stops at n_i = sigma_i / threshold samples, no fewer than FLOOR, no more
   than the cap. `threshold_for` chooses the threshold whose predicted image error,
   mean(sigma_i^2 / n_i), is (MARGIN t)^2 times the image's mean square (its RMS squared);
3. passes over the pixels not done, the session ending at a CHECKPOINT (fixed sample counts,
   so that the image does not depend on how the passes fell) once the image's estimate is at the
   target with no warning, or when every pixel is done, or at the cap or the time budget.

Every sample is assumed to cost the same: the cost of a pixel's samples is not kept per pixel,
and with it the split would be n_i ~ sigma_i / sqrt(cost_i). Pixels whose paths are long (glass,
media) are then sampled as much as their noise asks, not less because they are dear.

A pixel's spread is never taken below a share of its neighbours' in the pilot (`neighbourhood_guard`):
a pixel at a lamp's edge whose first samples all hit the lamp looks flat, and would stop far
from its mean; its neighbours show the edge.

The threshold, the floor, the tail share and the guard are fixed once, from the pilot, and kept in the film
(`Film.stopping`) and in a saved state, so a resumed render goes on with the same decisions.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .config import BATCHES
from .error_estimate import batch_variance
from .film import estimate_noise
from .rare_paths import image_mean
from .sampling import Sampling

PILOT = 32  # uniform samples per pixel before the threshold is chosen (a multiple of BATCHES)
# A pixel may stop from here on: the kernel judges it at the end of each round of BATCHES
# samples, the first round after the pilot (its decisions use only the pixel's own sums).
FLOOR = PILOT + BATCHES
# A pixel whose largest sample holds more than this share of its sum of squares goes on while
# that sample can move its mean past the error allowed: a few rare bright paths dominate it (a
# smooth spread of 40 samples puts 0.05 to 0.2 of its squares in the largest).
TAIL = 0.25
# A pixel's spread is taken as at least this share of the largest in its 3x3 neighbourhood in the
# pilot (Sampling.guard). The largest of nine spreads estimated from eight batch means each is
# about twice their mean, more where samples are skewed: at a quarter, the guard held pixels of
# cornell_smoke like their neighbours (in a simulation from its per-pixel spreads, 1.39x of the
# ideal 1.99x gain at equal samples, 1.57x at a tenth); a pixel beside a lamp's edge, whose
# neighbours' spread is hundreds of times its own, is held at a tenth as well.
GUARD_SHARE = 0.1
# The threshold aims at this fraction of the target: a pixel that stops on a spread that
# happens to be low (eight batch means are few) has a larger error than it says.
MARGIN = 0.8
# The session tests the image's estimate at these sample counts only (PILOT, then each about
# CHECK_GROWTH times the last, a whole number of rounds), so where it stops does not depend on
# how the passes fell.
CHECK_GROWTH = 1.25


def round_up(samples: float) -> int:
    """`samples` rounded up to a whole number of rounds of BATCHES."""
    return BATCHES * max(1, math.ceil(samples / BATCHES - 1e-9))


def next_checkpoint(samples: int) -> int:
    """The first checkpoint above `samples` (PILOT, then growing by CHECK_GROWTH)."""
    check = PILOT
    while check <= samples:
        check = max(check + BATCHES, round_up(check * CHECK_GROWTH))
    return check


def is_checkpoint(samples: int) -> bool:
    return samples >= PILOT and next_checkpoint(samples - 1) == samples


def pixel_mean_variance(batch: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The variance of each pixel's mean (h, w), averaged over channels, from its batch sums
    `batch` (h, w, BATCHES, 3) and its sample counts (h, w): the error estimate's spread of the
    batch means (error_estimate.batch_variance), whose sums are those of the batches."""
    total = batch.sum(axis=2)
    return batch_variance(batch, total, np.maximum(counts, 1)).var.mean(axis=2)


def neighbourhood_guard(sigma2: np.ndarray) -> np.ndarray:
    """GUARD_SHARE of the largest per-sample variance in each pixel's 3x3 neighbourhood (itself
    included), from the pilot's variances `sigma2` (h, w): Sampling.guard."""
    padded = np.pad(sigma2, 1, mode="edge")
    h, w = sigma2.shape
    most = np.max([padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)], axis=0)
    return np.ascontiguousarray(GUARD_SHARE * most, dtype=np.float64)


def predicted_error(sigma2: np.ndarray, threshold: float, floor: int, cap: int) -> float:
    """The image's mean square error (per pixel and channel) once each pixel of per-sample
    variance `sigma2` stopped by the rule of adaptive.pixel_converged at `threshold`."""
    if threshold <= 0:
        return float(np.mean(sigma2 / cap))
    stops = np.sqrt(sigma2) / threshold
    n = np.clip(BATCHES * np.ceil(stops / BATCHES), floor, max(cap, floor))
    return float(np.mean(sigma2 / n))


def predicted_counts(film) -> Optional[np.ndarray]:
    """The samples each pixel is expected to hold when the render ends, by the film's stopping rule
    (`film.stopping`, fixed after the pilot) and the pilot's spreads, as `threshold_for` predicted
    them: the samples a pixel holds already, at least. None without a rule that stops pixels."""
    if film.stopping is None or not film.stopping[0] > 0:
        return None
    threshold, floor, _tail, guard = film.stopping
    sigma2 = pilot_variance(film)
    if guard is not None and np.size(guard):
        sigma2 = np.maximum(sigma2, guard)
    stops = np.sqrt(sigma2) / threshold
    expected = np.clip(BATCHES * np.ceil(stops / BATCHES), floor, None)
    return np.maximum(expected, film.counts)


def pilot_variance(film) -> np.ndarray:
    """Each pixel's variance of one sample (h, w), channels averaged, from its batch means."""
    return pixel_mean_variance(film.batch, film.counts) * np.maximum(film.counts, 1)


def threshold_for(film, noise_target: float, cap: int, floor: int = FLOOR, guard=None) -> float:
    """The threshold of adaptive.pixel_converged that brings the image of `film` (a uniform
    pilot) to MARGIN * `noise_target` relative RMS error by the prediction of `predicted_error`
    (each pixel's variance at least its `guard`); 0.0 (no pixel stops) when even `cap` samples
    everywhere cannot."""
    n = film.counts
    se2 = pixel_mean_variance(film.batch, n)
    sigma2 = se2 * np.maximum(n, 1)
    if guard is not None:
        sigma2 = np.maximum(sigma2, guard)
    mean = film.total / np.maximum(n, 1)[:, :, None]
    # The mean square of the image, less what its own noise adds to it.
    signal = max(float(np.mean(np.square(mean))) - float(np.mean(se2)), 0.25 * float(np.mean(np.square(mean))))
    goal = (MARGIN * noise_target) ** 2 * signal
    if not np.isfinite(goal) or not np.isfinite(sigma2).all():
        return 0.0
    if float(sigma2.max(initial=0.0)) == 0.0:
        return 1.0  # nothing varies: every pixel may stop at the floor
    if predicted_error(sigma2, 0.0, floor, cap) > goal:
        return 0.0
    # predicted_error grows with the threshold: bisect on its logarithm.
    low = math.sqrt(float(sigma2.max())) / (16 * max(cap, floor))  # every pixel runs to the cap
    high = math.sqrt(float(sigma2.max())) / BATCHES  # every pixel stops at the floor
    if predicted_error(sigma2, high, floor, cap) <= goal:
        return high
    for _ in range(60):
        middle = math.sqrt(low * high)
        if predicted_error(sigma2, middle, floor, cap) <= goal:
            low = middle
        else:
            high = middle
    return low


def stopping_sampling(sampling: Sampling, stopping: tuple) -> Sampling:
    """`sampling` with the stopping rule (threshold, floor, tail, guard) of a film."""
    threshold, floor, tail, guard = stopping
    return sampling._replace(threshold=float(threshold), floor=int(floor), tail=float(tail),
                             guard=np.ascontiguousarray(guard, dtype=np.float64))


class AdaptiveRun:
    """The session's adaptive sampling for one render toward `noise_target` with at most `cap`
    samples per pixel (see the module's docstring). The session asks it, around each step:
    `step_target` (how far the next step may go), `sampling_after` (the rule to render with,
    once the pilot is in) and `finished` (whether the render may end here, and why)."""

    def __init__(self, noise_target: float, cap: int):
        self.noise_target = noise_target
        self.cap = cap

    def step_target(self, film, target: int) -> int:
        """The sample count the next step may reach: the pilot first, then the next checkpoint."""
        if film.stopping is None and film.samples < PILOT:
            return min(target, PILOT)
        return min(target, next_checkpoint(film.samples))

    def sampling_after(self, film, prior=None) -> Optional[tuple]:
        """The stopping rule (threshold, floor, tail, guard) to adopt now: once, when the pilot
        is in; None when the film already has one or the pilot is not done. `prior`: the scene's
        rare-path prior (rare_paths.RarePathPrior), which may say that no estimate holds yet."""
        if film.stopping is not None or film.samples < PILOT:
            return None
        guard = neighbourhood_guard(pilot_variance(film))
        if estimate_noise(film).warning is not None or (prior is not None and prior.warning(image_mean(film), film.samples)):
            # The image's estimate cannot be trusted (rare bright paths): neither can a pixel's
            # own spread, so none stops; the session goes on until the warning is gone.
            return (0.0, FLOOR, TAIL, guard)
        return (threshold_for(film, self.noise_target, self.cap, guard=guard), FLOOR, TAIL, guard)

    @staticmethod
    def share_done(film) -> float:
        return float(np.count_nonzero(film.done)) / max(1, film.done.size)

    def finished(self, film, estimate, warning: Optional[str] = None) -> bool:
        """Whether the render may end here: every pixel stopped, or, at a checkpoint, the upper end
        of the interval of the image's estimate (`estimate`: film.estimate_noise's, or None) at the
        target with no warning (neither the estimate's nor `warning`, the render's own)."""
        if film.stopping is not None and film.done.all():
            return True
        if estimate is None or not is_checkpoint(film.samples):
            return False
        high = estimate.high  # the upper end of the error's interval (film.estimate_noise)
        return estimate.warning is None and warning is None and math.isfinite(high) and high <= self.noise_target
