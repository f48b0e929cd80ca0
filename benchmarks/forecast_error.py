"""The forecast against the time a render really takes to its noise target (docs/forecast.md).

    python benchmarks/forecast_error.py                       # the five scenes below
    python benchmarks/forecast_error.py --scenes cornell_box --width 200 --noise 0.05

For each scene: the dry run's pilot and forecast (`rt render --dry-run`, rt/dry_run.py), then the
render itself to the same target (`rt render --noise`), which also says its own first forecast
after its pilot (renderer/forecast.py's ForecastTracker, what the progress line shows). Printed:
both forecasts with their 95% ranges (the dry run's in samples too: those do not depend on the
machine's load), the seconds and samples the render took, and whether each range held it.
Times are rendering seconds (no compile: the kernel is compiled before the first measurement).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# (scene, width, noise target): targets each reached in roughly 10 to 60 s on 2 busy cores (dry runs at 2%
# said 5 to 30 s for the first four, 7 min for material_spheres).
CASES = (
    ("cornell_box", 200, 0.012),
    ("final_scene", 200, 0.02),
    ("cornell_smoke", 200, 0.012),
    ("weekend_cover", 200, 0.012),
    ("material_spheres", 200, 0.06),
)


def one(scene: str, width: int, noise: float, threads=None, pilot_width=None) -> dict:
    from rt.dry_run import dry_forecast, run_pilot
    from rt.render_job import RenderOptions, prepare
    from rt.rendering import BUDGET_SAMPLE_CAP, render_scene

    opts = RenderOptions(scene=ROOT / "scenes" / f"{scene}.yaml", output=Path("/tmp/forecast_error.png"), width=width,
                         noise=noise, threads=threads, kernel="general")
    prepared = prepare(opts)
    t0 = time.perf_counter()
    pilot = run_pilot(prepared.loaded, opts, prepared.frame, prepared.features, target=BUDGET_SAMPLE_CAP, width=pilot_width)
    pilot_wall = time.perf_counter() - t0
    dry = dry_forecast(pilot, cap=BUDGET_SAMPLE_CAP, noise_target=noise, time_budget=None)
    first = []

    def watch(stats) -> None:
        if stats.forecast is not None and not first:
            first.append((stats.samples, stats.seconds, stats.forecast))

    result = render_scene(prepared.flat, prepared.frame, prepared.features, target=BUDGET_SAMPLE_CAP, kernel="general",
                          threads=threads, progress=watch, noise_target=noise)
    return {"scene": scene, "width": width, "noise": noise, "pilot": pilot, "pilot_wall": pilot_wall, "dry": dry,
            "first": first[0] if first else None, "seconds": result.stats.seconds, "samples": result.film.samples,
            "reached": result.stats.noise}


def held(f, seconds: float) -> str:
    return "yes" if f.seconds_low <= seconds <= f.seconds_high else "no"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="*", help="scene names (default: the five of CASES)")
    parser.add_argument("--width", type=int, help="width for every scene (default: each case's)")
    parser.add_argument("--noise", type=float, help="noise target for every scene (default: each case's)")
    parser.add_argument("--threads", type=int)
    parser.add_argument("--pilot-width", type=int, help="force the pilot's width (default: the dry run's choice)")
    args = parser.parse_args()
    cases = [c for c in CASES if not args.scenes or c[0] in args.scenes]
    cases += [(s, 200, 0.05) for s in (args.scenes or []) if s not in {c[0] for c in CASES}]
    print("| scene | width | target | pilot (spp at px, s) | dry-run forecast (95% range) | dry-run samples (range) | "
          "in-render forecast at spp (95% range) | actual (spp) | dry held | in-render held | dry / actual |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for scene, width, noise in cases:
        width = args.width or width
        noise = args.noise or noise
        r = one(scene, width, noise, args.threads, args.pilot_width)
        p, dry, first = r["pilot"], r["dry"], r["first"]
        dry_text = f"{dry.seconds:.1f} s ({dry.seconds_low:.1f}-{dry.seconds_high:.1f})" if dry else "none"
        if first:
            n, _, f = first
            first_text = f"{f.seconds:.1f} s at {n} ({f.seconds_low:.1f}-{f.seconds_high:.1f})"
        else:
            first_text = "none (reached first)"
        samples_text = f"{dry.samples:.0f} ({dry.samples_low:.0f}-{dry.samples_high:.0f})" if dry else "none"
        print(f"| {scene} | {width} | {100 * noise:g}% | {p.samples} at {p.width} px, {p.seconds:.1f} s "
              f"({r['pilot_wall']:.1f} s wall) | {dry_text} | {samples_text} | {first_text} | {r['seconds']:.1f} s ({r['samples']}) | "
              f"{held(dry, r['seconds']) if dry else '-'} | {held(first[2], r['seconds']) if first else '-'} | "
              f"{dry.seconds / r['seconds']:.2f} |" if dry else "- |", flush=True)


if __name__ == "__main__":
    main()
