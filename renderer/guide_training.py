"""Training the guide: a few short passes whose paths teach it where light arrives from.

Before a guided render (image.integrator guided), `train_guide` traces about TRAINING_PATHS[i]
paths in iteration i, through rows spread over the whole image, with the guide the iteration before
built (none at first: the first iteration is mis). Each path records its first vertices with a
density (guide_records.py), and the iteration's records become the next guide
(guide_build.build_guide). The last guide is the render's, fixed from its first sample to its
last: every sample of the render is drawn the same way, so the film's batches stay independent
and identically distributed and the error estimate keeps its meaning.

The training is a function of the scene, the seed and these constants alone: its pixels and
random numbers come from the seed (never from the render's own sample numbers: its seeds are
derived ones) and its rows are the first of the render's row order, and each record has one
writer. So every front end (a local render, each worker
of a cluster, a resumed render) builds the same guide, bit for bit, on any number of threads.
Its paths are not added to the image; its time is part of the render's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .flat import INTEGRATOR_GUIDED, FlatScene
from .guide_records import GUIDE_RECORD, RECORDS_PER_PATH, record_weights

# Paths traced in each training iteration: doubling, so each guide learns from twice the paths
# of the one it improves on (Mueller et al. 2017 double the samples per pixel likewise).
TRAINING_PATHS = (1 << 14, 1 << 15, 1 << 16, 1 << 17, 1 << 18)
# The records' bounding box is padded by this fraction of its diagonal, so that vertices of the
# render just outside every training vertex still find a leaf.
BOX_PADDING = 1e-3


@dataclass
class GuideTraining:
    """What training cost and made: per iteration the paths, records kept and seconds."""

    paths: list = field(default_factory=list)
    records: list = field(default_factory=list)
    seconds: list = field(default_factory=list)
    guide_rows: int = 0

    @property
    def total_seconds(self) -> float:
        return float(sum(self.seconds))


def training_seed(seed: int, iteration: int) -> int:
    """The seed of training iteration `iteration`: far from the render's own keys."""
    z = (seed * 0x9E3779B97F4A7C15 + 0xD1B54A32D192ED03 * (iteration + 1)) & ((1 << 63) - 1)
    return z ^ 0x5A17_6E1D_0000_0000


def training_rows(width: int, height: int, paths: int) -> tuple[int, int]:
    """(rows, samples per pixel) of an iteration of about `paths` paths: the first `rows` rows of
    the render's row order (tracing/integrator.row_stride, which spreads any run of them over the
    whole image), every row with more samples once the image has fewer pixels than paths."""
    rows = min(height, max(1, -(-paths // max(1, width))))
    spp = max(1, paths // (width * height)) if rows == height else 1
    return rows, spp


def train_guide(flat: FlatScene, width: int, height: int, seed: int, max_depth: int, sampler: int, kernels,
                serial: bool = False) -> tuple[FlatScene, GuideTraining]:
    """`flat` with the guide learned by the training iterations (guide_f, guide_i), and what the
    training cost. `kernels` is the variants.KernelSet to trace with (it must have the guiding
    path): its render pass over the first rows of the row order, or with `serial`, on the
    calling thread alone (a cluster's worker), its tile kernel row by row; the records, and so the
    guide, are the same. `sampler` is the sampling.SAMPLERS code."""
    from .film import Film
    from .guide_build import build_guide
    from .guiding import empty_guide
    from .sampling import Sampling
    from .tracing.integrator import row_stride

    stats = GuideTraining()
    flat = flat._replace(**empty_guide())
    sampling = Sampling(sampler)
    stride = row_stride(height)
    for iteration, paths in enumerate(TRAINING_PATHS):
        t0 = time.perf_counter()
        iteration_seed = training_seed(seed, iteration)
        rows, spp = training_rows(width, height, paths)
        per_row = width * spp * RECORDS_PER_PATH
        rec = np.zeros((rows * per_row, GUIDE_RECORD.width), np.float64)
        rays, bad = np.zeros(height, np.int64), np.zeros(height, np.int64)
        if serial:
            for m in range(rows):
                film = Film.empty(width, 1)
                kernels.render_tile(flat, width, 0, (m * stride) % height, iteration_seed, 0, spp, max_depth,
                                    INTEGRATOR_GUIDED, sampling, film.sums, rays[:1], bad[:1], rec[m * per_row:(m + 1) * per_row])
        else:
            film = Film.empty(width, height)
            kernels.render_pass(flat, width, height, iteration_seed, 0, spp, max_depth, INTEGRATOR_GUIDED, sampling,
                                film.sums, rays, bad, 0, rows, rec)
        positions, directions, weights = record_weights(rec)
        del rec, film
        if len(positions):
            lo, hi = positions.min(axis=0), positions.max(axis=0)
            pad = BOX_PADDING * max(float(np.linalg.norm(hi - lo)), 1e-6)
            flat = flat._replace(**build_guide(positions, directions, weights, lo - pad, hi + pad))
        stats.paths.append(rows * width * spp)
        stats.records.append(len(positions))
        stats.seconds.append(time.perf_counter() - t0)
    stats.guide_rows = int(flat.guide_f.shape[0])
    return flat, stats
