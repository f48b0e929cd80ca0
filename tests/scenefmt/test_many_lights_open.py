"""The open variant of the night market (benchmarks/light_tree_scenes/many_lights_open.yaml, for
benchmarks/light_tree.py): what scenes/generate_many_lights.py --open writes is what is committed,
and its 12,480 lamps are one-sided and face down (their light goes to the aisles, not the sky)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from scenefmt.validation import load

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "benchmarks" / "light_tree_scenes" / "many_lights_open.yaml"


def test_the_open_market_is_what_the_generator_writes():
    result = subprocess.run([sys.executable, str(ROOT / "scenes" / "generate_many_lights.py"), "--open", "--check"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_open_market_lamps_are_one_sided_and_face_down():
    scene = load(SCENE).scene
    lamps = {name for name, m in scene.materials.items() if m.type == "diffuse_light"}
    assert len(lamps) == 12 and all(scene.materials[name].sides == "front" for name in lamps)
    string = scene.groups["string"].shapes
    assert len(string) == 12 and all(s.material in lamps for s in string)
    for quad in string:
        u, v = quad.u, quad.v
        normal_y = u[2] * v[0] - u[0] * v[2]  # (u x v).y
        assert normal_y < 0.0
    placed = sum(1 for s in scene.shapes if getattr(s, "group", None) == "string")
    assert placed * len(string) == 12_480
