"""Error at equal time on a glossy surface: light sampling with MIS (`mis`) against the books' `path`.

    python benchmarks/glossy_light_sampling.py [--width 128] [--seconds 4] [--ref-spp 4096]
                                               [--clock cpu|wall] [--material YAML]

The scene: the shipped Cornell box with its lamp shrunk to 20 x 20 at the same power (a small,
bright light), a rough metal floor and a rough metal sphere where the tall block stood (gold,
GGX alpha 0.15; `--material` changes it), and dim walls (grey 0.4 and the box's red and green)
lit by that lamp. A glossy lobe of that width sees the lamp in a cone of a few degrees: `path`
finds it only when a sampled direction happens to fall on it, while `mis` also aims a shadow ray
at it from every glossy vertex and weighs the two by the power heuristic.

Printed: two converged references (`mis` at --ref-spp, two seeds; their RMS difference over
root 2 is each one's own error, which must be far below the errors measured), then per
integrator the samples reached in the budget, wall and CPU seconds, and the RMS error against the
first reference over the pixels that see no light (light_pixels.py), less the reference's own
noise, scaled to exactly the budget (error falls as one over the root of time). With
--clock cpu (the default) both integrators get the same CPU seconds of this process (all its
threads), which a machine shared with other work leaves fair; with --clock wall the same wall time.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from integrators import error
from light_pixels import kept_pixels

ROOT = Path(__file__).resolve().parents[1]
CACHE = Path(__file__).resolve().parent / ".cache"
METAL = "{type: conductor, metal: gold, alpha: 0.15}"
SMALL_LAMP = (
    # 20 x 20 centred where the 130 x 105 lamp was, 34.125 times brighter: the same power.
    "shapes[2]={type: quad, q: [288, 554, 289.5], u: [-20, 0, 0], v: [0, 0, -20], material: light}",
    "materials.light={type: diffuse_light, emit: [511.875, 511.875, 511.875]}",
)


def settings(material: str) -> tuple[str, ...]:
    return SMALL_LAMP + (
        "materials.white={type: lambertian, albedo: [0.4, 0.4, 0.4]}",  # dim surroundings
        f"materials.glossy={material}",
        "shapes[3].material=glossy",  # the floor
        "shapes[6]={type: sphere, center: [380, 120, 380], radius: 120, material: glossy}",
    )


def load_graph(material: str, width: int, integrator: str):
    from renderer.compile import with_integrator, with_width
    from scenefmt.validation import load

    graph = load(ROOT / "scenes" / "cornell_box.yaml", settings(material)).graph
    return with_integrator(with_width(graph, width), integrator)


def reference(graph, spp: int, seed: int, tag: str) -> tuple[np.ndarray, np.ndarray, float]:
    """A converged `mis` image, the variance of its pixel means, and the seconds it took (cached)."""
    from renderer.render import render

    CACHE.mkdir(exist_ok=True)
    path = CACHE / f"glossy-{tag}-{graph.image.width}-{spp}-{seed}.npz"
    if path.exists():
        saved = np.load(path)
        return saved["mean"], saved["var"], float(saved["seconds"])
    t0 = time.perf_counter()
    film = render(graph, samples=spp, seed=seed, kernel="general").film
    seconds = time.perf_counter() - t0
    np.savez(path, mean=film.mean(), var=film.mean_variance(), seconds=seconds)
    return film.mean(), film.mean_variance(), seconds


def equal_time(graph, seconds: float, clock: str):
    """Render for `seconds` of the chosen clock: (film, wall seconds, CPU seconds)."""
    from renderer.compile import compile_scene
    from renderer.render import render

    flat = compile_scene(graph)
    render(graph, flat=flat, samples=1, kernel="general")  # load (or compile) the kernel before the clock starts
    t0, c0 = time.perf_counter(), time.process_time()
    if clock == "cpu":
        result = render(graph, flat=flat, samples=1_000_000, seed=1, kernel="general", pass_seconds=0.25,
                        should_stop=lambda: time.process_time() - c0 >= seconds)
    else:
        result = render(graph, flat=flat, samples=1_000_000, time_budget=seconds, seed=1, kernel="general")
    return result.film, time.perf_counter() - t0, time.process_time() - c0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=128)
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--ref-spp", type=int, default=4096)
    parser.add_argument("--clock", choices=("cpu", "wall"), default="cpu")
    parser.add_argument("--material", default=METAL, help="the glossy material, as YAML")
    args = parser.parse_args(argv)
    import hashlib

    import numba

    tag = hashlib.sha256(args.material.encode()).hexdigest()[:8]
    graph = load_graph(args.material, args.width, "mis")
    print(f"{numba.get_num_threads()} threads, {graph.image.width}x{graph.image.pixel_height}, floor and sphere: "
          f"{args.material}; {args.seconds:g} {args.clock} seconds per integrator; references: mis at {args.ref_spp} spp")
    ref = reference(graph, args.ref_spp, 9001, tag)
    second = reference(graph, args.ref_spp, 9002, tag)
    keep = kept_pixels(graph, ref[0])
    own = float(np.sqrt(np.mean((ref[0][keep] - second[0][keep]) ** 2) / 2))
    print(f"  references: {ref[2]:.0f} s and {second[2]:.0f} s; each one's own RMS error {own:.5f} "
          f"(from their difference; the renderer's estimate {float(np.sqrt(np.mean(ref[1][keep]))):.5f}); "
          f"{np.mean(~keep):.1%} of pixels see the lamp and are left out")
    print(f"  {'integrator':10} {'spp':>6} {'wall s':>7} {'CPU s':>7} {'RMSE':>8} {'RMSE at budget':>15}")
    errors = {}
    for integrator in ("path", "mis"):
        film, wall, cpu = equal_time(load_graph(args.material, args.width, integrator), args.seconds, args.clock)
        rmse = error(film.mean(), ref[:2], keep)
        spent = cpu if args.clock == "cpu" else wall
        errors[integrator] = rmse * math.sqrt(spent / args.seconds)
        print(f"  {integrator:10} {film.samples:>6} {wall:>7.2f} {cpu:>7.2f} {rmse:>8.5f} {errors[integrator]:>15.5f}",
              flush=True)
    ratio = errors["path"] / errors["mis"]
    print(f"  error at equal {args.clock} time ({args.seconds:g} s), path / mis: {ratio:.2f} "
          f"(time for path to match mis: {ratio ** 2:.1f} x); references' own error is "
          f"{own / errors['mis']:.2f} of mis's")
    return 0


if __name__ == "__main__":
    sys.exit(main())
