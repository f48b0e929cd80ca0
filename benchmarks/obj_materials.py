"""What an OBJ's `usemtl` costs: the reader with and without it, and the cut into one mesh per material.

    python benchmarks/obj_materials.py                 # 10^6 triangles, 5 rounds
    python benchmarks/obj_materials.py --root DIR      # also another checkout's reader (git archive main | tar -x -C DIR)

Writes a 1,003,520-triangle icosphere OBJ (`meshgen.icosphere(224)`) to a temporary folder, once
as it is and once with 4 `usemtl` lines (a quarter of the faces each), and times
`meshfile.read_obj` on each (best and median of the rounds, alternated), then
`meshfile.split_by_material` on the second. With `--root`, the reader of the checkout in DIR
(its `scenefmt` loaded under another name) is timed in the same rounds: before against after.
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scenefmt import meshfile, meshgen  # noqa: E402


def other_reader(root: Path):
    """The meshfile module of the checkout in `root`, as package `scenefmt_other`."""
    spec = importlib.util.spec_from_file_location("scenefmt_other", root / "scenefmt" / "__init__.py",
                                                  submodule_search_locations=[str(root / "scenefmt")])
    package = importlib.util.module_from_spec(spec)
    sys.modules["scenefmt_other"] = package
    spec.loader.exec_module(package)
    return importlib.import_module("scenefmt_other.meshfile")


def timed(fn, data: bytes) -> float:
    gc.collect()
    start = time.perf_counter()
    fn(data)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--splits", type=int, default=224, help="icosphere subdivisions (224: 1,003,520 triangles)")
    parser.add_argument("--root", type=Path, help="another checkout whose reader is timed beside this one")
    args = parser.parse_args()
    readers = {"this": meshfile}
    if args.root:
        readers["other"] = other_reader(args.root)
    folder = Path(tempfile.mkdtemp(prefix="obj_materials_"))
    try:
        vertices, faces = meshgen.icosphere(args.splits)
        plain = meshgen.write_obj(folder / "plain.obj", vertices, faces).read_bytes()
        lines = plain.split(b"\n")
        face_lines = [i for i, line in enumerate(lines) if line.startswith(b"f ")]
        quarter = len(face_lines) // 4
        for k in reversed(range(4)):
            lines.insert(face_lines[k * quarter], b"usemtl m%d" % k)
        four = b"mtllib m.mtl\n" + b"\n".join(lines)
        print(f"{len(faces):,} triangles, {len(plain):,} bytes; {args.rounds} rounds")
        for label, data in (("no usemtl", plain), ("4 usemtl", four)):
            times = {name: [] for name in readers}
            for _ in range(args.rounds):
                for name, module in readers.items():
                    times[name].append(timed(module.read_obj, data))
            for name, got in times.items():
                print(f"  read_obj, {label}, {name}: best {min(got):.2f} s, median {float(np.median(got)):.2f} s")
        mesh = meshfile.read_obj(four)
        got = []
        for _ in range(args.rounds):
            gc.collect()
            start = time.perf_counter()
            parts = meshfile.split_by_material(mesh)
            got.append(time.perf_counter() - start)
        print(f"  split_by_material into {len(parts)} parts: best {min(got):.3f} s, median {float(np.median(got)):.3f} s")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
