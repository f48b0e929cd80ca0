"""What a training render records of its paths for the guide to learn from (guide_training.py).

Each path of a training pass may record its first RECORDS_PER_PATH vertices with a density (a
matte or rough surface, never a medium): where the vertex is, the direction the path left in,
the density with which that direction was drawn, and the radiance that then arrived along it.
The radiance is not known when the vertex is left: it is what the rest of the path adds to the
pixel, divided by the throughput the path had just after leaving the vertex. So a record keeps
the inverse of that throughput, and every later contribution to the pixel is added into every
open record of the path, scaled by it (`add_to_records`). The estimate is unbiased: Russian
roulette's reweighting is in the throughput, and so in the inverse.

`record_weights` turns the rows into the guide's weights (guide_build.build_guide): the
luminance of the arrived radiance over the density, an unbiased estimate of its integral.
"""

from __future__ import annotations

import numpy as np

from . import target
from .columns import Column, Layout

RECORDS_PER_PATH = 3

GUIDE_RECORD = Layout("GUIDE_RECORD", "float64", [
    Column("position", 3, "the vertex"),
    Column("direction", 3, "unit direction the path left the vertex in"),
    Column("pdf", 1, "solid angle density with which that direction was drawn (the guide's and the BSDF's mixture)"),
    Column("inverse_throughput", 3, "1 / the path's throughput just after the vertex, by channel (0 where it is 0)"),
    Column("radiance", 3, "the radiance that arrived along the direction: the path's later contributions x the inverse"),
])
REC_P, REC_D, REC_PDF, REC_INV, REC_L = GUIDE_RECORD.offsets("position", "direction", "pdf", "inverse_throughput",
                                                             "radiance")
REC_WIDTH = GUIDE_RECORD.width


def no_records() -> np.ndarray:
    """The record buffer of a pass that records nothing (every pass of a render)."""
    return np.zeros((0, REC_WIDTH), np.float64)


@target.device
def _inverse(t):
    return 1.0 / t if t > 0.0 else 0.0


@target.device
def open_record(rec, row, p, d, pdf, tr, tg, tb):
    """Start record `row`: vertex p left along unit d, drawn with density pdf; the path's
    throughput after it is (tr, tg, tb)."""
    for k in range(3):
        rec[row, REC_P + k] = p[k]
        rec[row, REC_D + k] = d[k]
        rec[row, REC_L + k] = 0.0
    rec[row, REC_PDF] = pdf
    rec[row, REC_INV] = _inverse(tr)
    rec[row, REC_INV + 1] = _inverse(tg)
    rec[row, REC_INV + 2] = _inverse(tb)


@target.device
def add_to_records(rec, first, count, r, g, b):
    """Add the contribution (r, g, b) the path just made to the pixel into its `count` open
    records, rows first..first + count - 1."""
    for row in range(first, first + count):
        rec[row, REC_L] += r * rec[row, REC_INV]
        rec[row, REC_L + 1] += g * rec[row, REC_INV + 1]
        rec[row, REC_L + 2] += b * rec[row, REC_INV + 2]


def record_weights(rec: np.ndarray):
    """(positions, directions, weights) of the rows of `rec` that a path opened (a density > 0:
    the buffer starts zeroed) and whose weight is finite: the luminance (Rec. 709) of the arrived
    radiance over the density."""
    rows = rec[rec[:, REC_PDF] > 0.0]
    radiance = rows[:, REC_L:REC_L + 3]
    luminance = radiance @ np.array([0.2126, 0.7152, 0.0722])
    pdf = rows[:, REC_PDF]
    with np.errstate(divide="ignore", invalid="ignore"):
        weights = np.where(pdf > 0.0, luminance / pdf, 0.0)
    keep = np.isfinite(weights) & (weights >= 0.0) & np.all(np.isfinite(rows[:, :REC_PDF]), axis=1)
    return (np.ascontiguousarray(rows[keep, REC_P:REC_P + 3]), np.ascontiguousarray(rows[keep, REC_D:REC_D + 3]),
            np.ascontiguousarray(weights[keep]))
