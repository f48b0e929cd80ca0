"""One tile of the image, serially: the unit of work of a render on a Dask cluster.

`render_tile` adds samples to a rectangle of pixels exactly as `integrator.render_pass` adds
them to the whole image: the same camera ray and path for each (pixel, sample), and each
pixel's sums continued in ascending sample order from the sums it is given. So a tile continued
round after round holds, bit for bit, the sums of the same pixels of a local render, however
the samples were split into rounds (`integrator.add_pixel_samples` is the loop both share).

It runs on one thread and releases the GIL: a Dask worker with several threads runs several
tiles at once, and no Numba threading layer is started inside a worker.
"""

import numpy as np

from .. import target
from ..config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from ..guide_records import RECORDS_PER_PATH
from .integrator import add_pixel_samples


@target.kernel
def render_tile(S, width, x0, y0, seed, sample_start, sample_count, max_depth, integrator, sampling, sums, row_rays, row_bad,
                rec):
    """Add `sample_count` samples per pixel, numbered from `sample_start`, into the sums
    (film.PixelSums) of the tile whose top left pixel is (x0, y0) in an image `width` pixels
    wide; the tile's size is that of `sums.total` (rows, columns, 3). `row_rays` and `row_bad`
    count per row of the tile. `rec`: the guide's training records (guide_records.py), those of
    sample s of the tile's pixel (k, t) from row ((k * tile width + t) * sample_count + s -
    sample_start) * RECORDS_PER_PATH on; empty in a render."""
    tile_h, tile_w = sums.total.shape[0], sums.total.shape[1]
    stack = (np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64))
    tstack = np.empty((BVH_STACK, 2))
    for k in range(tile_h):
        j = y0 + k
        rays = 0
        bad = 0
        for t in range(tile_w):
            n, nbad = add_pixel_samples(S, x0 + t, j, width, seed, sample_start, sample_count, max_depth, integrator,
                                        sampling, sums, k, t, stack, tstack, rec,
                                        (k * tile_w + t) * sample_count * RECORDS_PER_PATH)
            rays += n
            bad += nbad
        row_rays[k] += rays
        row_bad[k] += bad
