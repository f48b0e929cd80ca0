"""Error at equal time: light sampling with MIS (`mis`, the default) against the books' estimator (`path`).

    python benchmarks/integrators.py [--scenes cornell_box,cornell_smoke] [--width 600] [--seconds 6]
                                     [--ref-spp 1024] [--kernel general] [--mitsuba]

For each scene at the given width: a converged reference (the default integrator at --ref-spp
samples per pixel, another seed; cached in benchmarks/.cache/; its own noise is taken out of
the errors), then each integrator rendered
for the same wall time, side by side in this process. Printed per integrator: samples per pixel
reached, rays per second (shadow rays included), seconds per sample, the RMS error against the
reference with the pixels that see a light left out (light_pixels.py: wholly or in part; their
value and their noise are the camera's, the same for both), the renderer's own noise estimate, and the samples and seconds each needs for
2% and 1% relative noise (from that estimate: noise falls as one over the square root of the
samples). The ratio of the two errors is the figure the light-sampling issue asks for (at least
8 on the 600 x 600 Cornell box); the ratio with the mask used before (only pixels brighter than 1
left out, so the lamp's rim stayed in) is printed beside it.

Both integrators run on the general kernel, which any render can start with at once; with
--kernel specialised, on the kernel compiled for the scene's effects, which `rt render` uses
once it has been compiled (renderer/variants.py).

With --mitsuba (pip install mitsuba; its LLVM variant needs DRJIT_LIBLLVM_PATH set to a
libLLVM.so of version 19 or so), the Cornell box is also rendered by Mitsuba 3's path tracer for
the same wall time and its error against the same reference printed. Mitsuba's area lights are
one-sided and ours two-sided; the box's light faces down, into the box, so the images agree.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from light_pixels import kept_pixels

ROOT = Path(__file__).resolve().parents[1]
CACHE = Path(__file__).resolve().parent / ".cache"
TARGETS = (0.02, 0.01)
PASS_SPP = 4  # samples per Mitsuba pass


SETTINGS: tuple[str, ...] = ()  # --set overrides applied to every scene (see --set)


def load_graph(stem: str, width: int):
    from renderer.compile import with_width
    from scenefmt.validation import load

    return with_width(load(ROOT / "scenes" / f"{stem}.yaml", SETTINGS).graph, width)


def reference(stem: str, graph, width: int, spp: int) -> tuple[np.ndarray, np.ndarray]:
    """The reference image and the variance of each of its pixel means (its own noise)."""
    from renderer.compile import with_integrator
    from renderer.render import render

    CACHE.mkdir(exist_ok=True)
    path = CACHE / f"{stem}-{width}-{spp}.npz"
    if path.exists():
        saved = np.load(path)
        return saved["mean"], saved["var"]
    t0 = time.perf_counter()
    film = render(with_integrator(graph, "mis"), samples=spp, seed=9001).film
    mean = film.mean()
    var = film.mean_variance()
    np.savez(path, mean=mean, var=var)
    print(f"  reference {stem}: {spp} spp in {time.perf_counter() - t0:.0f} s (cached in {path})", flush=True)
    return mean, var


def error(image: np.ndarray, ref: tuple[np.ndarray, np.ndarray], keep: np.ndarray) -> float:
    """RMS error over the kept pixels (all channels), less the reference's own noise: the
    expected squared difference is the image's squared error plus the reference's variance."""
    mean, var = ref
    mse = np.mean((image[keep] - mean[keep]) ** 2) - np.mean(var[keep])
    return float(np.sqrt(max(mse, 0.0)))


def equal_time(graph, integrator: str, seconds: float, kernel: str = "general"):
    from renderer.compile import compile_scene, with_integrator
    from renderer.film import estimate_noise
    from renderer.render import render

    g = with_integrator(graph, integrator)
    flat = compile_scene(g)
    render(g, flat=flat, samples=1, kernel=kernel)  # load (or compile) the kernel before the clock starts
    result = render(g, flat=flat, samples=1_000_000, time_budget=seconds, seed=1, kernel=kernel)
    noise = estimate_noise(result.film).relative_rms
    return result, noise


def mitsuba_cornell(width: int, seconds: float):
    """Mitsuba 3's path tracer on the Cornell box for `seconds` of wall time: (image, spp, seconds, variant)."""
    import mitsuba as mi
    from mitsuba_scene import render_passes, scene_dict, set_variant

    variant = set_variant()
    scene_mi = mi.load_dict(scene_dict(load_graph("cornell_box", width), spp=PASS_SPP))
    passes = render_passes(scene_mi, PASS_SPP, seconds=seconds)
    return passes.mean(), passes.samples, passes.seconds, variant


def mitsuba_reference(width: int, seconds: float, tag: str = ""):
    """Mitsuba's own converged image of the Cornell box (cached): its light is one-sided, so it
    lacks the light our two-sided lamp sends up into the ceiling, and its mean differs from ours."""
    path = CACHE / f"mitsuba-cornell_box{tag}-{width}-{seconds:g}.npy"
    if path.exists():
        return np.load(path)
    image, spp, took, _ = mitsuba_cornell(width, seconds)
    np.save(path, image)
    print(f"  mitsuba reference: {spp} spp in {took:.0f} s (cached in {path})", flush=True)
    return image


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default="cornell_box,cornell_smoke,final_scene,simple_light")
    parser.add_argument("--width", type=int, default=600)
    parser.add_argument("--seconds", type=float, default=6.0)
    parser.add_argument("--ref-spp", type=int, default=1024)
    parser.add_argument("--kernel", choices=("general", "specialised"), default="general")
    parser.add_argument("--mitsuba", action="store_true")
    parser.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                        help="change the scenes as rt render --set does; e.g. shapes[2].q=[343,554.999,332] puts the "
                        "Cornell box's lamp flush with the ceiling, so its two-sided light matches Mitsuba's one-sided one")
    args = parser.parse_args(argv)
    global SETTINGS
    SETTINGS = tuple(args.set)
    tag = "-" + __import__("hashlib").sha256("\n".join(SETTINGS).encode()).hexdigest()[:8] if SETTINGS else ""
    import numba

    print(f"{numba.get_num_threads()} threads, {args.width} pixels wide, {args.seconds:g} s per integrator, "
          f"references at {args.ref_spp} spp, {args.kernel} kernel")
    for stem in args.scenes.split(","):
        graph = load_graph(stem, args.width)
        ref = reference(stem + tag, graph, args.width, args.ref_spp)
        bright = ref[0].max(axis=2) <= 1.0  # the mask used before: only pixels brighter than 1 left out
        keep = kept_pixels(graph, ref[0])
        print(f"\n{stem} ({graph.image.width}x{graph.image.pixel_height}, {np.mean(~keep):.2%} of pixels see a light "
              f"or are brighter than 1, {np.sum(bright & ~keep)} of them only in part):")
        print(f"  {'integrator':10} {'spp':>6} {'s':>6} {'Mrays/s':>8} {'s/spp':>7} {'RMSE':>8} {'noise':>7}  "
              + "  ".join(f"spp,s to {100 * t:g}%" for t in TARGETS))
        errors, errors_bright = {}, {}
        for integrator in ("path", "mis"):
            result, noise = equal_time(graph, integrator, args.seconds, args.kernel)
            stats, film = result.stats, result.film
            rmse = error(film.mean(), ref, keep)
            # The ratios compare errors at exactly the same time: a render stops between passes,
            # a little before or after the budget, and error falls as one over the root of time.
            at_budget = math.sqrt(stats.seconds / args.seconds)
            errors[integrator] = rmse * at_budget
            errors_bright[integrator] = error(film.mean(), ref, bright) * at_budget
            per = stats.seconds / max(1, film.samples)
            need = "  ".join(f"{math.ceil(film.samples * (noise / t) ** 2):>7} {film.samples * (noise / t) ** 2 * per:>6.0f}"
                             for t in TARGETS)
            print(f"  {integrator:10} {film.samples:>6} {stats.seconds:>6.2f} {stats.rays_per_second / 1e6:>8.2f} "
                  f"{per:>7.3f} {rmse:>8.4f} {100 * noise:>6.2f}%  {need}", flush=True)
        print(f"  error at equal time ({args.seconds:g} s), path / mis: {errors['path'] / errors['mis']:.2f} "
              f"(with the lamp's rim kept in: {errors_bright['path'] / errors_bright['mis']:.2f})")
        if args.mitsuba and stem == "cornell_box":
            try:
                image, spp, seconds, variant = mitsuba_cornell(graph.image.width, args.seconds)
            except ImportError:
                print("  mitsuba: not installed (pip install mitsuba)")
                continue
            own = mitsuba_reference(graph.image.width, 20 * args.seconds, tag)
            noise = float(np.sqrt(np.mean((image[keep] - own[keep]) ** 2)))
            bias = float(np.mean(own[keep]) / np.mean(ref[0][keep]) - 1.0)
            print(f"  mitsuba {variant}: {spp} spp in {seconds:.2f} s, RMSE {noise:.4f} against its own converged image "
                  f"(20x the time; its mean is {100 * bias:+.1f}% from ours: one-sided light); "
                  f"rt mis / mitsuba error at {args.seconds:g} s: {errors['mis'] / (noise * math.sqrt(seconds / args.seconds)):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
