"""The Owen-scrambled Sobol sampler against the independent one, scene by scene, at equal samples.

    python benchmarks/sampler_gain.py [--scenes cornell_box,final_scene] [--spp 16,64,256]
                                      [--seeds 6] [--reference-spp 0] [--width 48]

For each shipped scene (48 pixels wide, the general kernel for both samplers) and each sample
count, both samplers render the scene with `--seeds` seeds. The error of a sampler is its true
relative RMS error, sqrt(sum over pixels and channels of E[(estimate - truth)^2] / sum truth^2),
measured without a reference: both samplers are unbiased (the test suite's z-tests check it), so
E[(estimate - truth)^2] is the variance of a pixel's estimate over seeds, and the spread of the
seeds' images measures it (unbiased, with seeds - 1 degrees of freedom per pixel; the truth in
the denominator is the mean of every render). A converged reference would add its own noise to
both errors and pull the gain toward 1. With `--reference-spp N` (e.g. 16384) the study also
renders two independent references of N samples and reports each sampler's error against the
first, less that reference's own noise measured against the second: a check of the first method.

The gain is error_independent / error_sobol at equal samples (> 1: Sobol is better), with a
jackknife standard error over seeds; the time ratio is seconds_sobol / seconds_independent
summed over the renders, and the gain at equal time is gain / sqrt(time ratio) (as if both
errors fell as one over the square root of the samples: Sobol's falls faster where it gains, so
this is its lower bound). A bias check compares the two samplers' mean images over 4x4-pixel
blocks at the largest sample count (`block_bias`).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SAMPLERS = ("independent", "sobol")


def scene_paths(names):
    paths = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))
    if names:
        wanted = set(names)
        paths = [p for p in paths if p.stem in wanted]
    return paths


def with_sampler(graph, sampler: str):
    import dataclasses

    return dataclasses.replace(graph, image=graph.image.model_copy(update={"sampler": sampler}))


def render_mean(graph, spp: int, seed: int):
    from renderer.render import render

    result = render(graph, samples=spp, seed=seed, kernel="general")
    return result.film.mean(), result.stats.seconds


def relative_mse(images: np.ndarray, truth_sq: float) -> float:
    """Relative mean squared error of one render, from the spread of renders over seeds."""
    return float(images.var(axis=0, ddof=1).sum() / truth_sq)


def gain_with_error(ind: np.ndarray, sob: np.ndarray, truth_sq: float) -> tuple[float, float, float, float]:
    """(error_independent, error_sobol, gain, jackknife standard error of the gain)."""
    e_ind = np.sqrt(relative_mse(ind, truth_sq))
    e_sob = np.sqrt(relative_mse(sob, truth_sq))
    gain = e_ind / max(e_sob, 1e-300)
    r = ind.shape[0]
    leave = []
    for k in range(r):
        keep = [j for j in range(r) if j != k]
        leave.append(np.sqrt(relative_mse(ind[keep], truth_sq)) / max(np.sqrt(relative_mse(sob[keep], truth_sq)), 1e-300))
    leave = np.array(leave)
    se = float(np.sqrt((r - 1) / r * np.sum((leave - leave.mean()) ** 2)))
    return float(e_ind), float(e_sob), float(gain), se


def block_bias(ind: np.ndarray, sob: np.ndarray, block: int = 4) -> tuple[float, float, float]:
    """(mean z^2, largest |z|, expected mean z^2 without bias) of the difference of the two
    samplers' mean images over 4x4-pixel blocks and channels, each z a two-sample t statistic over
    seeds (variances pooled), with 2 (seeds - 1) degrees of freedom: its mean square is
    dof / (dof - 2) when both samplers converge to the same image, and grows with a bias."""
    def blocks(a):
        r, h, w, c = a.shape
        hb, wb = h // block, w // block
        return a[:, : hb * block, : wb * block].reshape(r, hb, block, wb, block, c).mean(axis=(2, 4))

    bi, bs = blocks(ind), blocks(sob)
    r = bi.shape[0]
    diff = bi.mean(axis=0) - bs.mean(axis=0)
    pooled = (bi.var(axis=0, ddof=1) + bs.var(axis=0, ddof=1)) / 2.0
    se = np.sqrt(pooled * 2.0 / r)
    noisy = se > 1e-12 * np.maximum(1.0, np.abs(bi.mean(axis=0)))
    z = diff[noisy] / se[noisy]
    dof = 2 * (r - 1)
    return float(np.mean(z**2)), float(np.abs(z).max()), dof / (dof - 2.0)


def reference_check(graph, spp: int, images: dict, levels) -> list[str]:
    """Errors against a converged reference (less its noise, from a second one), as a check."""
    ref_a, _ = render_mean(graph, spp, 1001)
    ref_b, _ = render_mean(graph, spp, 1002)
    truth_sq = float(np.sum(ref_a**2))
    # E|a - b|^2 = 2 * (the reference's own squared error).
    ref_mse = float(np.sum((ref_a - ref_b) ** 2) / 2.0 / truth_sq)
    lines = [f"    reference {spp} spp: own relative RMS error {np.sqrt(ref_mse):.4f}"]
    for n in levels:
        errs = {}
        for s in SAMPLERS:
            mse = np.mean([np.sum((img - ref_a) ** 2) / truth_sq for img in images[s, n]]) - ref_mse
            errs[s] = np.sqrt(max(mse, 0.0))
        lines.append(f"    {n:5d} spp against the reference: independent {errs['independent']:.4f}"
                     f"  sobol {errs['sobol']:.4f}  gain {errs['independent'] / max(errs['sobol'], 1e-300):.2f}")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", default="", help="comma-separated scene names (default: all)")
    parser.add_argument("--spp", default="16,64,256")
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--width", type=int, default=48)
    parser.add_argument("--reference-spp", type=int, default=0)
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from renderer.compile import with_width
    from scenefmt.validation import load

    levels = [int(x) for x in args.spp.split(",")]
    names = [n for n in args.scenes.split(",") if n]
    start = time.time()
    print(f"width {args.width}, seeds {args.seeds}, general kernel; error = relative RMS over seeds")
    print(f"{'scene':22s} {'spp':>5s} {'err indep':>10s} {'err sobol':>10s} {'gain':>12s} {'time s/i':>9s} {'time gain':>9s}")
    gains = {}
    for path in scene_paths(names):
        graph = with_width(load(path).graph, args.width)
        images, seconds = {}, {}
        variants = {s: with_sampler(graph, s) for s in SAMPLERS}
        for n in levels:
            runs = {s: [] for s in SAMPLERS}
            # The samplers take turns, seed by seed, so a change of the machine's load falls on both.
            for seed in range(1, args.seeds + 1):
                for s in SAMPLERS:
                    runs[s].append(render_mean(variants[s], n, seed))
            for s in SAMPLERS:
                images[s, n] = np.array([r[0] for r in runs[s]])
                seconds[s, n] = sum(r[1] for r in runs[s])
        pooled = np.concatenate([images[key] for key in images]).mean(axis=0)
        truth_sq = float(np.sum(pooled**2))
        for n in levels:
            e_i, e_s, gain, se = gain_with_error(images["independent", n], images["sobol", n], truth_sq)
            ratio = seconds["sobol", n] / max(seconds["independent", n], 1e-9)
            gains[path.stem, n] = (gain, se)
            # At equal time Sobol takes 1 / ratio of the samples, and its error grows by sqrt(ratio).
            print(f"{path.stem:22s} {n:5d} {e_i:10.4f} {e_s:10.4f} {gain:6.2f}+-{se:4.2f} {ratio:9.2f} "
                  f"{gain / np.sqrt(ratio):9.2f}", flush=True)
        top = levels[-1]
        mean_sq, worst, expected = block_bias(images["independent", top], images["sobol", top])
        print(f"{'':22s} bias check at {top} spp: blocks' mean z^2 {mean_sq:.2f} (no bias: {expected:.2f}), "
              f"largest |z| {worst:.1f}", flush=True)
        if args.reference_spp:
            for line in reference_check(graph, args.reference_spp, images, levels):
                print(line, flush=True)
    losers = sorted({scene for (scene, n), (g, se) in gains.items() if g + 2 * se < 1.0})
    print(f"scenes where sobol loses beyond 2 standard errors: {', '.join(losers) if losers else 'none'}")
    print(f"took {time.time() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
