"""How long `rt import` takes for a model of about a million triangles (docs/import.md).

Builds a .glb of a wavy grid (positions, normals, texture coordinates, 32-bit indices) with
pygltflib and numpy, then times, best of `--repeat` runs each: reading the file (`gltf_read.load`),
making the scene (`gltf_scene.plan_import`: accessors read, triangles and transforms), the whole
import with its files written (`rt.importing.import_gltf`), and `rt validate`'s load of the
written scene (which reads the PLY back).

    python benchmarks/gltf_import.py [--side 708] [--repeat 3]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def grid_model(path: Path, side: int) -> int:
    """A .glb of a side x side grid of vertices (2 (side - 1)^2 triangles); returns the triangle count."""
    sys.path.insert(0, str(ROOT / "tests"))
    from gltf_models import Builder

    u, v = np.meshgrid(np.linspace(0, 1, side), np.linspace(0, 1, side))
    height = 0.05 * np.sin(12 * u) * np.cos(9 * v)
    positions = np.stack([u - 0.5, height, v - 0.5], -1).reshape(-1, 3)
    normals = np.tile([0.0, 1.0, 0.0], (side * side, 1))
    uvs = np.stack([u, v], -1).reshape(-1, 2)
    k = np.arange(side * side).reshape(side, side)[:-1, :-1].reshape(-1)
    faces = np.concatenate([np.stack([k, k + side, k + 1], 1), np.stack([k + 1, k + side, k + side + 1], 1)])
    b = Builder()
    b.node(mesh=b.mesh(positions, faces, normals=normals, uvs=uvs, name="grid"))
    b.save_glb(path)
    return len(faces)


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=int, default=708, help="vertices along each side of the grid (708: 999,698 triangles)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    from rt.importing import import_gltf
    from scenefmt.gltf_read import load
    from scenefmt.gltf_scene import ImportOptions, plan_import
    from scenefmt.validation import load_source

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        model = tmp / "grid.glb"
        t = time.perf_counter()
        triangles = grid_model(model, args.side)
        built = time.perf_counter() - t
        size = model.stat().st_size
        print(f"model: {triangles:,} triangles, {args.side**2:,} vertices, {size / 2**20:.1f} MiB .glb (built in {built:.1f} s)")
        read = best(lambda: load(model), args.repeat)
        doc = load(model)
        planned = best(lambda: plan_import(doc, ImportOptions(assets="s_assets")), args.repeat)
        whole = best(lambda: import_gltf(model, tmp / "s.yaml", force=True), args.repeat)
        validate = best(lambda: load_source(tmp / "s.yaml", [], None, []), args.repeat)
        ply = (tmp / "s_assets" / "grid.ply").stat().st_size
        print(f"read the .glb (gltf_read.load):             {read:6.2f} s")
        print(f"make the scene (plan_import):               {planned:6.2f} s")
        print(f"rt import, files written:                   {whole:6.2f} s   (PLY {ply / 2**20:.1f} MiB)")
        print(f"rt validate of the imported scene (load):   {validate:6.2f} s")
        print(f"best of {args.repeat} runs each")


if __name__ == "__main__":
    main()
