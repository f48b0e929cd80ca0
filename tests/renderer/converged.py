"""Converged references: what an image of each scene is, closely enough to measure a render's true error.

For every shipped scene (scenes/*.yaml, scenes/*.json) and the benchmark scenes
(benchmarks/scenes/*.yaml), 48 pixels wide in the scene's own shape, with the default integrator and
the scene's own depth, two independent renders (seeds SEEDS) of SPP_BY_SCENE samples per pixel each.
A file tests/renderer/converged/STEM.npz keeps (float32):

- `mean`: the image, the mean of the two renders;
- `var`: the variance of each value of `mean` (h, w, 3), from the samples' own spread;
- `difference`: the first render less the second. Its squares measure the reference's own error
  without trusting the samples' spread: on a scene lit by rare bright paths that spread is
  underestimated, and the difference of two independent renders is not;

and the scalars `spp` (per render), `seeds`, `seconds` (of each render).

    python tests/renderer/converged.py STEM...          # (re)make these scenes' references
    python tests/renderer/converged.py --spp 4096 STEM  # with another sample count than the table's
    python tests/renderer/converged.py --integrator caustics --spp 131072 STEM
        # a second, independent reference made by another integrator, kept apart in
        # tests/renderer/converged/STEM.caustics.npz (the default integrator's file is left alone)

The coverage test (tests/test_error_coverage.py) and the accuracy study (benchmarks/accuracy.py)
read them through `load_reference` and measure with `true_error`.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CONVERGED_DIR = Path(__file__).resolve().parent / "converged"
WIDTH = 48
SEEDS = (900001, 900002)  # far from any seed a test or the study renders with
# Samples per pixel of each render. A reference's own relative error (one render's: the RMS of
# `difference` / sqrt 2) must be at most a quarter of a 256-spp render's true error. A render's
# expected squared error is the per-sample variance over its spp, so 16 x 256 = 4096 meets that on
# average, and 6144 leaves a margin (0.20 of it). The scenes lit through rare bright paths take 6 to
# 32 times 4096: a render of them often misses those paths, so its error is more often
# below its expected value, and two renders' difference would then say the reference is better
# than it is (the 4096-spp reference the study used before missed them: sky_spheres' true error at
# 256 spp is 0.35, and its reference at 2 x 131072 spp has 1/20 of that).
DEFAULT_SPP = 6144
SPP_BY_SCENE = {
    "sky_spheres": 131072,
    "caustic_glass": 65536,
    "material_spheres": 24576,
    # Lit only through glass: at 2,048 spp its own error is 10%, so 2^20 brings it to about 0.45%,
    # under a quarter of the caustics benchmark's 2% target (benchmarks/caustics.py).
    "glass_lamp": 1048576,
}


class Reference(NamedTuple):
    mean: np.ndarray  # (h, w, 3) float64
    var: np.ndarray  # (h, w, 3) float64: variance of `mean`
    difference: np.ndarray  # (h, w, 3) float64: first render less the second
    spp: int  # per render

    def own_error(self) -> float:
        """The relative RMS error of ONE of the two renders, measured from their difference."""
        return math.sqrt(float(np.sum(self.difference**2)) / 2.0 / _signal(self.mean))

    def own_error_from_spread(self) -> float:
        """The same figure from the samples' spread (the variance of one render is twice `var`)."""
        return math.sqrt(2.0 * float(np.sum(self.var)) / _signal(self.mean))


def _signal(image: np.ndarray) -> float:
    return float(np.sum(np.square(image, dtype=np.float64)))


def scene_files() -> list[Path]:
    """Every scene a reference is kept for: the shipped ones, then the benchmark scenes."""
    shipped = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))
    return shipped + sorted((ROOT / "benchmarks" / "scenes").glob("*.yaml"))


def scene_file(stem: str) -> Path:
    for path in scene_files():
        if path.stem == stem:
            return path
    raise KeyError(f"no scene named {stem!r}")


def reference_path(stem: str, integrator: str | None = None) -> Path:
    """The file of a scene's reference: STEM.npz for the scene's own integrator, STEM.INTEGRATOR.npz
    for one made with another (an independent estimator of the same image)."""
    return CONVERGED_DIR / (f"{stem}.npz" if integrator is None else f"{stem}.{integrator}.npz")


def load_reference(stem: str, integrator: str | None = None) -> Reference:
    return read_reference(reference_path(stem, integrator))


def true_error(image: np.ndarray, reference: Reference) -> float:
    """The relative RMS error of `image` against the truth: sqrt(sum of squared differences /
    sum of squared reference values), with the reference's own expected squared error removed
    from the sum (the two are independent, so their squared errors add)."""
    squared = float(np.sum((image - reference.mean) ** 2)) - float(np.sum(reference.var))
    return math.sqrt(max(squared, 0.0) / _signal(reference.mean))


def small_graph(path: Path, settings: tuple[str, ...] = ()):
    """The scene at `path`, `WIDTH` pixels wide, with `rt render --set` style `settings` applied
    (a variant of it, as benchmarks/caustics.py renders for Mitsuba)."""
    from renderer.compile import with_width
    from scenefmt.validation import load

    return with_width(load(path, settings).graph, WIDTH)


def render_reference(graph, spp: int, integrator: str | None = None) -> tuple[dict, list[float]]:
    """The arrays of a reference file (see the module's docstring) for `graph`, from two renders
    of `spp` samples per pixel with the seeds SEEDS (with `integrator` in place of the scene's own
    where given), and the seconds each took."""
    from renderer.render import render

    if integrator is not None:
        from renderer.compile import with_integrator

        graph = with_integrator(graph, integrator)
    films, seconds = [], []
    for seed in SEEDS:
        result = render(graph, samples=spp, seed=seed, kernel="general")
        films.append(result.film)
        seconds.append(result.stats.seconds)
    a, b = (f.mean() for f in films)
    n = 2 * spp
    total = films[0].total + films[1].total
    total_sq = films[0].total_sq + films[1].total_sq
    var = np.maximum(total_sq - total * (total / n), 0.0) / (n - 1) / n
    arrays = dict(mean=((a + b) / 2).astype(np.float32), var=var.astype(np.float32),
                  difference=(a - b).astype(np.float32), spp=np.int64(spp), seeds=np.array(SEEDS),
                  seconds=np.array(seconds))
    return arrays, seconds


def read_reference(path: Path) -> Reference:
    """A reference file's arrays, as `load_reference` gives them."""
    with np.load(path) as data:
        return Reference(data["mean"].astype(np.float64), data["var"].astype(np.float64),
                         data["difference"].astype(np.float64), int(data["spp"]))


def make_reference(path: Path, spp: int, integrator: str | None = None) -> tuple[Path, list[float]]:
    arrays, seconds = render_reference(small_graph(path), spp, integrator)
    CONVERGED_DIR.mkdir(exist_ok=True)
    out = reference_path(path.stem, integrator)
    np.savez_compressed(out, **arrays)
    return out, seconds


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description="(Re)make converged references of the named scenes.")
    parser.add_argument("stems", nargs="+", help="scene names, e.g. sky_spheres")
    parser.add_argument("--spp", type=int, default=0, help="samples per pixel of each render (default: the table's)")
    parser.add_argument("--integrator", default=None,
                        help="render with this integrator instead of the scene's own, into STEM.INTEGRATOR.npz "
                             "(e.g. caustics: a second, independent reference)")
    args = parser.parse_args(argv)
    known = {p.stem: p for p in scene_files()}
    unknown = sorted(set(args.stems) - set(known))
    if unknown:
        print(f"no scene named {', '.join(unknown)}", file=sys.stderr)
        return 1
    for stem in args.stems:
        spp = args.spp or SPP_BY_SCENE.get(stem, DEFAULT_SPP)
        started = time.perf_counter()
        out, seconds = make_reference(known[stem], spp, args.integrator)
        ref = load_reference(stem, args.integrator)
        print(f"{out.relative_to(ROOT)}: {ref.mean.shape[1]}x{ref.mean.shape[0]}, 2 x {spp} spp, "
              f"{seconds[0]:.1f} + {seconds[1]:.1f} s ({time.perf_counter() - started:.0f} s in all); "
              f"own error {ref.own_error():.4f} (from the spread {ref.own_error_from_spread():.4f})", flush=True)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main(sys.argv[1:]))
