"""Side by side with Mitsuba 3: one Cornell box per material family, rendered by both, compared within noise.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so \\
    python benchmarks/mitsuba_materials.py [--cases lambertian,conductor_0.05,...] [--width 128]
                                           [--spp 1024] [--mitsuba-spp 1024] [--block 16]

Each case is the shipped Cornell box (scenes/cornell_box.yaml) with its lamp flush with the
ceiling (mitsuba_scene.FLUSH_LAMP: our lamp is two-sided, Mitsuba's one-sided) and, but for
`lambertian`, the tall block replaced by a sphere of the material under test, written as
`rt render --set` arguments (printed per case), so `rt render scenes/cornell_box.yaml --set ...`
renders the same scene. The materials give the GGX width as `alpha:` and `shadowing: separable`,
Mitsuba's form; mitsuba_scene.py converts the scene (two-sided BSDFs, depth, pixel filter).
Figures and what they showed: docs/materials.md, "Side by side with Mitsuba 3".

Printed per case: for each renderer the samples per pixel, wall and CPU seconds, the image mean
per channel with its standard error; then the z-score of the difference of the image means per
channel, the largest |z| over the means of blocks of --block x --block pixels (every channel), and
PASS when both stay below the Bonferroni bound of their number of tests at significance 1e-3
(tests/renderer/stats.py), FAIL otherwise. A difference of image means that the test could
detect is about 3.5 times the standard error of the difference, printed beside it as a percentage
of the mean ("detects").

The standard errors: ours from each pixel's samples (Film.mean_variance); Mitsuba's from the
spread of its passes (each pass --mitsuba-pass samples, its own seed), per pixel. A block's or the
image's variance is the sum of its pixels'.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from mitsuba_scene import FLUSH_LAMP, render_passes, scene_dict, set_variant

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.renderer.stats import z_limit  # noqa: E402

ALPHA = 1e-3
SPHERE = "shapes[6]={type: sphere, center: [380, 120, 380], radius: 120, material: probe}"


def probe(material: str) -> tuple[str, ...]:
    """Overrides that put a sphere of `material` (YAML) where the tall block stood."""
    return (f"materials.probe={material}", SPHERE)


# name -> (what it shows, the --set arguments on top of the flush lamp)
CASES: dict[str, tuple[str, tuple[str, ...]]] = {
    "lambertian": ("the shipped box, lambertian only (the harness's own check)", ()),
    "conductor_0.05": ("rough gold, alpha 0.05",
                       probe("{type: conductor, metal: gold, alpha: 0.05, shadowing: separable}")),
    "conductor_0.3": ("rough gold, alpha 0.3",
                      probe("{type: conductor, metal: gold, alpha: 0.3, shadowing: separable}")),
    "conductor_aniso": ("rough gold, anisotropic: alpha 0.3 along the sphere's u (around +y), 0.05 along v",
                        probe("{type: conductor, metal: gold, alpha: 0.3, alpha_v: 0.05, shadowing: separable}")),
    "rough_dielectric": ("rough glass, alpha 0.2, ior 1.5",
                         probe("{type: rough_dielectric, ior: 1.5, alpha: 0.2, shadowing: separable}")),
    "thin_dielectric": ("a thin sheet of glass (ior 1.5) as a sphere: reflects, and lets light through unbent",
                        probe("{type: thin_dielectric, ior: 1.5}")),
    "plastic": ("smooth plastic, ior 1.5 over blue",
                probe("{type: plastic, albedo: [0.1, 0.25, 0.6], ior: 1.5}")),
    "roughplastic": ("rough plastic, alpha 0.2, ior 1.5 over blue",
                     probe("{type: plastic, albedo: [0.1, 0.25, 0.6], ior: 1.5, alpha: 0.2, shadowing: separable}")),
}


def load_case(name: str, width: int):
    from renderer.compile import with_width
    from scenefmt.validation import load

    return with_width(load(ROOT / "scenes" / "cornell_box.yaml", FLUSH_LAMP + CASES[name][1]).graph, width)


def ours(graph, spp: int, seed: int):
    """Our render (the scene's integrator, mis): (image, variance of each pixel's mean, spp, wall s, CPU s)."""
    from renderer.compile import compile_scene
    from renderer.render import render

    flat = compile_scene(graph)
    render(graph, flat=flat, samples=1, kernel="general")  # compile or load the kernel before the clock starts
    t0, c0 = time.perf_counter(), time.process_time()
    film = render(graph, flat=flat, samples=spp, seed=seed, kernel="general").film
    return film.mean(), film.mean_variance(), film.samples, time.perf_counter() - t0, time.process_time() - c0


def theirs(graph, spp: int, pass_spp: int):
    """Mitsuba's render of the same scene: (image, variance of each pixel's mean, spp, wall s, CPU s)."""
    import mitsuba as mi

    scene = mi.load_dict(scene_dict(graph, spp=pass_spp))
    passes = render_passes(scene, pass_spp, passes=max(2, -(-spp // pass_spp)))
    return passes.mean(), passes.mean_variance(), passes.samples, passes.seconds, passes.cpu_seconds


def block_means(image: np.ndarray, var: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean of each block of block x block pixels (per channel) and the variance of that mean."""
    h, w, _ = image.shape
    hb, wb = h // block, w // block

    def blocks(a):
        return a[: hb * block, : wb * block].reshape(hb, block, wb, block, 3).sum(axis=(1, 3))

    n = block * block
    return blocks(image) / n, blocks(var) / (n * n)


def compare(a, b, block: int) -> dict:
    """The statistics of two renders (image, variance of pixel means) of the same scene."""
    (ia, va), (ib, vb) = a, b
    npix = ia.shape[0] * ia.shape[1]
    mean_a, mean_b = ia.mean(axis=(0, 1)), ib.mean(axis=(0, 1))
    se_a, se_b = np.sqrt(va.sum(axis=(0, 1))) / npix, np.sqrt(vb.sum(axis=(0, 1))) / npix
    se = np.sqrt(se_a ** 2 + se_b ** 2)
    z_image = (mean_a - mean_b) / np.where(se > 0, se, 1.0)
    ba, bva = block_means(ia, va, block)
    bb, bvb = block_means(ib, vb, block)
    bse = np.sqrt(bva + bvb)
    diff = ba - bb
    z_blocks = np.where(bse > 0, diff / np.where(bse > 0, bse, 1.0), np.where(np.abs(diff) > 1e-9, np.inf, 0.0))
    worst = np.unravel_index(np.argmax(np.abs(z_blocks)), z_blocks.shape)
    limit_image, limit_blocks = z_limit(3, ALPHA), z_limit(z_blocks.size, ALPHA)
    ok = bool(np.all(np.abs(z_image) < limit_image) and np.max(np.abs(z_blocks)) < limit_blocks)
    return {"mean_a": mean_a, "mean_b": mean_b, "se_a": se_a, "se_b": se_b, "z_image": z_image,
            "limit_image": limit_image, "detects": limit_image * se / np.maximum(np.abs(mean_b), 1e-12),
            "z_blocks": float(np.abs(z_blocks[worst])), "worst_block": worst, "blocks": z_blocks.size,
            "limit_blocks": limit_blocks, "ok": ok}


def print_comparison(a, b, r: dict, verdict: str) -> np.ndarray:
    """Print a case's two renders (`ours`' and `theirs`' tuples) and their comparison `r`
    (`compare`'s) with `verdict` at the end; return rt / Mitsuba - 1 per channel, in per cent."""
    for label, run, mean, se in (("rt", a, r["mean_a"], r["se_a"]), ("mitsuba", b, r["mean_b"], r["se_b"])):
        print(f"  {label:8} {run[2]:>6} spp {run[3]:>7.1f} s wall {run[4]:>7.1f} s CPU   mean {triple(mean)}   "
              f"se {triple(se)} ({triple(100 * se / np.maximum(mean, 1e-12), '.2f')} %)")
    rel = 100 * (r["mean_a"] / np.maximum(r["mean_b"], 1e-12) - 1)
    print(f"  rt/mitsuba - 1: {triple(rel, '+.2f')} %; z of the image means {triple(r['z_image'], '+.2f')} "
          f"(bound {r['limit_image']:.2f}; detects {triple(100 * r['detects'], '.2f')} %)")
    print(f"  largest |z| of {r['blocks']} block means: {r['z_blocks']:.2f} at block (row, col, channel) "
          f"{tuple(int(x) for x in r['worst_block'])} (bound {r['limit_blocks']:.2f})  {verdict}", flush=True)
    return rel


def triple(x, fmt: str = ".4f") -> str:
    return " ".join(format(float(v), fmt) for v in x)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--width", type=int, default=128)
    parser.add_argument("--spp", type=int, default=1024, help="our samples per pixel")
    parser.add_argument("--mitsuba-spp", type=int, default=1024, help="Mitsuba's samples per pixel")
    parser.add_argument("--mitsuba-pass", type=int, default=32, help="Mitsuba's samples per pass (its noise comes from their spread)")
    parser.add_argument("--block", type=int, default=16)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    import numba

    variant = set_variant()
    print(f"Mitsuba {__import__('mitsuba').__version__} {variant}; ours on {numba.get_num_threads()} threads, general kernel; "
          f"{args.width} pixels wide; blocks of {args.block}x{args.block}; significance {ALPHA:g} per case (Bonferroni)")
    failed = []
    for name in args.cases.split(","):
        what, settings = CASES[name]
        graph = load_case(name, args.width)
        print(f"\n{name}: {what} ({graph.image.width}x{graph.image.pixel_height}, depth {graph.image.max_depth})")
        for s in settings:
            print(f"  --set '{s}'")
        a = ours(graph, args.spp, args.seed)
        b = theirs(graph, args.mitsuba_spp, args.mitsuba_pass)
        r = compare(a[:2], b[:2], args.block)
        print_comparison(a, b, r, "PASS" if r["ok"] else "FAIL")
        if not r["ok"]:
            failed.append(name)
        cache = Path(__file__).resolve().parent / ".cache"
        cache.mkdir(exist_ok=True)
        np.savez(cache / f"mitsuba_materials-{name}-{args.width}.npz", rt=a[0], rt_var=a[1], mitsuba=b[0], mitsuba_var=b[1])
    print(f"\n{'all PASS' if not failed else 'FAIL: ' + ', '.join(failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
