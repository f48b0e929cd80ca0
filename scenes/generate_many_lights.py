"""Write the many-lights scene: a night market of 1,000 stalls lit by 12,000 bulbs, seen from above.

    python scenes/generate_many_lights.py           # rewrite scenes/many_lights.yaml
    python scenes/generate_many_lights.py --check   # exit 1 if the committed file differs from what would be written
    python scenes/generate_many_lights.py --open    # write benchmarks/light_tree_scenes/many_lights_open.yaml instead

The open variant (a benchmark scene, not shipped): the same market, stalls and camera, but the
bulbs hang on strings above the aisles instead of under the awnings: each cell of the grid holds
a string of twelve lamps, small squares shining down only (`sides: front`: a shade above them),
across the aisle at its edge, 3 m up. Each lamp's square has the flux of a bulb of the market
(pi A L = 4 pi r^2 pi L: A = 4 pi r^2), and the same colours and strengths. Little stands between
a lamp and the aisle below it; the camera sees the lamps' dark backs.

Two groups each hold one market stall: a counter (a box), an awning (a thin box of dark canvas,
red or grey: a pale one would light the aisles as much as the bulbs do) and twelve small bulbs of varied colour and strength strung under the awning's edge. They
are placed over a square's grid of 3 m by 2.4 m cells, every one of them, turned half a turn at
random: 1,040 placements, 12,480 lights. The camera looks down from above, as a drone would, onto
the awnings and the lit aisles between them, steeply enough (30 degrees or more below the
horizon) that the awnings hide the bulbs from it: seen within a pixel, 12,000 bulbs would make an
image whose noise is theirs, whatever chooses the light of a shadow ray. The night sky is a dim
solid colour.

Each stall's bulbs light its counter and the aisles beside it; seen from a point of the market,
almost all of the others are far away or behind awnings and counters. Choosing a light by power
alone sends almost every shadow ray to one of those; the light tree (renderer/light_tree.py)
sends them to the bulbs near the shading point. The choice of each stall's turn comes from a
seeded `random.Random`: the file is the same on every machine.
"""

from __future__ import annotations

import argparse
import math
import random
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "many_lights.yaml"
# Not in benchmarks/scenes: every scene there must have a converged reference for the error
# coverage test (tests/renderer/converged.py), and this one is for benchmarks/light_tree.py only.
OPEN_OUT = HERE.parent / "benchmarks" / "light_tree_scenes" / "many_lights_open.yaml"
SEED = 33
CELL_X, CELL_Z = 3.0, 2.4  # a cell of the market's grid, in metres
CELLS_X, CELLS_Z = 40, 26  # the grid, centred on the origin
RADIUS = 0.035  # of a bulb
ROOF = 2.2  # height of an awning's underside
STRING_HEIGHT = 3.0  # of the open variant's strings of lamps, at their ends
LAMP_SIDE = math.sqrt(4.0 * math.pi) * RADIUS  # a one-sided square with a bulb's flux

HEADER = """\
# yaml-language-server: $schema=../schemas/scene.schema.json
# Written by scenes/generate_many_lights.py: edit that, not this file.
version: 1
description: >-
  Many lights: a night market of {placements:,} stalls seen from above, each a counter under an awning with
  12 small bulbs of varied colour and strength strung beneath it ({lights:,} lights: two groups, one
  stall each, placed over a grid). The awnings hide the bulbs from the camera; the aisles between
  the stalls are lit by the bulbs near them. A light tree chooses among the bulbs by what each may
  send to the shading point (docs/lights.md, "Many lights").
camera:
  look_from: [5, 26, 15]
  look_at: [0, 0, -1]
  up: [0, 1, 0]
  vfov: 50
image:
  width: 480
  height: 270
  samples_per_pixel: 64
  max_depth: 6
background: [0.004, 0.006, 0.016]
textures:
  cobbles: {{type: checker, scale: 0.3, even: [0.36, 0.34, 0.31], odd: [0.27, 0.26, 0.24]}}
materials:
  ground: {{type: lambertian, albedo: cobbles}}
  wood: {{type: lambertian, albedo: [0.45, 0.3, 0.18]}}
  red_canvas: {{type: lambertian, albedo: [0.3, 0.06, 0.05]}}
  white_canvas: {{type: lambertian, albedo: [0.22, 0.21, 0.19]}}
"""

OPEN_HEADER = HEADER.replace("../schemas/", "../../schemas/").replace(
    "Written by scenes/generate_many_lights.py:", "Written by scenes/generate_many_lights.py --open:").replace("""\
  Many lights: a night market of {placements:,} stalls seen from above, each a counter under an awning with
  12 small bulbs of varied colour and strength strung beneath it ({lights:,} lights: two groups, one
  stall each, placed over a grid). The awnings hide the bulbs from the camera; the aisles between
  the stalls are lit by the bulbs near them. A light tree chooses among the bulbs by what each may
  send to the shading point (docs/lights.md, "Many lights").""", """\
  Many lights, open variant (a benchmark scene): the night market of {placements:,} stalls seen from
  above, each a counter under an awning, lit by strings of 12 small lamps shining down over the
  aisles ({lights:,} one-sided lights: one string per cell of the grid, 3 m up) instead of bulbs
  under the awnings. Written for benchmarks/light_tree.py: the light tree against the power cdf
  where little stands between the lights and what they light.""")

# Bulb colours (emitted radiance); the bulbs are hidden from the camera, so they may be bright.
COLOURS = {"warm": [24, 16, 6.8], "amber": [26, 11, 2.4], "white": [18, 17.4, 15.6], "red": [28, 3, 1.8],
           "green": [3.6, 22, 4.2], "blue": [3, 6, 30], "pink": [22, 6, 16.8], "cyan": [3.6, 19.2, 21.6]}
# The colour of each bulb of a stall: mostly warm, a few coloured.
BULB_COLOURS = ["warm", "amber", "warm", "blue", "warm", "white", "amber", "warm", "pink", "warm", "green", "amber"]


def bulb_materials(rnd: random.Random, sides: str = "") -> list[str]:
    """A material per bulb of a stall: its colour times a strength from 0.5 to 1.5 (`sides`:
    front for the open variant's lamps, else the default, both)."""
    lines = []
    side = f", sides: {sides}" if sides else ""
    for k, colour in enumerate(BULB_COLOURS):
        strength = rnd.uniform(0.5, 1.5)
        e = [round(c * strength, 3) for c in COLOURS[colour]]
        lines.append(f"  {colour}_{k}: {{type: diffuse_light, emit: [{e[0]}, {e[1]}, {e[2]}]{side}}}")
    return lines


def bulb_places() -> list[tuple[float, float, float]]:
    """Twelve places under an awning 2.2 m by 1.6 m: four along the front and back, two at each
    end, 0.25 m in from its edge, hanging a little lower toward the middle of each run."""
    places = []
    for k in range(4):
        x = -0.75 + 0.5 * k
        sag = 0.06 if k in (1, 2) else 0.03
        places += [(x, ROOF - 0.06 - sag, 0.55), (x, ROOF - 0.06 - sag, -0.55)]
    for x in (-0.85, 0.85):
        places += [(x, ROOF - 0.08, 0.18), (x, ROOF - 0.08, -0.18)]
    return places


def stall_group(name: str, canvas: str, bulbs: bool = True) -> list[str]:
    lines = [f"  {name}:", "    shapes:",
             "    - {type: box, min: [-1.0, 0, -0.7], max: [1.0, 0.9, 0.7], material: wood}",
             f"    - {{type: box, min: [-1.1, {ROOF}, -0.8], max: [1.1, {ROOF + 0.08:.2f}, 0.8], material: {canvas}}}"]
    for k, (x, y, z) in enumerate(bulb_places() if bulbs else []):
        lines.append(f"    - {{type: sphere, center: [{x:.3f}, {y:.3f}, {z:.3f}], radius: {RADIUS}, material: {BULB_COLOURS[k]}_{k}}}")
    return lines


def string_group() -> list[str]:
    """The open variant's string of twelve lamps across a cell, over the aisle at its edge (z =
    half a cell): squares facing down (u x v points down), sagging toward the middle."""
    lines = ["  string:", "    shapes:"]
    half = 0.5 * LAMP_SIDE
    for k in range(12):
        x = CELL_X * ((k + 0.5) / 12 - 0.5)
        y = STRING_HEIGHT - 0.25 * (1.0 - (2.0 * x / CELL_X) ** 2)
        lines.append(f"    - {{type: quad, q: [{x - half:.4f}, {y:.3f}, {0.5 * CELL_Z - half:.4f}], u: [{LAMP_SIDE:.4f}, 0, 0], "
                     f"v: [0, 0, {LAMP_SIDE:.4f}], material: {BULB_COLOURS[k]}_{k}}}")
    return lines


def scene_text(open_aisles: bool = False) -> str:
    rnd = random.Random(SEED)
    materials = bulb_materials(rnd, "front" if open_aisles else "")
    placements = []
    for i in range(CELLS_X):
        for j in range(CELLS_Z):
            x, z = CELL_X * (i + 0.5 - 0.5 * CELLS_X), CELL_Z * (j + 0.5 - 0.5 * CELLS_Z)
            group = "red_stall" if (i + 2 * j) % 5 == 0 else "white_stall"
            turn = 180 * rnd.randrange(2)
            placements.append(f"  - {{type: instance, group: {group}, transform: [{{rotate: {{axis: y, degrees: {turn}}}}}, "
                              f"{{translate: [{x:.2f}, 0, {z:.2f}]}}]}}")
            if open_aisles:
                placements.append(f"  - {{type: instance, group: string, transform: [{{translate: [{x:.2f}, 0, {z:.2f}]}}]}}")
    stalls = len(placements) // (2 if open_aisles else 1)
    header = OPEN_HEADER if open_aisles else HEADER
    lines = header.format(lights=12 * stalls, placements=stalls).rstrip("\n").split("\n")
    lines += materials
    lines.append("groups:")
    lines += stall_group("white_stall", "white_canvas", bulbs=not open_aisles)
    lines += stall_group("red_stall", "red_canvas", bulbs=not open_aisles)
    if open_aisles:
        lines += string_group()
    lines.append("shapes:")
    lines.append("  - {type: quad, q: [-100, 0, -100], u: [200, 0, 0], v: [0, 0, 200], material: ground}")
    lines += placements
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if the committed file differs")
    parser.add_argument("--open", action="store_true", help="the open variant: benchmarks/light_tree_scenes/many_lights_open.yaml")
    args = parser.parse_args(argv)
    text = scene_text(open_aisles=args.open)
    out = OPEN_OUT if args.open else OUT
    if args.check:
        if not out.exists() or out.read_text() != text:
            print(f"{out.name} differs from what scenes/generate_many_lights.py writes", file=sys.stderr)
            return 1
        return 0
    out.write_text(text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
