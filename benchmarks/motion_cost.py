"""What motion costs: the moving-mesh scene (scenes/motion_knot.yaml) against the same scene with the
knot standing where it is when the shutter opens, same size, spp and seed, in one process.

    python benchmarks/motion_cost.py [--width 96] [--spp 16] [--runs 3] [--kernel general|specialised]

Each render is timed after a first untimed one (which compiles the kernel), the two scenes in turn,
`--runs` times; the medians are printed with the rays per second. With the general kernel both
scenes run the same compiled code, so the difference is what the motion itself costs: the
interpolated maps per visit of the moving instance, its box over the whole motion, and the blur
(rays that graze the knot at some times and miss it at others). With the specialised kernels the
still scene also leaves the motion and instance paths out.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from renderer.compile import compile_scene, with_width  # noqa: E402
from renderer.render import render  # noqa: E402
from scenefmt.validation import load, loads  # noqa: E402

SCENE = ROOT / "scenes" / "motion_knot.yaml"
MOTION = """    transform: [{rotate: {axis: x, degrees: -25}}, {scale: 130}]
    motion:
      - {time: 0, transform: [{translate: [200, 250, 300]}]}
      - {time: 1, transform: [{rotate: {axis: y, degrees: 90}}, {translate: [350, 250, 300]}]}
"""
STILL = """    transform: [{rotate: {axis: x, degrees: -25}}, {scale: 130}, {translate: [200, 250, 300]}]
"""


def graphs(width: int):
    """The scene as shipped; the knot standing still, baked into the room's tree; and the knot
    standing still but placed by an instance of a group (what a moving shape becomes, less its
    motion): the last isolates the cost of the motion from that of the second tree."""
    text = SCENE.read_text()
    assert MOTION in text, "scenes/motion_knot.yaml changed: update MOTION here"
    moving = with_width(load(SCENE).graph, width)
    still = loads(text.replace(MOTION, STILL), base_dir=SCENE.parent).graph
    start = text.index("  - type: mesh")
    mesh = text[start:].replace(MOTION, "    transform: [{rotate: {axis: x, degrees: -25}}, {scale: 130}]\n")
    group = "groups:\n  knot:\n    shapes:\n" + "\n".join("    " + line for line in mesh.splitlines()) + "\n"
    placed = text[:start].replace("shapes:\n", group + "shapes:\n", 1)
    placed += "  - {type: instance, group: knot, transform: [{translate: [200, 250, 300]}]}\n"
    instanced = loads(placed, base_dir=SCENE.parent).graph
    return {"moving": moving, "still": with_width(still, width), "instance": with_width(instanced, width)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=96)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--kernel", choices=("general", "specialised"), default="general")
    args = parser.parse_args(argv)
    scenes = graphs(args.width)
    flats = {name: compile_scene(graph) for name, graph in scenes.items()}
    times: dict[str, list[float]] = {name: [] for name in scenes}
    rays: dict[str, int] = {}
    for name, graph in scenes.items():  # compile (or load) the kernels first
        render(graph, flat=flats[name], samples=1, kernel=args.kernel)
    for _ in range(args.runs):
        for name, graph in scenes.items():
            start = time.perf_counter()
            result = render(graph, flat=flats[name], samples=args.spp, kernel=args.kernel)
            times[name].append(time.perf_counter() - start)
            rays[name] = result.stats.rays
    for name in scenes:
        median = statistics.median(times[name])
        print(f"{name:7s} {median:7.3f} s (runs {', '.join(f'{t:.3f}' for t in times[name])}), "
              f"{rays[name] / median / 1e6:.2f} Mrays/s")
    for base in ("still", "instance"):
        ratio = statistics.median(times["moving"]) / statistics.median(times[base])
        print(f"moving / {base}: {ratio:.3f} ({args.width} px wide, {args.spp} spp, kernel {args.kernel})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
