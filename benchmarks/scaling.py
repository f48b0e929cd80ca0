"""How render time and memory grow with the number of primitives (10^2 .. 10^6 spheres, or
icosphere meshes of 20 k^2 triangles read from PLY files).

    python benchmarks/scaling.py [--max-exponent 6] [--spp 4]
    python benchmarks/scaling.py --meshes [--max-triangles 3000000] [--spp 4] [--plot docs/meshes_scaling.png]
    python benchmarks/scaling.py --sphere-file 1000000 [--syntax json|yaml]

Spheres are scattered uniformly through a fixed cube with radii shrinking as N^(-1/3), so the
picture stays alike while N grows. For each N it prints the time to build the scene (models,
graph, flat tables and BVH), the render time per sample per pixel, rays per second, and the
memory of the flat scene per primitive. With a BVH the time per sample should grow about
like log N, not like N.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def build(n: int, seed: int = 1):
    from scenefmt import models as m
    from scenefmt.graph import build_graph

    rng = np.random.default_rng(seed)
    centers = rng.uniform(-10, 10, (n, 3))
    radius = 2.0 * (100.0 / n) ** (1 / 3)
    shapes = [m.Sphere(center=tuple(c), radius=radius, material="white") for c in centers.tolist()]
    scene = m.Scene(
        camera=m.Camera(look_from=(0, 0, 30), look_at=(0, 0, 0), vfov=45),
        image=m.Image(width=96, aspect_ratio=1, samples_per_pixel=4, max_depth=4),
        materials={"white": m.Lambertian(albedo=(0.7, 0.7, 0.7))},
        shapes=shapes,
    )
    return build_graph(scene)


MESH_SCENE = """
camera: {look_from: [0, 0.8, 3.2], look_at: [0, 0, 0], vfov: 40}
image: {width: 96, aspect_ratio: 1.0, samples_per_pixel: 1, max_depth: 4}
background: [0.8, 0.85, 1.0]
materials: {white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}}
shapes:
  - {type: mesh, file: mesh.ply, material: white}
"""


def plot(rows: list[tuple[int, float]], path: Path) -> None:
    """Render time per sample against the number of triangles, on a log axis: a straight line is log N."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.2), dpi=120)
    ax.plot([n for n, _ in rows], [ms for _, ms in rows], "o-")
    ax.set_xscale("log")
    ax.set_xlabel("triangles (icosphere)")
    ax.set_ylabel("ms per sample, 96 x 96 px")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)


def meshes(max_triangles: int, spp: int, plot_to: Path | None = None) -> None:
    """File to first sample (read, check, flatten, tree), memory and render time per sample."""
    import tempfile

    from renderer.compile import compile_scene
    from renderer.render import render
    from scenefmt import meshgen
    from scenefmt.validation import load

    print(f"{'triangles':>10} {'load s':>7} {'flatten+tree s':>15} {'to 1st sample s':>16} {'bytes/tri':>10} "
          f"{'ms/spp':>8} {'ms/spp / log2 N':>16}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "scene.yaml").write_text(MESH_SCENE)
        warm = True
        rows = []
        for splits in (3, 7, 22, 71, 224, 388, 708):
            n = 20 * splits * splits
            if n > max_triangles:
                break
            meshgen.write_ply(folder / "mesh.ply", *meshgen.icosphere(splits))
            if warm:  # compile the kernels once, outside the timings
                render(load(folder / "scene.yaml").graph, samples=1)
                warm = False
            t0 = time.perf_counter()
            graph = load(folder / "scene.yaml").graph
            t1 = time.perf_counter()
            flat = compile_scene(graph)
            t2 = time.perf_counter()
            first = render(graph, samples=1, flat=flat)
            t3 = time.perf_counter()
            result = render(graph, samples=spp, flat=flat)
            per_spp = 1000 * result.stats.seconds / spp
            nbytes = sum(a.nbytes for a in flat)
            print(f"{n:>10} {t1 - t0:>7.2f} {t2 - t1:>15.2f} {t2 - t0 + first.stats.first_pass_seconds:>16.2f} "
                  f"{nbytes / n:>10.0f} {per_spp:>8.2f} {per_spp / math.log2(n):>16.3f}", flush=True)
            rows.append((n, per_spp))
            del graph, flat, first, result
    if plot_to is not None:
        plot(rows, plot_to)


def write_sphere_file(path: Path, n: int, seed: int = 1) -> None:
    """n spheres in the compact form a generator writes, one line each (JSON, or YAML flow maps)."""
    rng = np.random.default_rng(seed)
    centers = np.round(rng.uniform(-10, 10, (n, 3)), 4).tolist()
    radius = round(2.0 * (100.0 / n) ** (1 / 3), 5)
    if path.suffix == ".json":
        head = ('{"camera": {"look_from": [0, 0, 30], "look_at": [0, 0, 0], "vfov": 45},\n'
                '"image": {"width": 96, "aspect_ratio": 1, "samples_per_pixel": 1, "max_depth": 4},\n'
                '"materials": {"white": {"type": "lambertian", "albedo": [0.7, 0.7, 0.7]}},\n"shapes": [\n')
        rows = ",\n".join(f'{{"type": "sphere", "center": [{x}, {y}, {z}], "radius": {radius}, "material": "white"}}'
                          for x, y, z in centers)
        path.write_text(head + rows + "\n]}\n")
    else:
        head = ("camera: {look_from: [0, 0, 30], look_at: [0, 0, 0], vfov: 45}\n"
                "image: {width: 96, aspect_ratio: 1, samples_per_pixel: 1, max_depth: 4}\n"
                "materials: {white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}}\nshapes:\n")
        path.write_text(head + "".join(f"  - {{type: sphere, center: [{x}, {y}, {z}], radius: {radius}, material: white}}\n"
                                       for x, y, z in centers))


def sphere_file(n: int, syntax: str) -> None:
    """File to first sample for n spheres, stage by stage, as `rt render` runs them."""
    import tempfile

    from renderer.compile import compile_scene
    from renderer.render import render
    from renderer.variants import features_of
    from scenefmt.bounds import check_memory
    from scenefmt.validation import load

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"spheres.{syntax}"
        write_sphere_file(path, n)
        small = Path(tmp) / f"small.{syntax}"
        write_sphere_file(small, 100)
        graph = load(small).graph  # compile the kernels once, outside the timings
        render(graph, samples=1, flat=compile_scene(graph), features=features_of(graph))
        clock = time.perf_counter
        t0 = clock()
        loaded = load(path)
        t1 = clock()
        check_memory(loaded.graph, loaded.document)
        flat = compile_scene(loaded.graph)
        features = features_of(loaded.graph)
        t2 = clock()
        first = render(loaded.graph, samples=1, flat=flat, features=features)
        t3 = clock()
        print(f"{n:,} spheres, {path.stat().st_size / 1e6:.0f} MB of {syntax.upper()}: read and check {t1 - t0:.2f} s, "
              f"flatten and tree {t2 - t1:.2f} s, first sample {t3 - t2:.2f} s ({first.stats.first_pass_seconds:.2f} s "
              f"rendering); file to first sample {t3 - t0:.2f} s")


def main() -> int:
    sys.path.insert(0, str(ROOT))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-exponent", type=int, default=6)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--meshes", action="store_true", help="icosphere meshes from PLY files instead of spheres")
    parser.add_argument("--max-triangles", type=int, default=3_000_000)
    parser.add_argument("--plot", type=Path, help="with --meshes: also plot ms per sample against N (needs matplotlib)")
    parser.add_argument("--sphere-file", type=int, metavar="N", help="time a scene file of N spheres from file to first sample")
    parser.add_argument("--syntax", choices=("json", "yaml"), default="json", help="the syntax of --sphere-file's scene")
    args = parser.parse_args()
    if args.sphere_file:
        sphere_file(args.sphere_file, args.syntax)
        return 0
    if args.meshes:
        meshes(args.max_triangles, args.spp, args.plot)
        return 0
    from renderer.compile import compile_scene
    from renderer.render import render

    print(f"{'N':>9} {'build s':>8} {'ms/spp':>8} {'Mrays/s':>8} {'bytes/prim':>11} {'ms/spp / log2 N':>16}")
    for exponent in range(2, args.max_exponent + 1):
        n = 10**exponent
        t0 = time.perf_counter()
        graph = build(n)
        flat = compile_scene(graph)
        build_s = time.perf_counter() - t0
        render(graph, samples=1, flat=flat)  # warm up
        result = render(graph, samples=args.spp, flat=flat)
        per_spp = 1000 * result.stats.seconds / args.spp
        nbytes = sum(a.nbytes for a in flat)
        print(
            f"{n:>9} {build_s:>8.2f} {per_spp:>8.2f} {result.stats.rays_per_second / 1e6:>8.2f} "
            f"{nbytes / n:>11.0f} {per_spp / math.log2(n):>16.3f}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
