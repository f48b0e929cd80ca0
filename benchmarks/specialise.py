"""What specialised kernels save: per book scene, and per effect. Writes docs/performance.md.

    python benchmarks/specialise.py [--reps 5] [--no-write]

For each book scene it renders with the kernel specialised to the scene's features and with
the general (all-effects) kernel, interleaved, and prints the median times, their ratio, the
largest pixel difference (must be 0) and the cold compile time of each kernel (each measured
in a fresh process with an empty cache folder).

For each effect it renders a pair of scenes that differ only by that effect being absent or
present but (almost) never reached: a tiny shape carrying it behind the camera, a sky whose
two colours are equal, a lens of negligible size. The absent scene should be at least as fast
as the present one, and the general kernel on the absent scene at most about 3% slower than
the specialised one.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from dataclasses import fields
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from renderer.compile import compile_scene, with_width  # noqa: E402
from renderer.render import render  # noqa: E402
from renderer.variants import GENERAL, KernelFeatures, features_of  # noqa: E402
from scenefmt.validation import load, loads  # noqa: E402

SCENES = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))
BOOK_WIDTH, BOOK_SPP = 320, 16
BEGIN, END = "<!-- measured by benchmarks/specialise.py -->", "<!-- end of measured -->"

# The effect-pair scenes: a few diffuse and metal spheres under a solid sky (no optional path).
BASE = """
camera: {look_from: [0, 1.2, 6], look_at: [0, 0.6, 0], vfov: 35}
image: {width: 400, aspect_ratio: 1.5, samples_per_pixel: 16, max_depth: 20, seed: 1}
background: BACKGROUND
textures:
  TEXTURES
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
  red: {type: lambertian, albedo: [0.7, 0.2, 0.2]}
  steel: {type: metal, albedo: [0.8, 0.8, 0.8], fuzz: 0.3}
  MATERIALS
MEDIA
shapes:
  - {type: sphere, center: [0, -1000, 0], radius: 1000, material: white}
  - {type: sphere, center: [-1.2, 0.6, 0], radius: 0.6, material: red}
  - {type: sphere, center: [0, 0.6, 0], radius: 0.6, material: steel}
  - {type: sphere, center: [1.2, 0.6, 0], radius: 0.6, material: white}
  - {type: box, min: [-2, 0, -2], max: [2, 0.3, -1.5], material: red}
EXTRA
"""
SOLID = "{type: solid, color: [0.6, 0.7, 0.9]}"
# Where an effect's carrier sits: behind the camera, far too small to be reached in practice.
BEHIND = "center: [0, 1, 30], radius: 0.001"
PAIRS = {
    "motion": {"EXTRA": "  - {type: moving_sphere, center0: [0, 1, 30], center1: [0, 1.001, 30], radius: 0.001, material: white}"},
    "defocus": {"CAMERA": "defocus_angle: 0.000001"},
    "media": {"MEDIA": "media:\n  fog: {type: constant, density: 1, albedo: [0.5, 0.5, 0.5]}",
              "EXTRA": f"  - {{type: sphere, {BEHIND}, interior: fog}}"},
    "instances": {"EXTRA": f"  - {{type: sphere, {BEHIND}, material: white, transform: [{{scale: [1, 2, 1]}}]}}"},
    "checker": {"TEXTURES": "chk: {type: checker, scale: 0.3, even: [0, 0, 0], odd: [1, 1, 1]}",
                "MATERIALS": "tiles: {type: lambertian, albedo: chk}", "EXTRA": f"  - {{type: sphere, {BEHIND}, material: tiles}}"},
    "image": {"TEXTURES": f"earth: {{type: image, file: {ROOT / 'scenes' / 'earthmap.png'}}}",
              "MATERIALS": "globe: {type: lambertian, albedo: earth}", "EXTRA": f"  - {{type: sphere, {BEHIND}, material: globe}}"},
    "noise": {"TEXTURES": "n: {type: noise, scale: 4}", "MATERIALS": "stone: {type: lambertian, albedo: n}",
              "EXTRA": f"  - {{type: sphere, {BEHIND}, material: stone}}"},
    "emitters": {"MATERIALS": "lamp: {type: diffuse_light, emit: [4, 4, 4]}", "EXTRA": f"  - {{type: sphere, {BEHIND}, material: lamp}}"},
    "dielectrics": {"MATERIALS": "glass: {type: dielectric, ior: 1.5}", "EXTRA": f"  - {{type: sphere, {BEHIND}, material: glass}}"},
    "sky": {"BACKGROUND": "{type: sky, bottom: [0.6, 0.7, 0.9], top: [0.6, 0.7, 0.9]}"},
}


def pair_scene(effect: str | None) -> str:
    parts = {"BACKGROUND": SOLID, "TEXTURES": "", "MATERIALS": "", "MEDIA": "", "EXTRA": "", "CAMERA": ""}
    if effect:
        parts.update(PAIRS[effect])
    text = BASE
    if parts["CAMERA"]:
        text = text.replace("vfov: 35}", f"vfov: 35, {parts['CAMERA']}}}")
    for key in ("BACKGROUND", "MEDIA", "EXTRA"):
        text = text.replace(key, parts[key])
    text = text.replace("  TEXTURES", "  " + parts["TEXTURES"] if parts["TEXTURES"] else "  {}")
    text = text.replace("textures:\n  {}\n", "")
    return text.replace("  MATERIALS", "  " + parts["MATERIALS"] if parts["MATERIALS"] else "")


def interleaved(graph, flat, kernels, reps, samples):
    """Median seconds per kernel, runs alternating between kernels so machine noise hits all alike."""
    times = {name: [] for name in kernels}
    films = {}
    for name, features in kernels.items():  # compile or load each first, outside the timing
        render(graph, flat=flat, features=features, samples=1)
    for _ in range(reps):
        for name, features in kernels.items():
            result = render(graph, flat=flat, features=features, samples=samples)
            times[name].append(result.stats.seconds)
            films[name] = result.film
    return {name: statistics.median(t) for name, t in times.items()}, films


COMPILE_SNIPPET = """
import sys, time
from renderer.compile import compile_scene
from renderer.render import render
from renderer.variants import KernelFeatures
from scenefmt.validation import load
flags = dict(zip({names!r}, map(bool, {values!r})))
graph = load({scene!r}).graph
result = render(graph, samples=0, flat=compile_scene(graph), features=KernelFeatures(**flags))
print(result.stats.kernel_seconds)
"""


def cold_compile_seconds(features: KernelFeatures, scene: Path) -> float:
    """Seconds to compile the render kernel for `features` in a fresh process with an empty cache."""
    names = [f.name for f in fields(KernelFeatures)]
    values = [int(getattr(features, n)) for n in names]
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = subprocess.run([sys.executable, "-c", COMPILE_SNIPPET.format(names=names, values=values, scene=str(scene))],
                             env=env, capture_output=True, text=True, cwd=ROOT, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/performance.md alone")
    args = parser.parse_args()
    lines = []

    def out(line=""):
        print(line, flush=True)
        lines.append(line)

    out(f"Machine: {os.cpu_count()} cores, {os.environ.get('NUMBA_NUM_THREADS', 'all')} threads; "
        f"median of {args.reps} interleaved runs; render passes only (no start-up).")
    out()
    out(f"## Book scenes ({BOOK_WIDTH} px wide, {BOOK_SPP} spp, each scene's own max depth)")
    out()
    out("| scene | kernel (paths compiled in) | specialised | general | general / specialised | max pixel difference |")
    out("|---|---|---|---|---|---|")
    compile_scene_of: dict[str, Path] = {}
    for path in SCENES:
        graph = with_width(load(path).graph, BOOK_WIDTH)
        flat = compile_scene(graph)
        features = features_of(graph)
        compile_scene_of.setdefault(features.tag, path)
        medians, films = interleaved(graph, flat, {"spec": features, "general": GENERAL}, args.reps, BOOK_SPP)
        diff = float(np.max(np.abs(films["spec"].total - films["general"].total)))
        out(f"| {path.stem} | {features.tag} | {medians['spec']:.3f} s | {medians['general']:.3f} s | "
            f"{medians['general'] / medians['spec']:.3f} | {diff:g} |")
    out()
    out(f"The {len(SCENES)} book scenes need {len(compile_scene_of)} feature sets (plus the general kernel).")
    out()
    out("## Cold compile of each kernel (fresh process, empty cache)")
    out()
    out("| kernel | compile |")
    out("|---|---|")
    out(f"| all (general) | {cold_compile_seconds(GENERAL, SCENES[0]):.1f} s |")
    for tag, path in sorted(compile_scene_of.items()):
        features = features_of(load(path).graph)
        out(f"| {tag} | {cold_compile_seconds(features, path):.1f} s |")
    out()
    out("## Each effect: absent, or present but never reached (400x267 px, 16 spp, depth 20)")
    out()
    out("| effect | absent, specialised | present, specialised | absent / present | its path compiled in, on absent | general on absent | general / specialised on absent |")
    out("|---|---|---|---|---|---|---|")
    absent_graph = loads(pair_scene(None)).graph
    absent_flat = compile_scene(absent_graph)
    none = features_of(absent_graph)
    assert none.tag == "none", none.tag
    for effect in PAIRS:
        present_graph = loads(pair_scene(effect)).graph
        present_flat = compile_scene(present_graph)
        present = features_of(present_graph)
        assert present.tag == effect, (effect, present.tag)
        render(present_graph, flat=present_flat, features=present, samples=1)
        a_times, p_times = {"spec": [], "one": [], "general": []}, []
        for _ in range(args.reps):
            a_times["spec"].append(render(absent_graph, flat=absent_flat, features=none).stats.seconds)
            p_times.append(render(present_graph, flat=present_flat, features=present).stats.seconds)
            # The absent scene through the kernel that has just this one path: what the path
            # costs when it is compiled in but never taken.
            a_times["one"].append(render(absent_graph, flat=absent_flat, features=present).stats.seconds)
            a_times["general"].append(render(absent_graph, flat=absent_flat, features=GENERAL).stats.seconds)
        a_spec, a_one, a_gen = (statistics.median(a_times[k]) for k in ("spec", "one", "general"))
        p_spec = statistics.median(p_times)
        out(f"| {effect} | {a_spec:.3f} s | {p_spec:.3f} s | {a_spec / p_spec:.3f} | "
            f"{a_one:.3f} s ({100 * (a_one / a_spec - 1):+.1f}%) | {a_gen:.3f} s | {100 * (a_gen / a_spec - 1):+.1f}% |")
    if not args.no_write:
        # The measured part of docs/performance.md sits between two markers; the prose stays.
        target = ROOT / "docs" / "performance.md"
        doc = target.read_text()
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        target.write_text(head + BEGIN + "\n" + "\n".join(lines) + "\n" + END + tail)
        print(f"wrote {target.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
