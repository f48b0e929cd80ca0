"""Whole-process render times of the speed targets, as a user runs them (`rt render`, warm cache).

    python benchmarks/speed.py [--runs 3] [--threads N]

Prints, per scene: the median and the best wall time of the whole `rt render` process, the rays
per second it reports, the peak resident memory, and the target and reference times. The first
run of a scene may compile the kernels; it is done once beforehand and not counted.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# A user's second run finds Python's bytecode cache warm, as well as Numba's. Some environments
# (CI images among them) set PYTHONDONTWRITEBYTECODE, and every run would then compile the
# project's sources again (a few hundredths of a second); the runs here may write the cache, as a
# user's would.
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}

# (scene, width, spp, max depth, target seconds, the books' C++ reference seconds on one core)
TARGETS = [
    ("final_scene", 400, 64, 40, 6.5, 31.5),
    ("cornell_box", 600, 64, 50, 9.5, 47.0),
    ("bouncing_spheres", 400, 50, 50, 1.5, 4.6),
]


def run_once(scene: str, width: int, spp: int, depth: int, threads: int | None, out_dir: Path) -> tuple[float, float, int]:
    """(wall seconds, Mrays/s, peak RSS in KiB) of one `rt render` process."""
    cmd = [sys.executable, "-m", "rt", "render", str(ROOT / "scenes" / f"{scene}.yaml"), "-o", str(out_dir / f"{scene}.png"),
           "--width", str(width), "--spp", str(spp), "--max-depth", str(depth)]
    if threads:
        cmd += ["--threads", str(threads)]
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=CHILD_ENV)
    stdout = proc.stdout.read()
    # wait4 gives this child's own resource usage (its peak resident memory).
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed with exit code {proc.returncode}")
    rate = float(re.search(r"([\d.]+) Mrays/s", stdout).group(1))
    return wall, rate, usage.ru_maxrss


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--threads", type=int, default=None)
    args = parser.parse_args()
    print(f"machine: {os.cpu_count()} cores; median and best of {args.runs} runs (a shared machine disturbs the best least); "
          "warm kernel cache")
    print(f"{'scene':<18} {'settings':<22} {'time':>7} {'best':>7} {'target':>7} {'C++ ref':>8} {'Mrays/s':>8} {'peak MiB':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = Path(tmp)
        for scene, width, spp, depth, target, reference in TARGETS:
            run_once(scene, 16, 1, 2, args.threads, out_dir)  # warm the kernel and bytecode caches
            runs = [run_once(scene, width, spp, depth, args.threads, out_dir) for _ in range(args.runs)]
            wall = statistics.median(r[0] for r in runs)
            best = min(r[0] for r in runs)
            rate = statistics.median(r[1] for r in runs)
            peak = max(r[2] for r in runs) / 1024
            settings = f"{width}px {spp}spp d{depth}"
            print(f"{scene:<18} {settings:<22} {wall:>6.2f}s {best:>6.2f}s {target:>6.1f}s {reference:>7.1f}s {rate:>8.2f} {peak:>9.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
