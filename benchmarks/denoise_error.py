"""What the denoiser buys and what bias it brings, measured against converged references (issue 35).

    python benchmarks/denoise_error.py [--scenes cornell_box,final_scene,sky_spheres] [--spp 4,16,64,256]
                                       [--seeds 8] [--write-doc [PATH]]

For each scene at the converged references' size (48 pixels wide, tests/renderer/converged.py)
and each sample count, `--seeds` renders with different seeds, each denoised (rt/denoise.py: Open
Image Denoise's RT filter, hdr) three ways (MODES): from its colour alone; guided by the albedo and
normal passes (renderer/tracing/aux_passes.py, rendered with the render's seed and as many camera
rays as `rt render --denoise` gives them, rt/denoised_files.PASS_SAMPLES) that OIDN filters first
(`prefiltered`, cleanAux off); and guided by the same passes read as they are (`guided`, cleanAux
on: what `rt render --denoise` does, SHIPPED). Every image's TRUE relative RMS error is measured
against the scene's converged reference with the reference's own expected squared error taken
out (converged.true_error), on two sets of pixels:

- `unlit`: all but those whose camera rays see a light or the background, or brighter than 1
  (benchmarks/light_pixels.py, as the integrator study of docs/accuracy.md): their value is the
  light's own, and on a 48-pixel Cornell box the lamp's 4% of the pixels hold most of the squared
  signal, so an error over all pixels is mostly the error on the lamp's rim;
- `all`: every pixel, which is what a viewer of the image sees.

The first table sets the three ways side by side (errors only); the others follow the shipped
one. Per scene, sample count and set of pixels they print: the raw render's error (the RMS over seeds,
as docs/accuracy.md measures it: a render's expected squared error), the denoised images' errors,
and what the raw render would need to reach the denoised error: spp x (e_raw / e_denoised)^2
samples (an unbiased estimator's squared error falls as one over its samples), and the seconds
of a render of that many. A render of a 48-pixel image at a few samples is mostly fixed cost
(starting its passes: 0.06 s of a 4-spp Cornell box's 0.1), so its seconds are not scaled in
proportion, t x (e_raw / e_denoised)^2, which would credit the raw render with that cost many
times over: the raw renders' mean seconds at the study's sample counts are fitted by a line,
fixed + per-sample x spp (least squares, the fixed part at least 0), and the seconds of both
are read from it. Against them, the denoised image's seconds: the same line at its samples, plus
the denoise (the passes' render included where guided). Their ratio is the gain at equal time:
above 1, denoising wins.

Bias: a denoised image's error is part noise, part bias. The noise goes away in the mean of many
renders with different seeds, the bias does not: the error of the mean of n renders is
sqrt(bias^2 + var / n), while one render's expected squared error is bias^2 + var. So
bias^2 = (n E_mean^2 - E^2) / (n - 1), with E the RMS over seeds and E_mean the error of the
mean image; printed as the bias's relative RMS, beside the raw render's own figure as a control
(an unbiased render gives about 0).

With --write-doc the table is written into docs/accuracy.md between the markers BEGIN and END
(the section "Denoising"; created at the end of the page if missing; benchmarks/accuracy.py keeps
it when it rewrites the page). The figures are generated, never typed.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for _path in (str(ROOT), str(Path(__file__).resolve().parent)):
    if _path not in sys.path:
        sys.path.insert(0, _path)

SCENES = ("cornell_box", "final_scene", "sky_spheres")
SPPS = (4, 16, 64, 256)
SEEDS = 8
KERNEL = "general"  # one compiled kernel for every scene (renderer/variants.py)
PIXELS = ("unlit", "all")
DOC = ROOT / "docs" / "accuracy.md"
HEADING = "## Denoising"
BEGIN, END = "<!-- measured by benchmarks/denoise_error.py -->", "<!-- end of measured by benchmarks/denoise_error.py -->"
SEED_BASE = 51000  # far from the converged references' seeds (converged.SEEDS)
# How each image is denoised: (passes given, cleanAux), and what the tables call it.
MODES = {"colour": (False, False), "prefiltered": (True, False), "guided": (True, True)}
NAMES = {"colour": "colour alone", "prefiltered": "passes, prefiltered", "guided": "passes as they are"}
SHIPPED = "guided"  # what rt render --denoise does (rt/denoised_files.guided_denoise)


@dataclass
class Trial:
    """One render of one scene at one sample count, raw and denoised, on every set of pixels."""

    spp: int
    seed: int
    render_seconds: float  # the raw render's wall time
    denoise_seconds: dict  # by mode (MODES): the filter's seconds, the passes' render included
    images: dict  # by mode, and "raw": the (h, w, 3) image


@dataclass
class Row:
    """One scene, sample count, set of pixels and mode: the figures of a line of the table."""

    scene: str
    pixels: str
    kept: float  # share of the pixels measured
    spp: int
    seeds: int
    raw_error: float  # RMS over seeds
    raw_seconds: float  # measured, the mean over seeds
    mode: str  # one of MODES
    error: float  # the denoised images', RMS over seeds
    denoise_seconds: float  # mean seconds of the denoise: the passes' render (guided) and the filter
    raw_bias: float  # the control: the raw renders' bias estimate
    bias: float  # the denoised images' bias estimate
    timing: tuple = (0.0, 0.0)  # (fixed, per sample): the line fitted to the raw renders' seconds

    def render_seconds(self, spp: float) -> float:
        """A raw render's seconds at `spp` samples per pixel, read from the fitted line."""
        fixed, per_sample = self.timing
        return fixed + per_sample * spp

    @property
    def raw_spp_to_match(self) -> float:
        """The samples per pixel the raw render would need to reach the denoised error: spp (e_raw / e_den)^2."""
        if not (self.error > 0.0 and math.isfinite(self.raw_error)):
            return math.inf
        return self.spp * (self.raw_error / self.error) ** 2

    @property
    def raw_time_to_match(self) -> float:
        """The seconds of a raw render of `raw_spp_to_match` samples (the fitted line)."""
        return self.render_seconds(self.raw_spp_to_match)

    @property
    def seconds(self) -> float:
        """The denoised image's seconds: its render's (the fitted line) and the denoise."""
        return self.render_seconds(self.spp) + self.denoise_seconds

    @property
    def gain(self) -> float:
        """The raw render's time to the denoised error over the denoised image's time."""
        return self.raw_time_to_match / self.seconds if self.seconds > 0 else math.nan


def fit_timing(spps, seconds) -> tuple[float, float]:
    """(fixed, per sample) of the line fixed + per_sample x spp nearest `seconds` at `spps` in least
    squares, the fixed part at least 0 (else the line through 0); one sample count gives the line through 0."""
    x, y = np.asarray(spps, float), np.asarray(seconds, float)
    if len(set(x.tolist())) >= 2:
        per_sample, fixed = np.polyfit(x, y, 1)
        if fixed >= 0.0 and per_sample > 0.0:
            return float(fixed), float(per_sample)
    return 0.0, float(np.dot(x, y) / np.dot(x, x))


def bias_estimate(errors: list[float], mean_error: float) -> float:
    """The relative RMS bias from n renders' true errors and the error of their mean image:
    sqrt(max(0, (n E_mean^2 - E^2) / (n - 1))), E^2 the mean squared error (see the module's text)."""
    n = len(errors)
    if n < 2:
        return math.nan
    squared = sum(e * e for e in errors) / n
    return math.sqrt(max(0.0, (n * mean_error**2 - squared) / (n - 1)))


def run_trials(graph, flat, spps, seeds: int) -> list[Trial]:
    """`seeds` renders of the flattened scene at each of `spps`, each denoised in every way of
    MODES (the passes rendered once per render, with its seed, their seconds counted in each way
    that reads them)."""
    from renderer.render import render
    from renderer.tracing.aux_passes import render_aux

    from rt.denoise import denoise
    from rt.denoised_files import PASS_SAMPLES

    width, height = graph.image.width, graph.image.pixel_height
    trials = []
    for spp in spps:
        for index in range(seeds):
            seed = SEED_BASE + 1000 * spp + index
            started = time.perf_counter()
            result = render(graph, flat=flat, samples=spp, seed=seed, kernel=KERNEL)
            render_seconds = time.perf_counter() - started
            raw = result.film.mean()
            images, seconds = {"raw": raw}, {}
            started = time.perf_counter()
            aux = render_aux(flat, width, height, samples=PASS_SAMPLES, seed=seed)
            pass_seconds = time.perf_counter() - started
            for mode, (guided, clean) in MODES.items():
                started = time.perf_counter()
                images[mode] = denoise(raw, aux["albedo"], aux["normal"], clean_aux=clean) if guided else denoise(raw)
                seconds[mode] = time.perf_counter() - started + (pass_seconds if guided else 0.0)
            trials.append(Trial(spp, seed, render_seconds, seconds, images))
    return trials


def measure(scene: str, trials: list[Trial], reference, keep: np.ndarray, pixels: str) -> list[Row]:
    """The rows of one scene on one set of pixels (`keep`, a (h, w) mask), from its trials."""
    from caustics import masked

    from tests.renderer.converged import true_error

    truth = masked(reference, keep)
    spps = sorted({t.spp for t in trials})
    timing = fit_timing(spps, [np.mean([t.render_seconds for t in trials if t.spp == spp]) for spp in spps])
    rows = []
    for spp in spps:
        at = [t for t in trials if t.spp == spp]
        raw_errors = [true_error(t.images["raw"][keep], truth) for t in at]
        raw_rms = math.sqrt(sum(e * e for e in raw_errors) / len(at))
        raw_mean_error = true_error(np.mean([t.images["raw"] for t in at], axis=0)[keep], truth)
        raw_seconds = sum(t.render_seconds for t in at) / len(at)
        for mode in [m for m in MODES if m in at[0].images]:
            errors = [true_error(t.images[mode][keep].astype(np.float64), truth) for t in at]
            mean_error = true_error(np.mean([t.images[mode].astype(np.float64) for t in at], axis=0)[keep], truth)
            rows.append(Row(scene, pixels, float(np.mean(keep)), spp, len(at), raw_rms, raw_seconds, mode,
                            math.sqrt(sum(e * e for e in errors) / len(at)),
                            sum(t.denoise_seconds[mode] for t in at) / len(at),
                            bias_estimate(raw_errors, raw_mean_error), bias_estimate(errors, mean_error), timing))
    return rows


def modes_table(rows: list[Row]) -> list[str]:
    """The three ways of denoising side by side, errors only: a line per scene and sample count of
    `rows` (one set of pixels)."""
    modes = [m for m in MODES if any(r.mode == m for r in rows)]
    lines = ["| scene | spp | raw error | " + " | ".join(f"denoised: {NAMES[m]}" for m in modes) + " |",
             "|---|---|---|" + "---|" * len(modes)]
    for key in dict.fromkeys((r.scene, r.spp) for r in rows):
        mine = {r.mode: r for r in rows if (r.scene, r.spp) == key}
        first = next(iter(mine.values()))
        lines.append(f"| {key[0]} | {key[1]} | {first.raw_error:.4f} | "
                     + " | ".join(f"{mine[m].error:.4f}" if m in mine else "" for m in modes) + " |")
    return lines


def table(rows: list[Row]) -> list[str]:
    """The markdown table of `rows` (one set of pixels, one way of denoising)."""
    lines = ["| scene (pixels kept) | spp | raw error | raw s | denoised from | denoised error | denoise s | denoised s "
             "| raw spp to that error | raw s to that error | gain at equal time | bias: raw (control) | bias: denoised |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.scene} ({r.kept:.0%}) | {r.spp} | {r.raw_error:.4f} | {r.raw_seconds:.3f} | "
                     f"{NAMES[r.mode]} | {r.error:.4f} | {r.denoise_seconds:.3f} | "
                     f"{r.seconds:.3f} | {r.raw_spp_to_match:.0f} | {r.raw_time_to_match:.3g} | {r.gain:.3g} | "
                     f"{r.raw_bias:.4f} | {r.bias:.4f} |")
    return lines


def timing_line(rows: list[Row]) -> str:
    """The fitted line of each scene's raw render seconds, as a sentence."""
    fits = {r.scene: r.timing for r in rows}
    return "Raw renders' seconds fitted as fixed + per sample x spp: " + "; ".join(
        f"{scene} {fixed:.3f} s + {1000 * per:.2f} ms x spp" for scene, (fixed, per) in fits.items()) + "."


def section(rows: list[Row], seeds: int, seconds: float, full: Optional[FullSize] = None) -> list[str]:
    """The generated part of docs/accuracy.md's "Denoising" section: how it was measured, the ways
    of denoising side by side on the unlit pixels, then the shipped way's table per set of pixels."""
    from rt.denoised_files import PASS_SAMPLES

    from importlib.metadata import version as package_version

    import pyoidn

    scenes = ", ".join(dict.fromkeys(r.scene for r in rows))
    spps = ", ".join(str(s) for s in sorted({r.spp for r in rows}))
    version = f"{package_version('pyoidn')} (Open Image Denoise {pyoidn.version.oidn_version})"
    lines = [f"Measured with `python benchmarks/denoise_error.py --write-doc` on {platform.machine()}, {os.cpu_count()} "
             f"cores, in {seconds:.0f} s: {scenes} at 48 pixels wide, {spps} samples per pixel, {seeds} seeds each, "
             f"the general kernel; pyoidn {version}, the RT filter with hdr on, from the colour alone and guided by "
             f"the albedo and normal passes ({PASS_SAMPLES} camera rays per pixel), prefiltered by OIDN or read as "
             "they are (cleanAux). Errors are relative RMS against the converged reference, RMS over the seeds. *Raw s* is the raw "
             "renders' measured wall seconds; *denoise s* the denoise's (the passes' render included where guided); "
             "*denoised s* the fitted render seconds at its samples plus the denoise; *raw spp to that error* is "
             "spp x (raw error / denoised error)^2 and *raw s to that error* the fitted seconds of a render of that "
             "many; *gain at equal time* is that over the denoised image's seconds. *Bias* is the part of the "
             "error the mean over the seeds keeps, sqrt((n E_mean^2 - E^2) / (n - 1)); the raw renders' own figure "
             "is the control: near 0 where the seeds saw the scene's light, well above it where they all missed "
             "its rare bright paths (then neither figure is a bias). " + timing_line(rows)
             + ("" if full is None else " " + full.sentence()),
             ""]
    unlit = "pixels that see no light nor the background and are not brighter than 1 (benchmarks/light_pixels.py)"
    lines += [f"**The ways of denoising**, unlit pixels: {unlit}. `rt render --denoise` reads the passes as they are.", ""]
    lines += modes_table([r for r in rows if r.pixels == PIXELS[0]]) + [""]
    for pixels in PIXELS:
        mine = [r for r in rows if r.pixels == pixels and r.mode == SHIPPED]
        if not mine:
            continue
        what = unlit if pixels == "unlit" else "every pixel"
        lines += [f"**{pixels.capitalize()} pixels**, denoised as `rt render --denoise` does: {what}.", ""] + table(mine) + [""]
    return lines


@dataclass
class FullSize:
    """What a denoise costs at a scene's own size, against a sample per pixel of its render."""

    scene: str
    width: int
    height: int
    per_sample: float  # seconds of one more sample per pixel of the render
    passes: float  # seconds of the albedo and normal passes (PASS_SAMPLES camera rays per pixel)
    filter: float  # seconds of the filter

    def sentence(self) -> str:
        samples = (self.passes + self.filter) / self.per_sample if self.per_sample > 0 else math.nan
        return (f"At {self.scene}'s own size, {self.width}x{self.height}, the passes took {self.passes:.2f} s and the filter "
                f"{self.filter:.2f} s, against {self.per_sample:.2f} s per sample per pixel of the render: the denoise costs "
                f"as much as {samples:.1f} samples per pixel there, where at 48 pixels wide it costs as much as the table's "
                "*denoise s* over the fitted per-sample seconds.")


def full_size_cost(stem: str) -> FullSize:
    """The seconds of the passes and the filter at `stem`'s own size, and of one sample per pixel of
    its render (the difference of a 4-spp and a 1-spp render over 3: their fixed cost cancels)."""
    from renderer.compile import compile_scene
    from renderer.render import render
    from renderer.tracing.aux_passes import render_aux

    from rt.denoise import denoise
    from rt.denoised_files import PASS_SAMPLES
    from scenefmt.validation import load
    from tests.renderer.converged import scene_file

    graph = load(scene_file(stem)).graph
    flat = compile_scene(graph)
    width, height = graph.image.width, graph.image.pixel_height
    seconds = {}
    for spp in (1, 4):
        started = time.perf_counter()
        image = render(graph, flat=flat, samples=spp, seed=SEED_BASE, kernel=KERNEL).film.mean()
        seconds[spp] = time.perf_counter() - started
    started = time.perf_counter()
    aux = render_aux(flat, width, height, samples=PASS_SAMPLES)
    passes = time.perf_counter() - started
    started = time.perf_counter()
    denoise(image, aux["albedo"], aux["normal"], clean_aux=True)
    return FullSize(stem, width, height, (seconds[4] - seconds[1]) / 3, passes, time.perf_counter() - started)


def write_doc(lines: list[str], path: Path = DOC) -> None:
    """Put `lines` between BEGIN and END in `path` (atomically), adding the section at the end of the
    page where it has none; the text around the markers stays."""
    from renderer.film import _atomic_write

    text = path.read_text(encoding="utf-8") if path.exists() else ""
    if BEGIN in text and END in text.split(BEGIN, 1)[1]:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
    else:
        head, tail = text.rstrip("\n") + f"\n\n{HEADING}\n\n", "\n"
    data = (head + BEGIN + "\n" + "\n".join(lines).rstrip("\n") + "\n" + END + tail).encode("utf-8")
    _atomic_write(path, lambda fh: fh.write(data))


def study(scenes, spps, seeds: int, progress=print) -> list[Row]:
    """Every scene's rows on every set of pixels."""
    from light_pixels import kept_pixels

    from renderer.compile import compile_scene
    from renderer.render import render
    from renderer.tracing.aux_passes import render_aux
    from rt.denoise import denoise
    from tests.renderer.converged import load_reference, scene_file, small_graph

    rows = []
    for stem in scenes:
        graph = small_graph(scene_file(stem))
        flat = compile_scene(graph)
        warm = render(graph, flat=flat, samples=1, kernel=KERNEL)  # compile or load the kernel before any clock
        denoise(warm.film.mean())  # the denoiser's device is made on its first call
        render_aux(flat, graph.image.width, graph.image.pixel_height, samples=1)  # and the passes' kernel compiled
        reference = load_reference(stem)
        started = time.perf_counter()
        trials = run_trials(graph, flat, spps, seeds)
        masks = {"unlit": kept_pixels(graph, reference.mean), "all": np.ones(reference.mean.shape[:2], bool)}
        for pixels in PIXELS:
            rows += measure(stem, trials, reference, masks[pixels], pixels)
        progress(f"{stem}: {len(trials)} renders in {time.perf_counter() - started:.0f} s")
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--spp", default=",".join(str(s) for s in SPPS), help="samples per pixel, comma-separated")
    parser.add_argument("--seeds", type=int, default=SEEDS, help="renders per scene and sample count (2 or more)")
    parser.add_argument("--full-size", default=SCENES[0], metavar="SCENE",
                        help="the scene whose denoise is also timed at its own size ('' for none)")
    parser.add_argument("--write-doc", nargs="?", const=str(DOC), default=None, metavar="PATH",
                        help="write the tables into docs/accuracy.md (or PATH) between the markers")
    args = parser.parse_args(argv)
    if args.seeds < 2:
        parser.error("--seeds: the bias needs 2 or more")
    spps = tuple(int(s) for s in args.spp.split(","))
    started = time.perf_counter()
    rows = study(args.scenes.split(","), spps, args.seeds, progress=lambda line: print(line, flush=True))
    full = full_size_cost(args.full_size) if args.full_size else None
    seconds = time.perf_counter() - started
    lines = section(rows, args.seeds, seconds, full)
    print("\n" + "\n".join(lines))
    if args.write_doc:
        write_doc(lines, Path(args.write_doc))
        print(f"wrote {args.write_doc}")
    print(f"{seconds:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
