"""The figures of docs/cluster.md: a render on two single-thread Dask workers against one process
with two threads, on this machine, and the cost of one chunk to the scheduler.

    python benchmarks/cluster.py [--width 160] [--spp 64]

Prints: the local render's seconds (2 Numba threads), the cluster render's seconds (a LocalCluster
of 2 worker processes, 1 thread each, kernels warm), the efficiency (local / cluster), whether the
images are equal bit for bit, and the seconds per empty chunk (a 1x1 tile, 0 samples) round trip.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "cornell_box.yaml"))
    parser.add_argument("--width", type=int, default=160)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--chunks", type=int, default=400)
    args = parser.parse_args()

    import numba
    from distributed import Client, LocalCluster

    import rt
    from rt import chunks
    from rt.cluster import package_scene, render_on_cluster
    from renderer.session import flatten_loaded as flatten
    from renderer.flat import Frame
    from renderer.variants import GENERAL
    from scenefmt.files import recording_reads

    numba.set_num_threads(2)
    rt.render(args.scene, spp=1, width=8, kernel="general")  # load the kernels
    t0 = time.perf_counter()
    reference = rt.render(args.scene, spp=args.spp, width=args.width, kernel="general")
    local_seconds = time.perf_counter() - t0

    with recording_reads() as reads:
        loaded = rt.load(args.scene)
        graph, flat = flatten(loaded, args.width)
    package = package_scene(args.scene, reads, loaded, flat, width=args.width)
    frame = Frame.of(graph)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, Client(cluster) as client:
        render_on_cluster(client, package, flat, frame, features=GENERAL, samples=1)  # workers build the scene, load kernels
        t0 = time.perf_counter()
        result = render_on_cluster(client, package, flat, frame, features=GENERAL, samples=args.spp)
        cluster_seconds = time.perf_counter() - t0
        equal = np.array_equal(result.film.total, reference.film.total) and np.array_equal(result.film.total_sq, reference.film.total_sq)

        # The overhead of a chunk: submit, run nothing, return a 1x1 tile's sums.
        scene = client.submit(chunks.package_value, package, pure=False)
        chunk = chunks.Chunk(chunks.Tile(0, 0, 1, 1), 0, 0, frame.width, frame.seed, frame.max_depth, 1)
        zero = np.zeros((1, 1, 3))
        client.gather([client.submit(chunks.render_chunk, scene, GENERAL, chunk, zero, zero, pure=False) for _ in range(10)])
        t0 = time.perf_counter()
        futures = [client.submit(chunks.render_chunk, scene, GENERAL, chunk, zero, zero, pure=False) for _ in range(args.chunks)]
        client.gather(futures)
        per_chunk = (time.perf_counter() - t0) / args.chunks
    rounds = result.stats
    print(f"scene {Path(args.scene).name} {args.width}x{frame.height}, {args.spp} spp")
    print(f"local, 1 process x 2 threads: {local_seconds:.2f} s")
    print(f"cluster, 2 workers x 1 thread: {cluster_seconds:.2f} s (render {rounds.seconds:.2f} s)")
    print(f"efficiency: {local_seconds / cluster_seconds:.3f}")
    print(f"images equal bit for bit: {equal}")
    print(f"empty chunk, {args.chunks} submitted at once: {1000 * per_chunk:.2f} ms each")


if __name__ == "__main__":
    main()
