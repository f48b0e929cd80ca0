"""How render time and memory grow with the number of primitives (10^2 .. 10^6 spheres).

    python benchmarks/scaling.py [--max-exponent 6] [--spp 4]

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


def main() -> int:
    sys.path.insert(0, str(ROOT))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-exponent", type=int, default=6)
    parser.add_argument("--spp", type=int, default=4)
    args = parser.parse_args()
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
