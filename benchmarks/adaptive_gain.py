"""Adaptive sampling's gain: the true error at equal time, adaptive against uniform.

    python benchmarks/adaptive_gain.py [--scenes final_scene,cornell_smoke] [--width 48] [--noise 0.01] [--seeds 3]

For each scene at a small size: a uniform reference render (seed 1); then, for each of `--seeds`
seeds, an adaptive render toward the noise target, timed; a uniform render with a time budget of
the adaptive render's seconds, and one with as many samples as the adaptive render spent on
average (each render its own seed; the errors' RMS over the seeds is reported).
Each image's true relative RMS error is measured against the reference, less the reference's own
noise (its per-pixel variance, estimated from its samples, is subtracted from the mean squared
difference), so the reference need not be converged. Also printed: the gain the pilot's
per-pixel spreads promise for samples split in proportion to them, mean(s^2) / mean(s)^2 in
variance (the square root of it in error), and what splitting them for one error everywhere
would give (none: it needs as many samples as a uniform render for the same image error).
Prints the table; the kernels compile once first (general kernel), not timed.
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

SCENES = ("final_scene", "cornell_smoke", "cornell_box", "weekend_cover")


def true_error(film, ref) -> float:
    mean = ref.total / ref.samples
    ref_var = np.maximum(ref.total_sq / ref.samples - mean ** 2, 0.0) / (ref.samples - 1)
    squared = float(np.mean(np.square(film.mean() - mean)) - np.mean(ref_var))
    return math.sqrt(max(squared, 0.0) / float(np.mean(np.square(mean))))


def promised_gain(ref) -> float:
    """sqrt(mean(s^2)) / mean(s) over the pixels' per-sample spreads s (from the reference): the
    error ratio, uniform over adaptive, of the ideal split n ~ s at equal samples."""
    n = ref.samples
    var = np.maximum(ref.total_sq / n - (ref.total / n) ** 2, 0.0).mean(axis=2)
    s = np.sqrt(var)
    return float(np.sqrt(np.mean(var)) / np.mean(s)) if s.mean() > 0 else 1.0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--width", type=int, default=48)
    parser.add_argument("--noise", type=float, default=0.01)
    parser.add_argument("--ref-spp", type=int, default=2048)
    parser.add_argument("--seeds", type=int, default=3, help="renders of each kind, their errors' RMS reported")
    args = parser.parse_args(argv)

    from renderer.compile import compile_scene, with_width
    from renderer.render import render
    from scenefmt.validation import load

    rows = []
    started = time.perf_counter()
    for name in args.scenes.split(","):
        graph = with_width(load(ROOT / "scenes" / f"{name}.yaml").graph, args.width)
        flat = compile_scene(graph)
        render(with_width(graph, 4), samples=1, kernel="general")  # the kernel, loaded or compiled: not timed
        ref = render(graph, flat=flat, samples=args.ref_spp, seed=1, kernel="general")
        runs = []
        for k in range(args.seeds):  # the errors of one seed swing with a scene's few brightest paths
            ada = render(graph, flat=flat, samples=1_000_000, seed=2 + 10 * k, noise_target=args.noise, adaptive=True,
                         kernel="general")
            seconds = ada.stats.seconds
            timed = render(graph, flat=flat, samples=1_000_000, seed=3 + 10 * k, time_budget=seconds, kernel="general")
            spp = max(2, int(round(ada.film.counts.mean())))
            equal = render(graph, flat=flat, samples=spp, seed=4 + 10 * k, kernel="general")
            runs.append((true_error(ada.film, ref.film), seconds, ada.film.counts.mean(), ada.film.done.mean(),
                         true_error(timed.film, ref.film), timed.film.samples, true_error(equal.film, ref.film)))
        r = np.array(runs, dtype=float)
        rms = lambda column: float(np.sqrt(np.mean(np.square(r[:, column]))))  # noqa: E731
        e_ada, e_time, e_spp = rms(0), rms(4), rms(6)
        rows.append((name, args.noise, e_ada, r[:, 1].mean(), r[:, 2].mean(), r[:, 3].mean(), e_time, int(r[:, 5].mean()),
                     e_time / e_ada if e_ada > 0 else float("inf"), e_spp / e_ada if e_ada > 0 else float("inf"),
                     promised_gain(ref.film), ref.stats.seconds))
        print(f"  {name}: done ({time.perf_counter() - started:.0f} s so far)", file=sys.stderr, flush=True)

    print(f"adaptive sampling toward {100 * args.noise:g}% relative RMS, {args.width} px wide, references of {args.ref_spp} spp "
          f"(their noise subtracted); general kernel; RMS of the errors of {args.seeds} seeds, mean seconds and spp")
    print()
    print("| scene | true error, adaptive | its seconds | its mean spp | pixels stopped | true error, uniform at equal time "
          "(spp) | gain at equal time | gain at equal samples | ideal gain (pilot-free) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, noise, e_ada, seconds, spp, done, e_time, t_spp, gain_t, gain_s, ideal, _ in rows:
        print(f"| {name} | {100 * e_ada:.2f}% | {seconds:.2f} s | {spp:.0f} | {100 * done:.0f}% | {100 * e_time:.2f}% ({t_spp}) | "
              f"{gain_t:.2f}x | {gain_s:.2f}x | {ideal:.2f}x |")
    print()
    print(f"{time.perf_counter() - started:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
