"""Our BVH against Embree: the same incoherent rays against the same 10^6-triangle mesh, closest
hits per second on the same cores.

    pip install -e '.[bench]'        # embreex: Embree 4 (and its TBB) in a wheel
    python benchmarks/embree.py [--segments 4096] [--sides 128] [--rays 2097152] [--threads 2] [--reps 3]

The mesh is a (2, 3) torus knot from `scenefmt.meshgen` (2 segments sides triangles: 1,048,576
by default), closed and folded over itself, so some rays leaving its surface meet it again. Two sets
of rays, half each:

- bounce: the second bounce of a diffuse scene. Primary rays from a camera hit the knot; from a
  random choice of the hit points (kept in pixel order, as a render meets them), a
  cosine-distributed direction about the surface normal, the origin moved 1e-5 off the surface.
- random: origins uniform in the knot's bounding box (some inside the tube), directions uniform
  over the sphere: no coherence at all.

Ours: `renderer.kernels.probe.closest_hits` (distance, primitive and instance per ray; numba
prange over chunks of rays, float64, our four-wide tree), through the general kernel a render
starts with. Embree: `embreex`, whose `EmbreeScene.run` loops over rays calling rtcIntersect1
with the GIL released, so `--threads` Python threads each run it on chunks of rays (float32, as
Embree takes them). Embree is timed with its robust flag (embreex's default; like our
watertight test, it gives up the faster, less exact triangle test) and without it. Each figure is
the best of --reps runs after one warm-up. The answers are compared: ours against the serial
`probe_rays` on a subset (the same to the bit), and ours against Embree (misses, distances
within 1e-4 relative, and the triangle hit).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CAMERA = (0.0, 0.6, 3.4)  # looking at the origin; the knot spans about [-1, 1]^2 x [-0.6, 0.6]
EPSILON = 1e-5  # bounce origins off the surface (triangles are about 1e-3 across)
EMBREE_CHUNK = 16384  # rays per call of EmbreeScene.run


def knot(segments: int, sides: int):
    from scenefmt import meshgen

    return meshgen.torus_knot(2, 3, segments, sides, 1.0, 0.25)


def build_ours(vertices, faces):
    from renderer.compile import compile_scene
    from scenefmt import models as m
    from scenefmt.graph import build_graph

    t0 = time.perf_counter()
    scene = m.Scene(camera=m.Camera(look_from=CAMERA, look_at=(0, 0, 0)),
                    shapes=[m.Mesh(vertices=vertices, faces=faces, material=m.Lambertian(albedo=(0.7, 0.7, 0.7)))])
    flat = compile_scene(build_graph(scene))
    return flat, time.perf_counter() - t0


def build_embree(vertices, faces, robust: bool):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    t0 = time.perf_counter()
    scene = rtcore_scene.EmbreeScene(robust=robust)
    TriangleMesh(scene, vertices.astype(np.float32), faces.astype(np.int32))
    one = np.zeros((1, 3), np.float32)
    scene.run(one, one + 1, output=1)  # the first run commits the scene: builds its tree
    return scene, time.perf_counter() - t0


def cosine_directions(normals, rng):
    """Directions about each unit normal with density cos(theta) / pi."""
    u1, u2 = rng.random(len(normals)), rng.random(len(normals))
    r, phi = np.sqrt(u1), 2 * math.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - u1))], 1)
    # An orthonormal basis about each normal (Duff et al. 2017).
    n = normals
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    s = np.stack([1 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], 1)
    t = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], 1)
    return local[:, :1] * s + local[:, 1:2] * t + local[:, 2:] * n


def bounce_rays(flat, count: int, rng):
    """Second-bounce rays: camera rays that hit the knot, then a diffuse bounce off each hit."""
    from renderer.kernels.probe import closest_hits, probe_rays

    side = int(math.ceil(math.sqrt(count * 5)))  # the knot covers about a third of the picture
    half = math.tan(math.radians(20.0))  # 40 degrees vertical field
    eye = np.array(CAMERA)
    w = eye / np.linalg.norm(eye)
    u = np.cross((0.0, 1.0, 0.0), w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    j, i = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    x = ((i.ravel() + rng.random(side * side)) / side * 2 - 1) * half
    y = (1 - (j.ravel() + rng.random(side * side)) / side * 2) * half
    dirs = x[:, None] * u + y[:, None] * v - w
    origins = np.broadcast_to(eye, dirs.shape).copy()
    t, prim, _ = closest_hits(flat, origins, dirs, 0.0, 0.0)
    hit = np.flatnonzero(prim >= 0)
    if len(hit) < count:
        raise SystemExit(f"only {len(hit)} camera rays hit the knot, {count} wanted")
    chosen = np.sort(rng.choice(hit, count, replace=False))
    _, _, _, p, n, _ = probe_rays(flat, origins[chosen], dirs[chosen], 0.0, 0.0, False)
    # The side the camera sees (the knot winds outward; this also holds for rays from inside).
    n *= -np.sign((n * dirs[chosen]).sum(1))[:, None]
    return p + EPSILON * n, cosine_directions(n, rng)


def random_rays(vertices, count: int, rng):
    lo, hi = vertices.min(0), vertices.max(0)
    pad = 0.05 * (hi - lo)
    origins = rng.uniform(lo - pad, hi + pad, (count, 3))
    d = rng.normal(size=(count, 3))
    return origins, d / np.linalg.norm(d, axis=1, keepdims=True)


def run_ours(flat, origins, dirs):
    from renderer.kernels.probe import closest_hits

    t, prim, _ = closest_hits(flat, origins, dirs, 0.0, 0.0)
    return t, prim


def run_embree(scene, origins32, dirs32, pool):
    starts = range(0, len(origins32), EMBREE_CHUNK)
    parts = list(pool.map(lambda s: scene.run(origins32[s:s + EMBREE_CHUNK], dirs32[s:s + EMBREE_CHUNK], output=1), starts))
    t = np.concatenate([q["tfar"] for q in parts])
    prim = np.concatenate([q["primID"] for q in parts])
    return t, prim


def best_of(fn, reps: int):
    fn()  # warm-up
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), times


def our_triangles(flat, prim):
    """Each hit's triangle as its sorted vertex indices in the input mesh (rows of -1 on a miss)."""
    from renderer.shapes.meshes import MESH_FIRST_VERTEX, TRI_MESH, TRI_VERTEX

    out = np.full((len(prim), 3), -1, np.int64)
    hit = prim >= 0
    rows = prim[hit] - len(flat.prims_f)
    first = flat.mesh_i[flat.tri_i[rows, TRI_MESH], MESH_FIRST_VERTEX]
    out[hit] = np.sort(flat.tri_i[rows, TRI_VERTEX:TRI_VERTEX + 3] - first[:, None], axis=1)
    return out


def compare(flat, faces, ours, embree):
    """Rays one hits and the other misses; hits whose distances differ by more than 1e-4
    relative (how many, the largest such distance, the largest gap); hits on another triangle
    (how many, the largest gap in distance); hits by both."""
    t1, p1 = ours
    t2, p2 = embree
    miss1, miss2 = p1 < 0, p2 < 0
    both = ~miss1 & ~miss2
    gap = np.where(both, np.abs(t1 - t2), 0.0)
    far = both & (gap > 1e-4 * t1)
    tri1 = our_triangles(flat, p1)
    tri2 = np.full_like(tri1, -1)
    tri2[~miss2] = np.sort(faces[p2[~miss2]], axis=1)
    other = both & (tri1 != tri2).any(1)
    return (int((miss1 != miss2).sum()), int(far.sum()), float(t1[far].max(initial=0.0)), float(gap[far].max(initial=0.0)),
            int(other.sum()), float(gap[other].max(initial=0.0)), int(both.sum()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--segments", type=int, default=4096)
    ap.add_argument("--sides", type=int, default=128)
    ap.add_argument("--rays", type=int, default=1 << 21, help="rays in all, half in each set")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--check", type=int, default=1 << 16, help="rays of each set checked against probe_rays")
    args = ap.parse_args()

    import numba

    try:
        from embreex import rtcore
    except ImportError:
        raise SystemExit("embreex is not installed: pip install -e '.[bench]'")
    from renderer.kernels.probe import probe_rays

    numba.set_num_threads(args.threads)
    rng = np.random.default_rng(20)
    vertices, faces = knot(args.segments, args.sides)
    flat, our_build = build_ours(vertices, faces)
    embree_robust, robust_build = build_embree(vertices, faces, robust=True)
    embree_fast, fast_build = build_embree(vertices, faces, robust=False)

    half = args.rays // 2
    t0 = time.perf_counter()
    sets = {"bounce": bounce_rays(flat, half, rng), "random": random_rays(vertices, half, rng)}
    ray_seconds = time.perf_counter() - t0
    pool = ThreadPoolExecutor(args.threads)

    print(f"Mesh: torus knot, {len(faces):,} triangles, {len(vertices):,} vertices. Machine: {os.cpu_count()} cores, "
          f"{args.threads} threads (numba layer {numba.threading_layer()}), load average {os.getloadavg()[0]:.2f} at start; "
          f"{rtcore.EmbreeDevice()!r}.")
    print(f"Build: ours {our_build:.2f} s (scene, graph, flat tables and tree), Embree {robust_build:.2f} s robust, "
          f"{fast_build:.2f} s not (scene and tree, TBB threads); rays made in {ray_seconds:.1f} s.")
    print()
    print("| rays | count | hit | ours Mrays/s | Embree robust Mrays/s | ratio | Embree fast Mrays/s | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    totals = {"ours": 0.0, "robust": 0.0, "fast": 0.0}
    checks = []
    for name, (origins, dirs) in sets.items():
        origins, dirs = np.ascontiguousarray(origins), np.ascontiguousarray(dirs)
        o32, d32 = origins.astype(np.float32), dirs.astype(np.float32)
        ours = run_ours(flat, origins, dirs)
        # The parallel query against the serial probe on a subset: the same search, the same bits.
        k = min(args.check, len(origins))
        t_ref, p_ref, *_ = probe_rays(flat, origins[:k], dirs[:k], 0.0, 0.0, False)
        assert np.array_equal(p_ref, ours[1][:k]) and np.array_equal(t_ref, ours[0][:k]), "closest_hits != probe_rays"
        checks.append((name, compare(flat, faces, ours, run_embree(embree_robust, o32, d32, pool)),
                       compare(flat, faces, ours, run_embree(embree_fast, o32, d32, pool))))
        s_ours, _ = best_of(lambda: run_ours(flat, origins, dirs), args.reps)
        s_robust, _ = best_of(lambda: run_embree(embree_robust, o32, d32, pool), args.reps)
        s_fast, _ = best_of(lambda: run_embree(embree_fast, o32, d32, pool), args.reps)
        n = len(origins)
        totals["ours"] += s_ours
        totals["robust"] += s_robust
        totals["fast"] += s_fast
        hit = (ours[1] >= 0).mean()
        print(f"| {name} | {n:,} | {hit:.0%} | {n / s_ours / 1e6:.2f} | {n / s_robust / 1e6:.2f} | {s_robust / s_ours:.2f} "
              f"| {n / s_fast / 1e6:.2f} | {s_fast / s_ours:.2f} |")
    n = sum(len(o) for o, _ in sets.values())
    print(f"| both | {n:,} | | {n / totals['ours'] / 1e6:.2f} | {n / totals['robust'] / 1e6:.2f} | "
          f"{totals['robust'] / totals['ours']:.2f} | {n / totals['fast'] / 1e6:.2f} | {totals['fast'] / totals['ours']:.2f} |")
    print()
    print(f"Load average at the end: {os.getloadavg()[0]:.2f}. Ratio: ours / Embree's rate (the issue asks for at least 0.33).")
    print(f"closest_hits = probe_rays, to the bit, on the first {args.check:,} rays of each set. Ours against Embree:")
    for name, robust, fast in checks:
        for label, (miss, far, far_t, far_gap, other, other_gap, both) in (("robust", robust), ("fast", fast)):
            print(f"- {name}, Embree {label}: {miss} rays hit by one only; of {both:,} hit by both, {far} with distances "
                  f"apart by more than 1e-4 relative (all at distances up to {far_t:.2g}, gaps up to {far_gap:.1e}), "
                  f"{other} on another triangle (gaps in distance up to {other_gap:.1e}).")
    pool.shutdown()


if __name__ == "__main__":
    main()
