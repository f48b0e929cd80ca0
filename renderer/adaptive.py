"""Adaptive sampling: when a pixel has samples enough (the kernels' side; placeholder)."""

from . import target


@target.device
def pixel_converged(sums, row, col, n, sampling):
    """Whether the pixel at [row, col] of `sums`, holding `n` samples (a whole number of rounds of
    BATCHES), may stop: its error is below `sampling.threshold` and no single sample dominates it."""
    return False
