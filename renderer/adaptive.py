"""Adaptive sampling, the kernels' side: whether a pixel has samples enough (`pixel_converged`).

The rule (chosen and calibrated in adaptive_plan.py, which sets `sampling.threshold`):

- The pixel's error is judged from its BATCHES batch means, which are independent estimates of
  the pixel whatever the sampler does within a batch: their spread gives the variance of the
  pixel's mean, se2 (averaged over the three channels), with BATCHES - 1 degrees of freedom.
- It stops once se2 <= threshold^2 * n, that is once its samples n reach sigma / threshold,
  where sigma = sqrt(se2 * n) is the spread of one sample. Samples in proportion to each
  pixel's sigma is the split that makes the image's mean squared error smallest for a given
  number of samples (minimise sum sigma_i^2 / n_i with sum n_i fixed: n_i ~ sigma_i). Stopping
  every pixel at one standard error instead (n_i ~ sigma_i^2) spends exactly as many samples
  as a uniform render for the same image error, so it gains nothing on that figure.
- A pixel's spread is taken as no less than `sampling.guard` (a share of the largest spread of
  its 3x3 neighbourhood in the pilot): a pixel whose few first samples happen to agree (all on a
  lamp, at its edge) would otherwise stop on a spread of zero, far from its mean.
- A pixel whose largest sample (`peak`) holds more than `sampling.tail` of its sum of squares
  does not stop while that sample alone moves its mean by more than the standard error it may
  stop at: a few rare, bright paths dominate it, and its spread says little yet. (A dark pixel
  whose rare paths are dim may stop: they cannot move its mean by much.)

The decision reads only the pixel's own sums at a whole number of rounds of BATCHES samples, so
it does not depend on passes, bands, threads, tiles or resume: images stay deterministic.
"""

from . import target
from .config import BATCHES


@target.device
def pixel_converged(sums, row, col, n, sampling):
    """Whether the pixel at [row, col] of `sums`, holding `n` samples (a whole number of rounds of
    BATCHES), may stop: the variance of its mean from its batch means is at most
    sampling.threshold^2 * n, and its largest sample holds at most `sampling.tail` of its sum of
    squares or cannot move its mean by more than that standard error."""
    squares = sums.total_sq[row, col, 0] + sums.total_sq[row, col, 1] + sums.total_sq[row, col, 2]
    peak = sums.peak[row, col]
    peak2 = peak[0] * peak[0] + peak[1] * peak[1] + peak[2] * peak[2]
    # The peak's share of the squares, and its weight in the mean (its channels' average over n)
    # against the standard error allowed, threshold * sqrt(n): squared, peak2 / 3 / n^2 > threshold^2 n.
    if peak2 > sampling.tail * squares and peak2 > 3.0 * sampling.threshold * sampling.threshold * n * n * n:
        return False  # (an all-black pixel, 0 > 0, goes on to the spread, which is 0)
    per_batch = n // BATCHES
    spread = 0.0
    for c in range(3):
        mean = 0.0
        for k in range(BATCHES):
            mean += sums.batch[row, col, k, c]
        mean /= BATCHES * per_batch
        for k in range(BATCHES):
            d = sums.batch[row, col, k, c] / per_batch - mean
            spread += d * d
    se2 = spread / (3.0 * BATCHES * (BATCHES - 1))
    if sampling.guard.shape[0] > 0:
        # Never less spread than its neighbours' pilot allows: a pixel at a lamp's edge whose pilot
        # samples all hit the lamp looks flat, its neighbours do not.
        se2 = max(se2, sampling.guard[row, col] / n)
    return se2 <= sampling.threshold * sampling.threshold * n
