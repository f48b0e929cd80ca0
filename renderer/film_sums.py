"""The kernels' side of the film: how one sample is added to a pixel's sums (film.PixelSums)."""

from . import target


@target.device
def add_sample(sums, row, col, batch, r, g, b):
    """Add the finite sample (r, g, b) of batch `batch` to the pixel at [row, col]: its sum and sum
    of squares (in sample order, as they always were), its batch's sum, and its peak (the sample
    with the largest r^2 + g^2 + b^2, what heavy tails are judged by)."""
    sums.total[row, col, 0] += r
    sums.total[row, col, 1] += g
    sums.total[row, col, 2] += b
    r2, g2, b2 = r * r, g * g, b * b
    sums.total_sq[row, col, 0] += r2
    sums.total_sq[row, col, 1] += g2
    sums.total_sq[row, col, 2] += b2
    sums.batch[row, col, batch, 0] += r
    sums.batch[row, col, batch, 1] += g
    sums.batch[row, col, batch, 2] += b
    peak = sums.peak[row, col]
    if r2 + g2 + b2 > peak[0] * peak[0] + peak[1] * peak[1] + peak[2] * peak[2]:
        peak[0] = r
        peak[1] = g
        peak[2] = b
