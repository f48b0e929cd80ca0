"""Choosing a row of a table by a cumulative distribution: lights by power, environment rows and texels by brightness."""

from numba import njit


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
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
