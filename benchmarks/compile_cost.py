"""What a newcomer waits for: compiling on a fresh install, scene by scene.

Renders each scene twice as a user would (`python -m rt render`, a tiny image), each time in a
new process: first with an empty kernel cache folder shared by the runs (so a scene pays only
for what the scenes before it left in the cache), then again with that cache warm. The
difference is the compiling a scene cost. Prints a row per scene and the total.

    python benchmarks/compile_cost.py [--checkout DIR] [--kernel general|specialised] [--each-cold] [SCENE ...]

`--checkout` times another checkout of the project (for before-and-after figures) with this
interpreter. `--kernel` makes every render use that kernel (the default lets `rt` choose);
`--each-cold` gives each scene an empty cache of its own, so each pays all of its compiling (what
a scene with or without some effect costs on a fresh install). The default scenes are the first
five book scenes in name order.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SCENES = ["bouncing_spheres", "checkered_spheres", "cornell_box", "cornell_smoke", "earth"]


def run(checkout: Path, scene: str, cache: str, out: Path, kernel: str | None = None) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(checkout))
    command = [sys.executable, "-m", "rt", "render", str(checkout / "scenes" / f"{scene}.yaml"),
               "-o", str(out / f"{scene}.png"), "--width", "16", "--spp", "1"] + (["--kernel", kernel] if kernel else [])
    start = time.perf_counter()
    subprocess.run(command, cwd=checkout, env=env, check=True, capture_output=True)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=DEFAULT_SCENES)
    parser.add_argument("--checkout", type=Path, default=ROOT)
    parser.add_argument("--kernel", choices=["general", "specialised"], default=None)
    parser.add_argument("--each-cold", action="store_true", help="an empty cache for each scene")
    args = parser.parse_args(argv)
    checkout = args.checkout.resolve()
    cold, warm = [], []
    with tempfile.TemporaryDirectory() as shared, tempfile.TemporaryDirectory() as out:
        for scene in args.scenes:
            with tempfile.TemporaryDirectory() as own:
                cache = own if args.each_cold else shared
                cold.append(run(checkout, scene, cache, Path(out), args.kernel))
                if args.each_cold:
                    warm.append(run(checkout, scene, cache, Path(out), args.kernel))
        if not args.each_cold:
            warm = [run(checkout, scene, shared, Path(out), args.kernel) for scene in args.scenes]
    print(f"checkout: {checkout}  ({os.cpu_count()} cores)  kernel: {args.kernel or 'chosen by rt'}"
          f"{'  each scene from an empty cache' if args.each_cold else ''}")
    print(f"{'scene':<20} {'empty cache':>12} {'warm':>8} {'compiling':>10}")
    for scene, c, w in zip(args.scenes, cold, warm):
        print(f"{scene:<20} {c:>11.1f}s {w:>7.2f}s {c - w:>9.1f}s")
    print(f"{'total':<20} {sum(cold):>11.1f}s {sum(warm):>7.2f}s {sum(cold) - sum(warm):>9.1f}s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
