"""Choosing a row of a table by a cumulative distribution: lights by power, environment rows and texels by brightness."""

import numpy as np

from .. import target


def pmf_and_cdf(weights: np.ndarray, total: float) -> tuple[np.ndarray, np.ndarray]:
    """The probabilities of rows of `weights` (summing to `total` > 0) and their cdf for
    search_cdf, whose last entry is exactly 1 so that every u in [0, 1) finds a row."""
    cdf = np.cumsum(weights) / total
    cdf[-1] = 1.0
    return weights / total, cdf


@target.device
def search_cdf(table, column, first, count, u):
    """The first of rows first..first + count - 1 whose `column` (a cdf) exceeds u, by binary
    search: a row of zero probability (its cdf equal to the one before) is never chosen."""
    lo, hi = first, first + count - 1
    while lo < hi:
        mid = (lo + hi) // 2
        if u < table[mid, column]:
            hi = mid
        else:
            lo = mid + 1
    return lo
