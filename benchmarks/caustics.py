"""Time to a true error of 2% on the scenes lit through glass (issue 34): each integrator, and Mitsuba 3.

    python benchmarks/caustics.py [--scenes sky_spheres,caustic_glass,...] [--integrators mis guided caustics]
                                  [--seconds 4] [--target 0.02] [--mitsuba] [--pixels unlit matte]
                                  [--references mis caustics]

For each scene at the converged references' size (48 pixels wide, tests/renderer/converged.py),
each integrator renders for a budget of `--seconds` and again for 4 x that budget, interleaved
(mis, guided, caustics, mis, ...), in this one process, on the full general kernel, loaded or
compiled before any clock starts. Each render's TRUE relative RMS error is measured against a
converged reference of the scene with the reference's own expected squared error taken out
(converged.true_error), over the same pixels for every renderer. Two sets of pixels (`--pixels`,
each its own table, measured on the same renders):

- `unlit` (the default): all but those whose camera rays see a light or the background directly
  (light_pixels.sees_light), whose value is the camera's sampling of a light's edge or the sky,
  the same for every integrator;
- `matte`: only those whose camera rays all land on a surface with a density
  (matte_pixels.matte_pixels). A pixel whose first hit is glass or a mirror is rendered by the
  very same estimator in mis and caustics, and its error (a lamp seen through the glass) is the
  camera's sampling of a tiny bright image, which no integrator changes.

Each scene may have a reference per integrator that made it (`--references`: STEM.npz of the
scene's own integrator, mis, and STEM.caustics.npz from `converged.py --integrator caustics`); for
each set of pixels the one with the lower own error there is used, and its name and own error
are printed with the scene. Where both exist, how well they agree is printed too
(reference_agreement.py).

The time to reach the target error is t x (e / target)^2: an unbiased estimator's squared error
falls as one over its samples, so as one over the time spent. t is the whole wall time of the
render call (for guided, its training included; the training's own seconds are printed too).
Printed for both budgets: where the two agree, the extrapolation holds; where the longer one
is much lower, the short render missed rare paths that its own figure could not see.

With --mitsuba, Mitsuba 3's `path` integrator (llvm_ad_rgb, the same max depth, box filter, the
same camera and pixels: mitsuba_scene.py) renders each scene for the same wall times, its error
measured the same way (a lamp inside glass given Mitsuba's radiance convention: MITSUBA_EMITTER_SCALE).
Where Mitsuba has no equal of something in a scene, both renderers render
a variant (VARIANTS) against that variant's own converged reference (made here the first time,
with converged.py's seeds and sample counts, and kept in benchmarks/.cache/); a scene with no
faithful variant is left out of the comparison with the reason printed (LEFT_OUT).
"""

from __future__ import annotations

import argparse
import hashlib
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CACHE = Path(__file__).resolve().parent / ".cache"
for _path in (str(ROOT), str(Path(__file__).resolve().parent)):
    if _path not in sys.path:
        sys.path.insert(0, _path)

from tests.renderer.converged import (  # noqa: E402
    DEFAULT_SPP, SPP_BY_SCENE, Reference, read_reference, reference_path, render_reference, scene_file,
    small_graph, true_error)

SCENES = ("sky_spheres", "caustic_glass", "final_scene", "glass_lamp", "cornell_box")
INTEGRATORS = ("mis", "guided", "caustics")
PIXELS = ("unlit", "matte")  # the sets of pixels measured (see above); the first is the default
REFERENCES = ("mis", "caustics")  # the integrators whose converged references are looked for
BUDGET_FACTORS = (1, 4)  # each render at t and at 4 t: the time-to-error figure must hold at both
KERNEL = "general"  # one compiled kernel for every integrator and scene (renderer/variants.py)
MITSUBA_PASS_SPP = 16
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"

# What each scene becomes for Mitsuba (`rt render --set` arguments), where Mitsuba has no equal of
# something in it. Both renderers render the variant, against its own converged reference.
VARIANTS: dict[str, tuple[str, ...]] = {
    # The books' fuzzed metal has no Mitsuba equal; unfuzzed it is a mirror in both.
    "sky_spheres": ("materials.steel.fuzz=0",),
    # The books' lamp is two-sided and lights the ceiling through the gap above it; Mitsuba's
    # area light is one-sided: make ours one-sided too (`sides: front`, facing down).
    "cornell_box": ("materials.light.sides=front",),
}
# Sample counts of a variant's reference where they are not the scene's own (converged.SPP_BY_SCENE).
# The own error of the reference is printed with every figure measured against it.
# sky_spheres' mirror variant: 2 x 65,536 spp of caustics bring its reference's own error on the
# matte pixels well under a 2% target's quarter, in half the scene's own count of mis samples.
VARIANT_SPP: dict[str, int] = {"sky_spheres": 65536}
# Radiance crossing into a denser medium is compressed by the squared ratio of the indices, and
# Mitsuba's dielectric (in radiance mode, as pbrt-v4's) scales it so: light leaving glass of index
# n is divided by n^2 and light entering multiplied by it. Ours does not scale it. A path that enters
# and leaves the glass gets both factors, which cancel; a lamp inside the glass gets only the first,
# so Mitsuba renders glass_lamp's lamp 1 / 1.5^2 = 0.444 as bright (measured: 0.445 of our image's
# mean, and 1.000 with the glass made black). The lamp's radiance as given is ours inside the glass,
# so Mitsuba's emitter is given n^2 times it: then both render the same image.
MITSUBA_EMITTER_SCALE: dict[str, float] = {"glass_lamp": 1.5**2}
LEFT_OUT: dict[str, str] = {
    "final_scene": "Mitsuba has no equal of its image and marble textures, its fuzzed metal, or its two constant media "
                   "(a subsurface sphere and the mist filling the scene), and a variant without them is another scene",
}


@dataclass
class Measurement:
    """One render of one scene: by which renderer, for which budget, and what it reached."""

    scene: str  # the scene's name, with '@variant' for a Mitsuba variant
    renderer: str  # an integrator's name, or 'mitsuba'
    budget: float  # seconds asked for
    wall: float  # seconds of wall time the whole render took (for guided, the training included)
    cpu: float  # CPU seconds of this process over the same span (every thread)
    training: float  # seconds of that spent training a guide (0 for the others)
    spp: int
    error: float  # true relative RMS error over the kept pixels
    kept: np.ndarray  # the pixels measured (rows, columns), the same array for every renderer of the scene

    def time_to(self, target: float) -> float:
        return time_to_error(self.wall, self.error, target)

    def cpu_to(self, target: float) -> float:
        """The same in CPU seconds: fairer where renders of one run got unequal shares of a busy machine."""
        return time_to_error(self.cpu, self.error, target)


def time_to_error(seconds: float, error: float, target: float) -> float:
    """The time an unbiased estimator that reached relative error `error` in `seconds` needs to
    reach `target`: its squared error falls as one over the time, so t (e / target)^2."""
    if not (math.isfinite(seconds) and math.isfinite(error)) or target <= 0.0:
        return math.inf
    return seconds * (error / target) ** 2


def kept_pixels(graph, pixels: str = "unlit") -> np.ndarray:
    """The pixels measured (rows, columns): for `unlit` all but those whose camera rays see a light
    or the background directly; for `matte` only those whose camera rays all land on a surface
    with a density."""
    if pixels == "matte":
        from matte_pixels import matte_pixels

        return matte_pixels(graph)
    if pixels != "unlit":
        raise ValueError(f"no set of pixels named {pixels!r}: expected one of {', '.join(PIXELS)}")
    from light_pixels import sees_light

    return ~sees_light(graph)


def masked(reference: Reference, keep: np.ndarray) -> Reference:
    """The reference restricted to the kept pixels (true_error and own_error sum over what they get)."""
    return Reference(reference.mean[keep], reference.var[keep], reference.difference[keep], reference.spp)


def variant_reference_path(stem: str, settings: tuple[str, ...], integrator: str = "mis") -> Path:
    """Where the converged reference of a variant of a scene made with `integrator` is cached."""
    tag = hashlib.sha256("\n".join(settings).encode()).hexdigest()[:10]
    spp = VARIANT_SPP.get(stem) or SPP_BY_SCENE.get(stem, DEFAULT_SPP)
    suffix = "" if integrator == "mis" else f".{integrator}"
    return CACHE / f"converged-{stem}-{tag}-{spp}{suffix}.npz"


def variant_reference(stem: str, settings: tuple[str, ...], graph, integrator: str = "mis") -> Reference:
    """The converged reference of a variant of a scene, made as converged.py makes the scene's own
    (its seeds and sample count; the scene's own integrator or `integrator`), cached under
    benchmarks/.cache/."""
    path = variant_reference_path(stem, settings, integrator)
    if not path.exists():
        spp = VARIANT_SPP.get(stem) or SPP_BY_SCENE.get(stem, DEFAULT_SPP)
        print(f"  making the {integrator} reference of {stem} with {'; '.join(settings)}: 2 x {spp} spp ...", flush=True)
        arrays, seconds = render_reference(graph, spp, None if integrator == "mis" else integrator)
        CACHE.mkdir(exist_ok=True)
        np.savez_compressed(path, **arrays)
        print(f"  ... {seconds[0]:.0f} + {seconds[1]:.0f} s (cached in {path.relative_to(ROOT)})", flush=True)
    return read_reference(path)


def references_of(stem: str, settings: tuple[str, ...], graph, integrators=REFERENCES,
                  make: tuple[str, ...] = ("mis",)) -> dict[str, Reference]:
    """The converged references of a scene (or of its variant) there are, by the integrator that
    made them: a variant's references by the integrators in `make` are made where missing, any
    other only read where it was made before (a scene's: converged.py --integrator)."""
    out = {}
    for integrator in integrators:
        if settings and integrator in make:
            out[integrator] = variant_reference(stem, settings, graph, integrator)
            continue
        path = variant_reference_path(stem, settings, integrator) if settings else reference_path(
            stem, None if integrator == "mis" else integrator)
        if path.exists():
            out[integrator] = read_reference(path)
    if not out:
        raise SystemExit(f"{stem}: no converged reference of {', '.join(integrators)} (make one with "
                         f"tests/renderer/converged.py, or --make-variant-references for a variant)")
    return out


def best_reference(references: dict[str, Reference], keep: np.ndarray) -> tuple[str, Reference]:
    """The reference with the lowest own error on the kept pixels, restricted to them, and its name."""
    name = min(references, key=lambda k: masked(references[k], keep).own_error())
    return name, masked(references[name], keep)


def training_seconds(stats) -> float:
    """The seconds a render spent training its guide (RenderStats.guide_training; 0 without one)."""
    training = getattr(stats, "guide_training", None)
    return float(training.total_seconds) if training is not None else 0.0


@dataclass
class Render:
    """One render of one scene, before it is measured on a set of pixels."""

    scene: str
    renderer: str
    budget: float
    wall: float
    cpu: float
    training: float
    spp: int
    image: np.ndarray | None  # (h, w, 3); None where the budget left no sample

    def measured(self, truth: Reference, keep: np.ndarray) -> Measurement:
        error = true_error(self.image[keep], truth) if self.image is not None else math.inf
        return Measurement(self.scene, self.renderer, self.budget, self.wall, self.cpu, self.training, self.spp,
                           error, keep)


def render_rt(scene: str, graph, integrator: str, seconds: float, seed: int) -> Render:
    """Render `graph` with `integrator` for `seconds` (the kernel loaded first)."""
    from renderer.compile import compile_scene, with_integrator
    from renderer.render import render

    g = with_integrator(graph, integrator)
    flat = compile_scene(g)
    render(g, flat=flat, samples=1, kernel=KERNEL)  # compile or load the kernels before the clock starts
    w0, c0 = time.perf_counter(), time.process_time()
    result = render(g, flat=flat, samples=1 << 40, time_budget=seconds, seed=seed, kernel=KERNEL)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    # A budget the training used up leaves no sample: no image, an infinite error and time.
    image = result.film.mean() if result.film.samples > 0 else None
    return Render(scene, integrator, seconds, wall, cpu, training_seconds(result.stats), result.film.samples, image)


def measure_rt(scene: str, graph, integrator: str, seconds: float, truth: Reference, keep: np.ndarray,
               seed: int) -> Measurement:
    """Render `graph` with `integrator` for `seconds` (the kernel loaded first) and measure it."""
    return render_rt(scene, graph, integrator, seconds, seed).measured(truth, keep)


def mitsuba_variant() -> str:
    """Mitsuba's LLVM variant (its library named for Dr.Jit where this machine has it)."""
    if os.path.exists(LLVM):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    from mitsuba_scene import set_variant

    return set_variant()


def render_mitsuba(scene: str, graph, seconds: float, seed: int) -> Render:
    """Mitsuba 3's path tracer on `graph` for `seconds` of wall time (its kernel traced and compiled
    by a first pass before the clock starts)."""
    import mitsuba as mi
    from mitsuba_scene import render_passes, scene_dict

    converted = scene_dict(graph, spp=MITSUBA_PASS_SPP)
    scale = MITSUBA_EMITTER_SCALE.get(scene.split("@")[0], 1.0)
    for entry in converted.values():
        if isinstance(entry, dict) and entry.get("emitter", {}).get("type") == "area":
            radiance = entry["emitter"]["radiance"]
            radiance["value"] = [scale * x for x in radiance["value"]]
    scene_mi = mi.load_dict(converted)
    passes = render_passes(scene_mi, MITSUBA_PASS_SPP, seconds=seconds, seed=1000 * seed)
    return Render(scene, "mitsuba", seconds, passes.seconds, passes.cpu_seconds, 0.0, passes.samples, passes.mean())


def measure_mitsuba(scene: str, graph, seconds: float, truth: Reference, keep: np.ndarray, seed: int) -> Measurement:
    """Mitsuba 3's path tracer on `graph` for `seconds` of wall time, measured as ours are."""
    return render_mitsuba(scene, graph, seconds, seed).measured(truth, keep)


@dataclass
class SceneRows:
    """A scene's renders measured on one set of pixels against the better reference there."""

    pixels: str  # the name of the set of pixels (PIXELS)
    measurements: list[Measurement]
    truth: Reference  # restricted to the kept pixels
    reference: str  # the integrator that made it
    agreement: object = None  # reference_agreement.Agreement of the scene's two references there, if both exist


def measure_scene_pixels(stem: str, integrators=INTEGRATORS, seconds: float = 4.0, factors=BUDGET_FACTORS,
                         mitsuba: bool = False, settings: tuple[str, ...] = (), pixels=PIXELS[:1],
                         references=REFERENCES, make: tuple[str, ...] = ("mis",)) -> list[SceneRows]:
    """Every renderer on one scene (or its variant, with `settings`) at each budget, interleaved,
    each render measured on every set of `pixels` against the scene's better reference there."""
    from reference_agreement import agreement

    graph = small_graph(scene_file(stem), settings)
    name = stem + ("@variant" if settings else "")
    renders = []
    for seed, factor in enumerate(factors, start=1):
        budget = seconds * factor
        for integrator in integrators:
            renders.append(render_rt(name, graph, integrator, budget, seed))
        if mitsuba:
            renders.append(render_mitsuba(name, graph, budget, seed))
    # Read (or made) after the renders: a reference still being made elsewhere may be ready by then.
    available = references_of(stem, settings, graph, references, make)
    out = []
    for kind in pixels:
        keep = kept_pixels(graph, kind)
        which, truth = best_reference(available, keep)
        agree = None
        if "mis" in available and "caustics" in available:
            agree = agreement(masked(available["caustics"], keep), masked(available["mis"], keep))
        out.append(SceneRows(kind, [r.measured(truth, keep) for r in renders], truth, which, agree))
    return out


def measure_scene(stem: str, integrators=INTEGRATORS, seconds: float = 4.0, factors=BUDGET_FACTORS,
                  mitsuba: bool = False, settings: tuple[str, ...] = (), pixels: str = PIXELS[0],
                  references=REFERENCES) -> tuple[list[Measurement], Reference]:
    """`measure_scene_pixels` on one set of pixels: the measurements, and the reference restricted to them."""
    rows = measure_scene_pixels(stem, integrators, seconds, factors, mitsuba, settings, (pixels,), references)[0]
    return rows.measurements, rows.truth


def table(rows: list[tuple[list[Measurement], Reference]], target: float, baseline: str = "guided",
          reference_names: list[str] | None = None) -> str:
    """The markdown table of the measurements, one row per render; the last column is the row's
    time to the target over `baseline`'s at the same budget on the same scene. `reference_names`:
    per row group, the integrator that made its reference (printed with its own error)."""
    lines = [f"| scene (kept pixels, reference's own error) | renderer | budget s | wall s | CPU s | training s | spp "
             f"| true error | time to {100 * target:g}% (s) | CPU s to {100 * target:g}% | / {baseline} |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for index, (measurements, truth) in enumerate(rows):
        made_by = f"{reference_names[index]} " if reference_names else ""
        for m in measurements:
            base = next((b for b in measurements if b.renderer == baseline and b.budget == m.budget), None)
            ratio = m.time_to(target) / base.time_to(target) if base is not None and base.time_to(target) > 0 else math.nan
            scene = f"{m.scene} ({np.mean(m.kept):.0%}, {made_by}{truth.own_error():.4f})"
            lines.append(f"| {scene} | {m.renderer} | {m.budget:g} | {m.wall:.2f} | {m.cpu:.2f} | {m.training:.2f} | "
                         f"{m.spp} | {m.error:.4f} | {m.time_to(target):.4g} | {m.cpu_to(target):.4g} | "
                         f"{'' if m.renderer == baseline or not math.isfinite(ratio) else f'{ratio:.2f}'} |")
    return "\n".join(lines)


def agreement_lines(rows: list[SceneRows]) -> list[str]:
    """One line per scene and set of pixels whose two references were compared."""
    out = []
    for r in rows:
        if r.agreement is None:
            continue
        a = r.agreement
        out.append(f"- {r.measurements[0].scene}, {r.pixels} pixels: caustics - mis reference RMS {a.rms:.4f} against "
                   f"{a.expected_rms:.4f} expected from their own errors (ratio {a.rms / a.expected_rms:.2f}); image "
                   f"means differ by {100 * a.relative_mean_difference:+.2f}%, z = {a.z:+.2f}")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--integrators", nargs="+", default=list(INTEGRATORS))
    parser.add_argument("--seconds", type=float, default=4.0, help="the shorter budget per render (the longer is 4x)")
    parser.add_argument("--target", type=float, default=0.02, help="relative RMS error to reach")
    parser.add_argument("--mitsuba", action="store_true", help="also Mitsuba 3 at the same wall times")
    parser.add_argument("--pixels", nargs="+", default=list(PIXELS[:1]), choices=PIXELS,
                        help="the sets of pixels measured, a table each (unlit: all but those that see a light or "
                             "the background; matte: only those whose camera rays all land on a matte surface)")
    parser.add_argument("--references", nargs="+", default=list(REFERENCES),
                        help="the integrators whose converged references may be used (the better one is)")
    parser.add_argument("--make-variant-references", nargs="+", default=["mis"], metavar="INTEGRATOR",
                        help="make the Mitsuba variants' references with these integrators where missing (default mis)")
    args = parser.parse_args(argv)
    import numba

    started = time.perf_counter()
    print(f"{numba.get_num_threads()} threads, {KERNEL} kernel, budgets "
          f"{', '.join(f'{args.seconds * f:g}' for f in BUDGET_FACTORS)} s; target {100 * args.target:g}%", flush=True)
    if args.mitsuba:
        print(f"Mitsuba {__import__('mitsuba').__version__} {mitsuba_variant()}, passes of {MITSUBA_PASS_SPP} spp", flush=True)
    rows: list[SceneRows] = []
    baseline = next((b for b in ("caustics", "guided") if b in args.integrators), args.integrators[-1])
    for stem in args.scenes.split(","):
        print(f"{stem} ...", flush=True)
        as_is = args.mitsuba and stem not in VARIANTS and stem not in LEFT_OUT
        rows += measure_scene_pixels(stem, args.integrators, args.seconds, mitsuba=as_is, pixels=args.pixels,
                                     references=args.references)
        if args.mitsuba and stem in VARIANTS:
            print(f"{stem}, variant for Mitsuba ({'; '.join(VARIANTS[stem])}) ...", flush=True)
            rows += measure_scene_pixels(stem, args.integrators, args.seconds, mitsuba=True, settings=VARIANTS[stem],
                                         pixels=args.pixels, references=args.references,
                                         make=tuple(args.make_variant_references))
    for pixels in args.pixels:
        mine = [r for r in rows if r.pixels == pixels]
        print(f"\n{pixels} pixels:\n")
        print(table([(r.measurements, r.truth) for r in mine], args.target, baseline, [r.reference for r in mine]))
        agree = agreement_lines(mine)
        if agree:
            print("\nThe two references of a scene:\n" + "\n".join(agree))
    if args.mitsuba:
        for stem in args.scenes.split(","):
            if stem in LEFT_OUT:
                print(f"\n{stem}: left out of the Mitsuba comparison: {LEFT_OUT[stem]}.")
    print(f"\n{time.perf_counter() - started:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
