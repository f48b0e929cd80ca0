"""How many records a spatial leaf of the guide should hold (guide_build.MAX_RECORDS), measured.

A leaf with few records sees its light finely in space but coarsely and noisily in direction; one
with many the other way round. The trade is measured on a synthetic light field with a known
answer: a floor and a wall (records at their points) lit by a sphere of radiance 1 (1% of the
sphere of directions) whose direction changes from point to point. Records come as the training
renders give them: iterations of doubling record counts, the first of uniform directions, each
later one drawn half from the guide the iteration before built and half uniformly, with weights
L / density; each iteration builds its guide with the settings measured. The last guide is judged
by the variance of the estimate of the incident radiance's integral at fresh points of the floor
and wall, drawing half from the guide and half uniformly (as a guided bounce off a BSDF that is
uniform): its variance over that of uniform sampling alone, summed over the points (lower is
better; 2 is a guide that never finds the light, about 0.01 a perfect one).

    python benchmarks/guide_records.py                 # light overhead (a minute on one core)
    python benchmarks/guide_records.py --up z          # along the pole of the guide's map
    python benchmarks/guide_records.py --spot 2        # only on a disc of the floor, as a caustic
    python benchmarks/guide_records.py --max-records 1000 4000 --cell-records 4 8 32

The figures of guide_build.py's docstring came from these (2 million records; 2 minutes for
each of the first two with every setting there, under load).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from renderer.guide_build import build_guide, guide_summary  # noqa: E402
from tests.renderer.guiding_calls import mixture_samples  # noqa: E402

LIGHT, RADIUS = np.array([6.0, 5.0, 3.0]), 1.0
LO, HI = np.zeros(3), np.full(3, 10.0)
UP = [2]  # the floor's normal axis: z (--up z: the guide's map has its pole there) or y (main sets it)


def surface_points(rng, n):
    """Points of the floor (up coordinate 0) and the wall x = 0 of the box 0..10."""
    p = rng.random((n, 3)) * 10.0
    wall = rng.random(n) < 0.3
    p[~wall, UP[0]] = 0.0
    p[wall, 0] = 0.0
    return p


SPOT = [0.0]  # --spot R: the light reaches only the points within R of the floor's centre (0: all)


def lit(p):
    """Whether the light reaches p: everywhere, or (--spot) only in a disc of the floor, as a
    caustic does: light whose direction is the same over a region and absent beside it."""
    if SPOT[0] <= 0.0:
        return np.ones(p.shape[:-1], bool)
    centre = np.full(3, 5.0)
    centre[UP[0]] = 0.0
    return np.sum((p - centre) ** 2, axis=-1) < SPOT[0] ** 2


def radiance(p, d):
    """1 where the ray p + t d meets the light's sphere (and the light reaches p), else 0."""
    oc = LIGHT - p
    b = np.einsum("...k,...k->...", oc, d)
    c = np.einsum("...k,...k->...", oc, oc) - RADIUS * RADIUS
    return ((b > 0.0) & (b * b >= c) & lit(p)).astype(float)


def unit_sphere(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


def records(rng, n, guide):
    """n records: uniform directions without a guide, else half from it, weights L / density."""
    p = surface_points(rng, n)
    if guide is None:
        d = unit_sphere(rng, n)
        q = np.full(n, 1.0 / (4.0 * math.pi))
    else:
        d, q = mixture_samples(guide["guide_f"], guide["guide_i"], p, rng.random((n, 1, 3)))
        d, q = d[:, 0], q[:, 0]
    return p, d, radiance(p, d) / q


def relative_variance(guide, rng, points=400, draws=2000):
    """Sum over fresh points of the variance of L / q (q: half the guide, half uniform), over
    that of L / uniform density."""
    p = surface_points(rng, points)
    d, q = mixture_samples(guide["guide_f"], guide["guide_i"], p, rng.random((points, draws, 3)))
    f = radiance(p[:, None, :], d) / q
    # Uniform sampling's variance, exactly: the light covers a share s of the sphere: (4 pi)^2 s (1 - s).
    share = np.clip((1.0 - np.sqrt(np.maximum(0.0, 1.0 - RADIUS ** 2 / np.sum((LIGHT - p) ** 2, axis=1)))) / 2.0, 0, 1)
    uniform = (4.0 * math.pi) ** 2 * share * (1.0 - share) * lit(p)
    return float(f.var(axis=1, ddof=1).sum() / uniform.sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", type=int, nargs="+", default=[2_000_000])
    parser.add_argument("--max-records", type=int, nargs="+", default=[2000, 8000, 16000])
    parser.add_argument("--cell-records", type=int, nargs="+", default=[1, 16])
    parser.add_argument("--up", choices=["z", "y"], default="y",
                        help="the floor's normal: z puts the light near the pole of the guide's map, y on its equator")
    parser.add_argument("--spot", type=float, default=0.0, help="the light reaches only a disc of this radius on the floor")
    args = parser.parse_args()
    SPOT[0] = args.spot
    global LIGHT
    if args.up == "y":
        UP[0] = 1
        LIGHT = LIGHT[[0, 2, 1]]
    start = time.perf_counter()
    print("records (last)  max_records  cell_records   leaves  guided   quads   build s   variance / uniform's")
    for count in args.counts:
        for max_records, cell_records in [(m, c) for m in args.max_records for c in args.cell_records]:
            rng = np.random.default_rng(1)
            guide, seconds = None, 0.0
            for share in (8, 4, 2, 1):
                p, d, w = records(rng, count // share, guide)
                t = time.perf_counter()
                guide = build_guide(p, d, w, LO, HI, max_records=max_records, cell_records=cell_records)
                seconds = time.perf_counter() - t
            s = guide_summary(guide)
            leaves = int((guide["guide_i"][1:1 + s["nodes"], 0] < 0).sum())
            ratio = relative_variance(guide, np.random.default_rng(2))
            print(f"{count:>14,} {max_records:>11,} {cell_records:>13,} {leaves:>8,} {s['guided']:>7,} {s['quads']:>7,} "
                  f"{seconds:>9.2f}   {ratio:.4f}", flush=True)
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
