"""Side by side with Mitsuba 3: the Cornell box under each new kind of light, rendered by both,
compared within noise.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so \\
    python benchmarks/mitsuba_lights.py [--cases one_sided,point,spot,directional] [--width 64]
                                        [--spp 512] [--mitsuba-spp 512] [--block 8]

The cases, each the shipped Cornell box (scenes/cornell_box.yaml) at the same depth (50) in both:

- one_sided: its lamp as the books place it, 1 unit under the ceiling, made one-sided
  (`sides: front`, facing down as its u x v does). Mitsuba's area light is one-sided, so no
  flush-lamp trick is needed: the lamp's back lights nothing in either.
- point, spot: the lamp's quad made part of the white ceiling (flush with it, white), and the
  box lit by a point light, or a spot light aimed at the floor, under the ceiling.
- directional: the same box without a lamp, lit by parallel light coming in through its open
  front, down toward the back wall (a closed box would stay dark).
- two_sided (the control, not run unless named): the books' two-sided lamp as shipped, which
  Mitsuba can only render one-sided: the light of its back, up onto the ceiling and down again,
  is about 2% of the image, and the comparison must tell it apart (it prints DIFFERS, as it
  should, and FAIL if it cannot).

Each case is written as `rt render --set` arguments on the shipped scene (printed per case), so
`rt render scenes/cornell_box.yaml --set ...` renders it. mitsuba_scene.py converts the scene and
its lights (point -> `point`, spot -> `spot` with the same angles: the same profile,
directional -> `directional`). The comparison is mitsuba_materials.py's: the image means and the
means of --block x --block blocks (every channel), each difference as a z-score against both
sides' noise (ours from each pixel's samples, Mitsuba's from the spread of its passes, each with
its own seed), held to the Bonferroni bound of their number at significance 1e-3. Figures and
what they showed: docs/lights.md, "Side by side with Mitsuba 3".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from mitsuba_materials import compare, ours, print_comparison, triple
from mitsuba_scene import render_passes, scene_dict, set_variant

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# The lamp's quad as part of the white ceiling: flush with it, and white.
NO_LAMP = ("shapes[2].q=[343,554.999,332]", "shapes[2].material=white")

# name -> (what it shows, the --set arguments on the shipped scene)
CASES: dict[str, tuple[str, tuple[str, ...]]] = {
    "one_sided": ("the books' lamp, 1 under the ceiling, emitting only downward (sides: front)",
                  ("materials.light.sides=front",)),
    "point": ("a point light of 10^5 W/sr in the middle of the box, 105 under the ceiling",
              NO_LAMP + ("lights=[{type: point, position: [278, 450, 278], intensity: [100000, 100000, 100000]}]",)),
    "spot": ("a spot light of 3 x 10^5 W/sr under the ceiling aimed at the floor, cut-off 35 degrees, beam 20",
             NO_LAMP + ("lights=[{type: spot, position: [278, 545, 278], look_at: [278, 0, 278], "
                        "intensity: [300000, 300000, 300000], cutoff_angle: 35, beam_width: 20}]",)),
    "directional": ("parallel light of 2 W/m^2 through the open front, down toward the back wall",
                    NO_LAMP + ("lights=[{type: directional, direction: [0.15, -0.5, 1], irradiance: [2, 2, 2]}]",)),
}
# Cases whose images must differ: the check's power, shown on a difference it must see.
CONTROLS: dict[str, tuple[str, tuple[str, ...]]] = {
    "two_sided": ("the books' two-sided lamp as shipped, against Mitsuba's one-sided one (must differ)", ()),
}


def load_case(name: str, width: int):
    from renderer.compile import with_width
    from scenefmt.validation import load

    return with_width(load(ROOT / "scenes" / "cornell_box.yaml", {**CASES, **CONTROLS}[name][1]).graph, width)


def theirs(graph, spp: int, pass_spp: int, seed: int):
    """Mitsuba's render (mitsuba_materials.theirs) with its passes seeded from `seed`: passes k of
    seed s use Mitsuba's seed 100000 s + k, so two seeds never share a pass."""
    import mitsuba as mi

    scene = mi.load_dict(scene_dict(graph, spp=pass_spp))
    passes = render_passes(scene, pass_spp, passes=max(2, -(-spp // pass_spp)), seed=100000 * seed)
    return passes.mean(), passes.mean_variance(), passes.samples, passes.seconds, passes.cpu_seconds


def verdict(within_noise: bool, control: bool) -> str:
    """PASS for a case within noise; for a control, DIFFERS when the check sees its difference."""
    if control:
        return "DIFFERS (control: PASS)" if not within_noise else "FAIL (control not told apart)"
    return "PASS" if within_noise else "FAIL"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES), help=f"of {', '.join(CASES)}; controls: {', '.join(CONTROLS)}")
    parser.add_argument("--width", type=int, default=64)
    parser.add_argument("--spp", type=int, default=512, help="our samples per pixel")
    parser.add_argument("--mitsuba-spp", type=int, default=512, help="Mitsuba's samples per pixel")
    parser.add_argument("--mitsuba-pass", type=int, default=32, help="Mitsuba's samples per pass (its noise comes from their spread)")
    parser.add_argument("--block", type=int, default=8)
    parser.add_argument("--seed", type=int, default=1, help="ours, and Mitsuba's passes (from 100000 x seed): "
                        "cases rendered with one seed share their random numbers, so their noise is alike")
    args = parser.parse_args(argv)
    import numba

    variant = set_variant()
    print(f"Mitsuba {__import__('mitsuba').__version__} {variant}; ours on {numba.get_num_threads()} threads, general kernel; "
          f"{args.width} pixels wide; blocks of {args.block}x{args.block}; significance 1e-3 per case (Bonferroni)")
    failed = []
    rows = []
    for name in args.cases.split(","):
        what, settings = {**CASES, **CONTROLS}[name]
        control = name in CONTROLS
        graph = load_case(name, args.width)
        print(f"\n{name}: {what} ({graph.image.width}x{graph.image.pixel_height}, depth {graph.image.max_depth})")
        for s in settings:
            print(f"  --set '{s}'")
        a = ours(graph, args.spp, args.seed)
        b = theirs(graph, args.mitsuba_spp, args.mitsuba_pass, args.seed)
        r = compare(a[:2], b[:2], args.block)
        rel = print_comparison(a, b, r, verdict(r["ok"], control))
        rows.append((name, a, b, r, rel, control))
        if r["ok"] == control:
            failed.append(name)
        cache = Path(__file__).resolve().parent / ".cache"
        cache.mkdir(exist_ok=True)
        np.savez(cache / f"mitsuba_lights-{name}-{args.width}-seed{args.seed}.npz", rt=a[0], rt_var=a[1], mitsuba=b[0], mitsuba_var=b[1])
    print("\n| case | rt spp | Mitsuba spp | rt mean (R G B) | Mitsuba mean | rt / Mitsuba - 1 | z of the means | largest block z (bound) | |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, a, b, r, rel, control in rows:
        print(f"| {name} | {a[2]} | {b[2]} | {triple(r['mean_a'])} | {triple(r['mean_b'])} | {triple(rel, '+.2f')} % | "
              f"{triple(r['z_image'], '+.2f')} | {r['z_blocks']:.2f} ({r['limit_blocks']:.2f}) | {verdict(r['ok'], control)} |")
    print(f"\n{'all PASS' if not failed else 'FAIL: ' + ', '.join(failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
