"""The light tree against the choice by power, at equal time, against a converged reference.

    python benchmarks/light_tree.py [--scenes many_lights,cornell_box] [--width 96] [--seconds 8]
                                    [--repeats 2] [--reference-spp 1024] [--masked] [--threshold]

For each scene (scenes/NAME.yaml at `--width`, the general kernel for both):

- the tree's tables are built (forced on where the scene has too few lights for the threshold:
  the Cornell box's one light makes a tree of one leaf, so what is measured there is what the
  tree's code costs), and the power cdf's are the same flat scene with the tree's tables emptied
  (the kernel then chooses by `light_f`'s cdf, as a kernel without the path does);
- a reference is rendered with the tree at `--reference-spp`, and a second one with another seed:
  the relative RMS difference of the two, over sqrt(2), is the reference's own error, which is
  taken out of each error below (errors add in squares);
- each estimator renders `--repeats` times for `--seconds` (a time budget: the render stops
  after the pass that crosses it), the two alternating so that both see the machine alike; each
  error is the relative RMS error over the image, sqrt(sum (image - reference)^2 / sum
  reference^2), scaled to exactly `--seconds` by sqrt(seconds / budget) (error falls as one
  over the square root of the time); wall and CPU seconds (the process's, every thread) are
  printed beside each other.

The ratio is the power cdf's error over the tree's at equal time (> 1: the tree is better).

`--max-depth 2` renders every image of the study (references included) with direct light only:
what the two light samplers differ in, without the light after a bounce that both share.

`--masked` prints the same figures also over the pixels whose camera ray sees no emitter: a mask
made once per scene, before anything is timed, from a render at max_depth 1 (the camera ray's
first hit, no shadow ray: a pixel is masked out where any of its samples met emitted light, the
background's included). Both estimators, the reference and the reference's own error are
measured over the same pixels, from the same renders. A bulb seen within a pixel makes noise that
no choice of light sample touches; without those pixels the figure is the lighting's.

A scene is scenes/NAME.yaml, or a path ending in .yaml (relative to the repository), as
`--scenes benchmarks/light_tree_scenes/many_lights_open.yaml` (the night market lit by strings of
one-sided lamps over its aisles: scenes/generate_many_lights.py --open).

`--cost SPP` measures instead what each sample costs: the least time of 3 renders of SPP samples
per pixel by each estimator, alternating, with one seed (on the Cornell box the two images are the
same bit for bit: its one light is chosen with pmf 1 either way).

`--threshold` measures instead where the tree starts to pay: scenes of N small lamps (squares
facing down under shades, over a floor, N = 2 .. 64) rendered by each estimator; with no reference, the error of each is
taken from the film's own per-pixel variance of the mean (both are unbiased), times the seconds
spent, which is the equal-time figure.
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


def flats(graph, force: bool):
    """(the flat scene with a light tree, the same with the power cdf)."""
    from renderer.compile import compile_scene
    from renderer.light_tree import LTREE_F, LTREE_I
    from renderer.lights import light_tree_tables

    flat = compile_scene(graph)
    if force or len(flat.ltree_i) == 0:
        flat = flat._replace(**light_tree_tables(flat))
    return flat, flat._replace(ltree_f=LTREE_F.array(0), ltree_i=LTREE_I.array(0))


def render(graph, flat, seed: int, samples: int, budget: float | None = None, max_depth: int | None = None):
    from renderer.render import render as run

    cpu = time.process_time()
    result = run(graph, flat=flat, samples=samples, seed=seed, time_budget=budget, max_depth=max_depth, kernel="general")
    return result.film.mean(), result.stats.seconds, time.process_time() - cpu, result.film.samples


def rel_rms(image: np.ndarray, reference: np.ndarray, where: np.ndarray | None = None) -> float:
    """Relative RMS difference over the image, or over the pixels `where` is True (a (h, w) mask)."""
    if where is not None:
        image, reference = image[where], reference[where]
    return float(np.sqrt(((image - reference) ** 2).sum() / (reference ** 2).sum()))


def scene_path(name: str) -> Path:
    """scenes/NAME.yaml, or NAME itself (relative to the repository) where it ends in .yaml."""
    return ROOT / name if name.endswith(".yaml") else ROOT / "scenes" / f"{name}.yaml"


def unseen_emitters(graph, flat, samples: int = 256) -> np.ndarray:
    """(h, w) bool: the pixels none of whose camera rays (`samples` per pixel, at max_depth 1:
    the first hit's emission only, no shadow ray) met emitted light or the background."""
    image, _, _, _ = render(graph, flat, 1003, samples, max_depth=1)
    return ~(image > 0.0).any(axis=-1)


def without_reference(raw: float, ref_error: float, wall: float, seconds: float) -> float:
    """An error measured against the reference, less the reference's own (errors add in squares),
    scaled to exactly `seconds` (error falls as one over the square root of the time)."""
    return float(np.sqrt(max(raw * raw - ref_error * ref_error, 0.0)) * np.sqrt(wall / seconds))


def equal_time(name: str, width: int, seconds: float, repeats: int, reference_spp: int, masked: bool = False,
               max_depth: int | None = None) -> None:
    from renderer.compile import with_width
    from scenefmt.validation import load

    graph = with_width(load(scene_path(name)).graph, width)
    tree, power = flats(graph, force=True)
    lights = len(tree.light_i)
    render(graph, tree, 0, 1)  # the kernel compiled (or loaded) before anything is timed
    regions = {"all": None}
    if masked:
        regions["unseen"] = unseen_emitters(graph, tree)
    start = time.time()
    ref, ref_s, ref_cpu, _ = render(graph, tree, 1001, reference_spp, max_depth=max_depth)
    ref2, _, _, _ = render(graph, tree, 1002, reference_spp, max_depth=max_depth)
    ref_errors = {region: rel_rms(ref, ref2, where) / np.sqrt(2.0) for region, where in regions.items()}
    depth = f", max_depth {max_depth}" if max_depth else ""
    print(f"{Path(name).stem}{depth}: {width}x{graph.image.pixel_height}, {lights:,} lights, tree of {len(tree.ltree_i):,} nodes; "
          f"reference {reference_spp} spp x 2 ({time.time() - start:.0f} s), its own error {ref_errors['all']:.4f}")
    if masked:
        unseen = regions["unseen"]
        print(f"  pixels that see no emitter: {int(unseen.sum()):,} of {unseen.size:,} ({unseen.mean():.1%}); "
              f"the reference's own error over them {ref_errors['unseen']:.4f}")
    errors = {(method, region): [] for method in ("power", "tree") for region in regions}
    for k in range(repeats):
        for method, flat in (("power", power), ("tree", tree)) if k % 2 == 0 else (("tree", tree), ("power", power)):
            image, wall, cpu, spp = render(graph, flat, 7 + k, 1 << 20, seconds, max_depth=max_depth)
            figures = []
            for region, where in regions.items():
                raw = rel_rms(image, ref, where)
                error = without_reference(raw, ref_errors[region], wall, seconds)
                errors[method, region].append(error)
                figures.append(f"{region}: {raw:.4f} raw, {error:.4f}")
            print(f"  {method:5s} run {k}: {spp:5d} spp in {wall:5.1f} s wall, {cpu:5.1f} s CPU; error "
                  f"({'; '.join(figures)} at {seconds:g} s without the reference's)")
    for region in regions:
        tree_error, power_error = np.mean(errors["tree", region]), np.mean(errors["power", region])
        label = "over every pixel" if region == "all" else "over the pixels that see no emitter"
        print(f"  => error at equal time {label}: power {power_error:.4f}, tree {tree_error:.4f}; "
              f"ratio power / tree {power_error / tree_error:.2f}")


def cost(name: str, width: int, spp: int, repeats: int = 3) -> None:
    """Seconds per render of `spp` samples per pixel by each estimator, the least of `repeats`
    alternating renders with one seed (the least is the one the machine's other work disturbed
    least), and whether the two images are the same."""
    from renderer.compile import with_width
    from scenefmt.validation import load

    graph = with_width(load(scene_path(name)).graph, width)
    tree, power = flats(graph, force=True)
    render(graph, tree, 0, 1)
    best = {"power": (math.inf, math.inf), "tree": (math.inf, math.inf)}
    images = {}
    for k in range(repeats):
        for method, flat in (("power", power), ("tree", tree)) if k % 2 == 0 else (("tree", tree), ("power", power)):
            image, wall, cpu, _ = render(graph, flat, 5, spp)
            best[method] = (min(best[method][0], wall), min(best[method][1], cpu))
            images[method] = image
    same = np.array_equal(images["power"], images["tree"])
    print(f"{name}: {spp} spp at {width} px wide, least of {repeats}: power {best['power'][0]:.2f} s wall, {best['power'][1]:.2f} s CPU; "
          f"tree {best['tree'][0]:.2f} s wall, {best['tree'][1]:.2f} s CPU; the tree takes {best['tree'][0] / best['power'][0]:.3f} x the "
          f"time; images {'the same, bit for bit' if same else 'differ'}")


THRESHOLD_SCENE = """
materials: {{white: {{type: lambertian, albedo: [0.6, 0.6, 0.6]}}, lamp: {{type: diffuse_light, emit: [20, 20, 20]}}}}
camera: {{look_from: [0, 12, 6], look_at: [0, 0, 0], vfov: 60}}
image: {{width: 64, aspect_ratio: 1, max_depth: 3}}
shapes:
  - {{type: quad, q: [-8, 0, -8], u: [16, 0, 0], v: [0, 0, 16], material: white}}
{lamps}
"""
# A lamp: a small square facing down under a shade (a thin box) that hides it from the camera
# above, so that the image's noise is the lighting's, not that of lamps seen within a pixel.
LAMP = ("  - {{type: quad, q: [{x0:.3f}, {y:.3f}, {z0:.3f}], u: [0.2, 0, 0], v: [0, 0, 0.2], material: lamp}}\n"
        "  - {{type: box, min: [{x1:.3f}, {y1:.3f}, {z1:.3f}], max: [{x2:.3f}, {y2:.3f}, {z2:.3f}], material: white}}")


def threshold(seconds: float) -> None:
    """Equal-time error of both estimators on floors lit by N small lamps."""
    from scenefmt.validation import loads

    rng = np.random.default_rng(12)
    print(f"threshold: N small lamps over a floor, 64x64, {seconds:g} s each; error from the film's own variance")
    for n in (2, 4, 8, 16, 32, 64):
        xz = rng.uniform(-7, 7, (n, 2))
        heights = rng.uniform(0.3, 1.5, n)
        lamps = "\n".join(LAMP.format(x0=x - 0.1, y=y, z0=z - 0.1, x1=x - 0.15, y1=y + 0.001, z1=z - 0.15, x2=x + 0.15, y2=y + 0.03,
                                       z2=z + 0.15) for (x, z), y in zip(xz, heights))
        graph = loads(THRESHOLD_SCENE.format(lamps=lamps)).graph
        tree, power = flats(graph, force=True)
        figures = {}
        for method, flat in (("power", power), ("tree", tree)):
            from renderer.render import render as run

            run(graph, flat=flat, samples=1, kernel="general")
            result = run(graph, flat=flat, samples=1 << 20, time_budget=seconds, kernel="general")
            film = result.film
            m = film.total / film.samples
            # The variance of the mean: the samples' spread (biased form) over n - 1.
            var = np.maximum(film.total_sq / film.samples - m * m, 0.0) / (film.samples - 1)
            figures[method] = np.sqrt(var.sum() / (m * m).sum()) * np.sqrt(result.stats.seconds / seconds)
        print(f"  N = {n:3d}: error power {figures['power']:.2e}, tree {figures['tree']:.2e}, "
              f"ratio {figures['power'] / figures['tree']:.2f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default="many_lights,cornell_box")
    parser.add_argument("--width", type=int, default=96)
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--masked", action="store_true",
                        help="also measure over the pixels whose camera ray sees no emitter (a mask from a max_depth 1 render)")
    parser.add_argument("--max-depth", type=int, default=None,
                        help="render every image of the equal-time study at this depth (2: direct light only)")
    parser.add_argument("--threshold", action="store_true", help="measure where the tree starts to pay instead")
    parser.add_argument("--cost", type=int, default=0, metavar="SPP",
                        help="measure instead the time of SPP samples per pixel by each estimator (least of 3)")
    args = parser.parse_args(argv)
    began = time.time()
    if args.threshold:
        threshold(args.seconds)
    elif args.cost:
        for name in args.scenes.split(","):
            cost(name, args.width, args.cost)
    else:
        for name in args.scenes.split(","):
            equal_time(name, args.width, args.seconds, args.repeats, args.reference_spp, args.masked, args.max_depth)
    print(f"({time.time() - began:.0f} s in all)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
