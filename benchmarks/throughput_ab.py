"""Render throughput of two checkouts of rt, interleaved: did a change slow the kernels?

    python benchmarks/throughput_ab.py --before /path/to/old/checkout [--rounds 5]

Each checkout renders with its own virtual environment (`<checkout>/.venv`) and its own warm
Numba cache. Per scene, the two `rt render` processes run in turn, A B A B ..., so a drift in the
machine's speed falls on both; each prints the Mrays/s of its rendering alone (compile and load
times are never counted in it). The figure to quote is the median ratio new / old of those rates,
pair by pair, with its range: above 1 the new code is faster. Both sides use the same kernel
(`--kernel general`, then `--kernel specialised`) so a change in the auto planner cannot pass for
a change of speed. CPU time beside wall time: the user+system seconds of each process.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
# (scene, width, samples per pixel, max depth): the two scenes the issue names, at sizes whose
# rendering takes 3 to 5 seconds on two cores (shorter ones varied by 10% from run to run).
SCENES = [("cornell_box", 300, 256, 50), ("final_scene", 300, 128, 40)]


def run(checkout: Path, scene: str, width: int, spp: int, depth: int, kernel: str, out: Path) -> tuple[float, float]:
    """(Mrays/s, CPU seconds) of one render by `checkout`'s own rt."""
    cmd = [str(checkout / ".venv" / "bin" / "python"), "-m", "rt", "render", str(checkout / "scenes" / f"{scene}.yaml"),
           "-o", str(out), "--width", str(width), "--spp", str(spp), "--max-depth", str(depth), "--kernel", kernel]
    proc = subprocess.Popen(cmd, cwd=checkout, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=CHILD_ENV)
    stdout = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(cmd)} failed")
    return float(re.search(r"([\d.]+) Mrays/s", stdout).group(1)), usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True, help="the old checkout (with its own .venv)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--scene", action="append", help="only these scenes (cornell_box, final_scene)")
    parser.add_argument("--kernel", action="append", choices=("general", "specialised"), help="only these kernels")
    args = parser.parse_args()
    sides = {"old": args.before.resolve(), "new": ROOT}
    with tempfile.TemporaryDirectory() as tmp:
        for scene, width, spp, depth in SCENES:
            if args.scene and scene not in args.scene:
                continue
            for kernel in args.kernel or ("general", "specialised"):
                for side in sides.values():  # warm-up: compile or load each side's kernel once
                    run(side, scene, width, 8, depth, kernel, Path(tmp) / "warm.png")
                rates = {"old": [], "new": []}
                cpu = {"old": [], "new": []}
                for _ in range(args.rounds):
                    for name, side in sides.items():
                        rate, seconds = run(side, scene, width, spp, depth, kernel, Path(tmp) / f"{name}.png")
                        rates[name].append(rate)
                        cpu[name].append(seconds)
                ratios = sorted(n / o for n, o in zip(rates["new"], rates["old"]))
                print(f"{scene} {width}px {spp}spp, {kernel} kernel: old {statistics.median(rates['old']):.2f} Mrays/s "
                      f"({statistics.median(cpu['old']):.1f} s CPU), new {statistics.median(rates['new']):.2f} Mrays/s "
                      f"({statistics.median(cpu['new']):.1f} s CPU); new/old median {statistics.median(ratios):.3f} "
                      f"(range {ratios[0]:.3f} to {ratios[-1]:.3f}, {args.rounds} pairs)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
