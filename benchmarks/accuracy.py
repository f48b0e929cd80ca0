"""The accuracy-versus-time study behind docs/accuracy.md.

    python benchmarks/accuracy.py [--scenes cornell_box,final_scene] [--no-plots]
    python benchmarks/accuracy.py --reported-only [--scenes ...]   # print the first table, write nothing

For each scene (the shipped ones and benchmarks/scenes/) at a small size (48 pixels wide), against
its converged reference (tests/renderer/converged/, two independent renders; see
tests/renderer/converged.py): the error rt reports, with its interval and warning, against the true
error at 16, 64 and 256 samples per pixel over several seeds; the true error against samples per
pixel and seconds, with the fitted log-log slope (Monte Carlo predicts -0.5); the two integrators;
the bias and time of limiting the path depth; the cost of resolution; the BVH against brute force;
and, from the measured error, how many samples and seconds each scene needs at its own size for a
target. Writes docs/accuracy.md (and plots in docs/accuracy/ when matplotlib is installed: pip
install '.[docs]').
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
WIDTH = 48
DEPTHS = (1, 2, 3, 4, 6, 8, 12, 16, 50)
TARGETS = (0.10, 0.05, 0.02, 0.01)
# The reported-against-true trials: (samples per pixel, seeds), as the coverage test renders them
# (tests/test_error_coverage.py), so the page shows what the test checks.
REPORTED_TRIALS = ((16, 8), (64, 4), (256, 2))
# Every render uses the one general kernel: a single compile serves the whole study (a kernel
# specialised to a scene is about 5% faster: renderer/variants.py, SPECIALISED_GAIN).
KERNEL = "general"


def rms_relative(image, reference):
    return float(np.sqrt(np.sum((image - reference) ** 2) / np.sum(reference**2)))


def fit_slope(xs, ys):
    lx, ly = np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float))
    slope, _ = np.polyfit(lx, ly, 1)
    return float(slope)


def study_scene(path, trials):
    """The true error against samples and seconds, from the reported-against-true trials: at each
    sample count, the RMS over seeds of the true error, the mean seconds and the mean reported
    figure, and the log-log slopes of that RMS against spp and seconds.

    The RMS over seeds, not one render's error: a render's expected squared error is the variance
    per sample over the spp on every scene, so the RMS falls as 1/sqrt(spp); one render of a scene
    lit through rare bright paths usually misses them at few samples, and its error then falls far
    slower (one seed gave sky_spheres a slope of -0.18 against its converged reference, as the
    4096-spp reference did before)."""
    from tests.renderer.converged import load_reference

    ref = load_reference(path.stem)
    rows = []
    for spp, _ in REPORTED_TRIALS:
        at = [r for r in trials if r[0] == spp]
        rows.append((spp, sum(r[2] for r in at) / len(at), math.sqrt(sum(r[3] ** 2 for r in at) / len(at)),
                     sum(r[4] for r in at) / len(at)))
    slope_spp = fit_slope([r[0] for r in rows], [r[2] for r in rows])
    return {"rows": rows, "slope_spp": slope_spp,
            "reference": ref.mean, "reference_var": ref.var, "ref": ref}


def reported_trials(path, graph_small):
    """Per trial of REPORTED_TRIALS: (spp, seed, seconds, true error, reported figure, low, high,
    warning). `low`, `high` and `warning` are None where the estimate has no such field (rt before
    issue 32 reported one figure)."""
    from renderer.film import estimate_noise
    from renderer.render import render

    from tests.renderer.converged import load_reference, true_error

    ref = load_reference(path.stem)
    rows = []
    for spp, seeds in REPORTED_TRIALS:
        for index in range(seeds):
            seed = 1000 * spp + index  # the coverage test's seeds
            result = render(graph_small, samples=spp, seed=seed, kernel=KERNEL)
            estimate = estimate_noise(result.film)
            rows.append((spp, seed, result.stats.seconds, true_error(result.film.mean(), ref), estimate.relative_rms,
                         getattr(estimate, "low", None), getattr(estimate, "high", None),
                         getattr(estimate, "warning", None) or getattr(result.stats, "noise_warning", None)))
    return rows


def reported_summary(rows, spp):
    """(seeds, RMS true error, mean reported figure, mean low, mean high, covered, warned) at `spp`:
    a trial is covered when its interval holds the true error; warned trials are not counted as covered."""
    at = [r for r in rows if r[0] == spp]
    truth = math.sqrt(sum(r[3] ** 2 for r in at) / len(at))
    figure = sum(r[4] for r in at) / len(at)
    has_interval = all(r[5] is not None and r[6] is not None for r in at)
    low = sum(r[5] for r in at) / len(at) if has_interval else None
    high = sum(r[6] for r in at) / len(at) if has_interval else None
    warned = sum(1 for r in at if r[7])
    covered = sum(1 for r in at if has_interval and not r[7] and r[5] <= r[3] <= r[6])
    return len(at), truth, figure, low, high, covered, warned


def reported_table(trials) -> list[str]:
    """The page's first table: for each scene and sample count, the true error beside what rt reports."""
    lines = ["| scene | spp | seeds | true error (RMS over seeds) | reported (mean) | interval (mean) | covered | warned | ratio true / reported |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, rows in trials.items():
        for spp, _ in REPORTED_TRIALS:
            n, truth, figure, low, high, covered, warned = reported_summary(rows, spp)
            interval = f"{low:.4f} to {high:.4f}" if low is not None else "none"
            cov = f"{covered}/{n}" if low is not None else "-"
            ratio = truth / figure if figure > 0 else float("nan")
            lines.append(f"| {name} | {spp} | {n} | {truth:.4f} | {figure:.4f} | {interval} | {cov} | {warned}/{n} | {ratio:.2f} |")
    return lines


# The adaptive study: a noise target every scene reaches at 48 px in seconds, and the cap for those lit
# through rare paths (which do not reach it in any sensible time); seeds per scene.
ADAPTIVE_TARGET = 0.02
ADAPTIVE_CAP = 4096
ADAPTIVE_SEEDS = 2


def adaptive_runs(graphs) -> dict:
    """Per scene and seed: a render toward ADAPTIVE_TARGET as `rt render --noise` renders it (adaptive
    sampling on), with the first forecast its session made after the pilot; a uniform render of the same
    seconds with each sampler; the true errors against the converged reference."""
    from renderer.compile import with_sampler
    from renderer.render import render

    from tests.renderer.converged import load_reference, true_error

    runs = {}
    for name, (_graph, small) in graphs.items():
        ref = load_reference(name)
        rows = []
        for index in range(ADAPTIVE_SEEDS):
            seed = 9000 + index
            first = []

            def keep_first(stats, first=first):
                if not first and getattr(stats, "forecast", None) is not None:
                    first.append((stats.forecast, stats.seconds))

            ada = render(small, samples=ADAPTIVE_CAP, seed=seed, noise_target=ADAPTIVE_TARGET, adaptive=True,
                         kernel=KERNEL, progress=keep_first)
            seconds = ada.stats.seconds
            uniform = render(small, samples=ADAPTIVE_CAP, seed=seed, time_budget=seconds, kernel=KERNEL)
            sobol = render(with_sampler(small, "sobol"), samples=ADAPTIVE_CAP, seed=seed, time_budget=seconds, kernel=KERNEL)
            sobol_ada = render(with_sampler(small, "sobol"), samples=ADAPTIVE_CAP, seed=seed, time_budget=seconds,
                               noise_target=ADAPTIVE_TARGET / 4, adaptive=True, kernel=KERNEL)
            rows.append({"seconds": seconds, "samples": float(ada.film.counts.mean()), "stop": ada.stats.stop_reason,
                         "forecast": first[0] if first else None,
                         "error": true_error(ada.film.mean(), ref), "uniform": true_error(uniform.film.mean(), ref),
                         "sobol": true_error(sobol.film.mean(), ref), "sobol_adaptive": true_error(sobol_ada.film.mean(), ref)})
        runs[name] = rows
    return runs


_ADAPTIVE_RUNS: dict = {}


def adaptive_runs_once(graphs) -> dict:
    """`adaptive_runs`, rendered once for the two sections that read them."""
    if not _ADAPTIVE_RUNS:
        _ADAPTIVE_RUNS.update(adaptive_runs(graphs))
    return _ADAPTIVE_RUNS


def forecast_section(graphs, results) -> list[str]:
    """The forecast of the time to a noise target against the time the render took, per scene: the
    first forecast the render's session made after its pilot (what the progress line says), the
    samples and seconds it took."""
    runs = adaptive_runs_once(graphs)
    lines = ["## The forecast against the time taken",
             "",
             f"Each scene at {WIDTH} px toward {100 * ADAPTIVE_TARGET:g}% noise with adaptive sampling (as `rt render --noise "
             f"{ADAPTIVE_TARGET:g}` renders; capped at {ADAPTIVE_CAP} spp), {ADAPTIVE_SEEDS} seeds: the first forecast after the "
             "pilot (renderer/forecast.py) with its 95% range, against what the render took. Renders of a fraction of a "
             "second are timed poorly on a shared machine: the samples' forecast is the firmer figure. "
             "[forecast.md](forecast.md) measures it at 200 px on five scenes.",
             "",
             "| scene | seed | forecast: mean spp (range) | took | forecast: seconds (range) | took | stopped on | held |",
             "|---|---|---|---|---|---|---|---|"]
    for name, rows in runs.items():
        for index, row in enumerate(rows):
            found = row["forecast"]
            if found is None:
                lines.append(f"| {name} | {index} | (ended before its pilot) | {row['samples']:.0f} | - | {row['seconds']:.2f} | "
                             f"{row['stop']} | - |")
                continue
            f, _at = found
            held = "yes" if f.seconds_low <= row["seconds"] <= f.seconds_high else "no"
            lines.append(f"| {name} | {index} | {f.samples:.0f} ({f.samples_low:.0f}-{f.samples_high:.0f}) | {row['samples']:.0f} | "
                         f"{f.seconds:.2f} ({f.seconds_low:.2f}-{f.seconds_high:.2f}) | {row['seconds']:.2f} | {row['stop']} | {held} |")
    return lines


# The sampler study: sample counts and seeds per sampler and scene (each seed's true error against the
# converged reference; the RMS over seeds is the sampler's error).
SAMPLER_TRIALS = ((64, 4), (256, 2))


def sampler_gain_section(graphs, results) -> list[str]:
    """The Owen-scrambled Sobol sampler against the independent one, per scene, at equal samples and
    at equal time: error_independent / error_sobol, the second divided by the square root of the
    ratio of their rendering seconds (as if each error fell as one over the square root of the time)."""
    from renderer.compile import with_sampler
    from renderer.render import render

    from tests.renderer.converged import load_reference, true_error

    lines = ["## The Sobol sampler against the independent one",
             "",
             "`image.sampler: sobol` (renderer/numerics/sobol.py: Owen-scrambled Sobol points in pairs of dimensions, one "
             "independent scramble per batch) against the books' independent numbers, at "
             + " and ".join(f"{spp} spp ({n} seeds)" for spp, n in SAMPLER_TRIALS)
             + ". *Gain* is the independent sampler's true error over Sobol's (RMS over the seeds, against the converged "
             "reference); *at equal time* divides it by the square root of Sobol's time over the independent sampler's. "
             "The images are too small for a precise timing (tenths of a second): `benchmarks/sampler_gain.py` measures "
             "the gains with more seeds and without a reference.",
             "",
             "| scene | " + " | ".join(f"gain at {spp} spp | at equal time" for spp, _ in SAMPLER_TRIALS) + " |",
             "|---|" + "---|---|" * len(SAMPLER_TRIALS)]
    for name, (_graph, small) in graphs.items():
        ref = load_reference(name)
        cells = []
        for spp, seeds in SAMPLER_TRIALS:
            errors, seconds = {}, {}
            for sampler in ("independent", "sobol"):
                graph = with_sampler(small, sampler)
                squared, spent = 0.0, 0.0
                for index in range(seeds):
                    result = render(graph, samples=spp, seed=7000 + 100 * spp + index, kernel=KERNEL)
                    squared += true_error(result.film.mean(), ref) ** 2
                    spent += result.stats.seconds
                errors[sampler], seconds[sampler] = math.sqrt(squared / seeds), spent
            gain = errors["independent"] / errors["sobol"] if errors["sobol"] > 0 else float("nan")
            timed = gain / math.sqrt(seconds["sobol"] / seconds["independent"]) if seconds["independent"] > 0 else float("nan")
            cells += [f"{gain:.2f}", f"{timed:.2f}"]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def adaptive_gain_section(graphs, results) -> list[str]:
    """Adaptive sampling, and the Sobol sampler with it, against uniform sampling with independent numbers
    at equal time, per scene (the renders of `adaptive_runs`)."""
    runs = adaptive_runs_once(graphs)
    lines = ["## Adaptive sampling at equal time",
             "",
             f"The renders of the forecast's table: adaptive sampling toward {100 * ADAPTIVE_TARGET:g}% (docs/adaptive.md), "
             "then uniform renders of the same seconds (`--time`): with the independent sampler, with Sobol, and Sobol with "
             "adaptive sampling (a lower target, so that the time decides). *Gain* is the uniform independent render's true "
             f"error over the other's (RMS over {ADAPTIVE_SEEDS} seeds). Scenes whose noise is even gain nothing from "
             "adaptive sampling; those with flat and noisy parts (a lamp's edge, smoke, a dark background) gain most. "
             "`benchmarks/adaptive_gain.py` measures it with more seeds on four scenes.",
             "",
             "| scene | seconds | mean spp | true error, uniform | gain: adaptive | gain: Sobol | gain: Sobol + adaptive |",
             "|---|---|---|---|---|---|---|"]

    def rms(rows, key):
        return math.sqrt(sum(r[key] ** 2 for r in rows) / len(rows))

    for name, rows in runs.items():
        uniform = rms(rows, "uniform")
        gains = [uniform / rms(rows, key) if rms(rows, key) > 0 else float("nan") for key in ("error", "sobol", "sobol_adaptive")]
        lines.append(f"| {name} | {sum(r['seconds'] for r in rows) / len(rows):.2f} | {sum(r['samples'] for r in rows) / len(rows):.0f} | "
                     f"{uniform:.4f} | " + " | ".join(f"{g:.2f}x" for g in gains) + " |")
    return lines


def depth_study(graph_small, reference):
    from renderer.render import render

    out = []
    for depth in DEPTHS:
        result = render(graph_small, samples=256, seed=7, max_depth=depth, kernel=KERNEL)
        bias = float(result.film.mean().mean() / reference.mean() - 1.0)
        out.append((depth, result.stats.seconds, bias))
    return out


def resolution_study(graph):
    from renderer.compile import with_width
    from renderer.render import render

    out = []
    for width in (32, 64, 128, 256):
        g = with_width(graph, width)
        result = render(g, samples=16, seed=7, kernel=KERNEL)
        pixels = g.image.width * g.image.pixel_height
        out.append((width, g.image.pixel_height, result.stats.seconds, 1e9 * result.stats.seconds / (pixels * 16)))
    return out


def bvh_study(graph_small):
    from renderer.compile import compile_scene
    from renderer.render import render

    brute_flat = compile_scene(graph_small, use_bvh=False)
    render(graph_small, samples=1, flat=brute_flat, kernel=KERNEL)
    with_bvh = render(graph_small, samples=16, seed=7, kernel=KERNEL)
    brute = render(graph_small, samples=16, seed=7, flat=brute_flat, kernel=KERNEL)
    same = bool(np.array_equal(with_bvh.film.total, brute.film.total))
    return with_bvh.stats.seconds, brute.stats.seconds, same, int(brute_flat.prims_i.shape[0])


INTEGRATOR_SCENES = ("cornell_box", "cornell_smoke", "final_scene", "simple_light")
INTEGRATOR_SPP = (4, 16, 64, 256)


def integrator_study(graph_small, result):
    """(integrator, spp, seconds, error) for both estimators against the scene's reference."""
    from renderer.compile import compile_scene, with_integrator
    from renderer.render import render

    from light_pixels import kept_pixels

    reference = result["reference"]
    # Pixels that see a light, wholly or in part, hold its radiance (the same for both) and, at its
    # edges, the noise of where in the pixel the light falls, which no light sampling changes: left out.
    keep = kept_pixels(graph_small, reference)
    ref_noise = float(np.sqrt(np.sum(result["reference_var"][keep]) / np.sum(reference[keep] ** 2)))
    rows = []
    for integrator in ("path", "mis"):
        g = with_integrator(graph_small, integrator)
        flat = compile_scene(g)
        render(g, flat=flat, samples=1, kernel=KERNEL)  # kernels loaded before timing
        for spp in INTEGRATOR_SPP:
            run = render(g, flat=flat, samples=spp, seed=7, kernel=KERNEL)
            error = rms_relative(run.film.mean()[keep], reference[keep])
            error = math.sqrt(max(error**2 - ref_noise**2, 0.0))
            rows.append((integrator, spp, run.stats.seconds, error))
    return rows


def equal_time_ratio(rows) -> float:
    """Error of `path` over error of `mis` at the time of mis's most samples (path's error moved
    to that time along the 1/sqrt(seconds) law from its own nearest measurement)."""
    mis = max((r for r in rows if r[0] == "mis"), key=lambda r: r[1])
    path = min((r for r in rows if r[0] == "path"), key=lambda r: abs(math.log(r[2] / mis[2])))
    return path[3] * math.sqrt(path[2] / mis[2]) / mis[3]


def plot_integrators(studies, out_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(exist_ok=True)
    fig, axes = plt.subplots(1, len(studies), figsize=(3.2 * len(studies), 3.2), squeeze=False)
    for ax, (name, rows) in zip(axes[0], studies.items()):
        for integrator, style in (("path", "o--"), ("mis", "s-")):
            pts = [(r[2], r[3]) for r in rows if r[0] == integrator]
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, ms=3, label=integrator)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("seconds (48 px wide)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("relative RMS error")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "integrators_error_vs_time.png", dpi=90)
    plt.close(fig)


def plot(results, out_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for name, r in results.items():
        rows = r["rows"]
        axes[0].loglog([x[0] for x in rows], [x[2] for x in rows], marker="o", ms=3, label=name)
        axes[1].loglog([x[1] for x in rows], [x[2] for x in rows], marker="o", ms=3, label=name)
    axes[0].set_xlabel("samples per pixel")
    axes[1].set_xlabel("seconds (48 px wide, 2 threads)")
    fig.suptitle("RMS over seeds of the true error", fontsize=9)
    for ax in axes:
        ax.set_ylabel("relative RMS error")
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=6, ncol=2)
    fig.tight_layout()
    fig.savefig(out_dir / "error_vs_spp_and_time.png", dpi=90)
    plt.close(fig)


def main() -> int:
    sys.path.insert(0, str(ROOT))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="")
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--reported-only", action="store_true",
                        help="print the reported-against-true table and stop (writes nothing)")
    args = parser.parse_args()
    from renderer.compile import with_width
    from renderer.render import render
    from scenefmt.validation import load

    from tests.renderer.converged import DEFAULT_SPP, SPP_BY_SCENE, scene_files

    paths = scene_files()
    if args.scenes:
        wanted = set(args.scenes.split(","))
        paths = [p for p in paths if p.stem in wanted]
    results, graphs, trials = {}, {}, {}
    started = time.perf_counter()
    for path in paths:
        graph = load(path).graph
        small = with_width(graph, WIDTH)
        render(small, samples=1, kernel=KERNEL)  # compile or load the kernels before timing
        graphs[path.stem] = (graph, small)
        trials[path.stem] = reported_trials(path, small)
        if args.reported_only:
            print("\n".join(reported_table({path.stem: trials[path.stem]})[2:]), flush=True)
            continue
        results[path.stem] = study_scene(path, trials[path.stem])
        print(f"{path.stem}: slope {results[path.stem]['slope_spp']:.3f}", flush=True)
    if args.reported_only:
        print(f"({time.perf_counter() - started:.0f} s)")
        return 0
    sweep_seconds = time.perf_counter() - started
    refs = {name: r["ref"] for name, r in results.items()}
    lines = [
        "# What accuracy costs in time",
        "",
        "<!-- Written by `python benchmarks/accuracy.py`; the figures below were measured by it. -->",
        "",
        f"Measured on {platform.machine()}, {__import__('os').cpu_count()} cores, with `python benchmarks/accuracy.py` "
        f"({sweep_seconds:.0f} s for the scene sweep; every render uses the general kernel). Each scene is rendered "
        f"{WIDTH} pixels wide. The truth is the scene's converged reference (`tests/renderer/converged/`, made by "
        f"`tests/renderer/converged.py`): two independent renders with seeds other than the study's, of {DEFAULT_SPP} "
        "samples per pixel each, and more on the scenes lit through rare bright paths ("
        + ", ".join(f"{name} {spp:,}" for name, spp in SPP_BY_SCENE.items()) + "). *Error* is the relative RMS error against it, sqrt(sum of squared differences / sum of squared "
        "reference values), with the reference's own expected squared error taken out; *reported* is what `rt render` "
        "reports, computed from the render's own samples. `caustic_glass` is not shipped: it is the benchmark scene "
        "`benchmarks/scenes/caustic_glass.yaml`, a glass sphere focusing a small, bright lamp onto a matte floor.",
        "",
        "## The error rt reports against the true error",
        "",
        "Each scene at 16, 64 and 256 samples per pixel, over "
        + ", ".join(f"{n} seeds at {spp}" for spp, n in REPORTED_TRIALS)
        + " (`tests/test_error_coverage.py` renders the first seeds of these and checks that the interval holds the "
        "true error at its stated rate or the warning fires). *Interval* is the mean of the reported bounds; *covered* counts the renders "
        "whose interval holds their true error, without a warning; *warned* counts those where rt said its estimate "
        "could not be trusted. A ratio of true over reported near 1 is an honest figure; well above 1, the report is "
        "too optimistic.",
        "",
    ]
    lines += reported_table(trials)
    lines += ["", "The references' own error (one render's, from the difference of the two) beside a 256 spp render's "
              "true error, as the coverage test measures it from all the scene's renders above (the mean of error^2 x spp "
              "over them, / 256: a render's expected squared error is the variance per sample over its spp): the test "
              "asks for at most a quarter.", "",
              "| scene | spp per reference | reference's own error | true error at 256 spp | share |", "|---|---|---|---|---|"]
    for name, ref in refs.items():
        rows = trials[name]
        at_256 = math.sqrt(sum(r[3] ** 2 * r[0] for r in rows) / len(rows) / 256)
        lines.append(f"| {name} | {ref.spp} | {ref.own_error():.4f} | {at_256:.4f} | "
                     f"{ref.own_error() / at_256 if at_256 > 0 else float('nan'):.2f} |")
    for section in (forecast_section, sampler_gain_section, adaptive_gain_section):
        found = section(graphs, results)
        if found:
            lines += [""] + found
    lines += [
        "",
        "## Error against samples and seconds",
        "",
        "Monte Carlo error falls as one over the square root of the samples: a log-log slope of -0.5. The slopes are "
        "fitted to the RMS over seeds of the true error at 16, 64 and 256 samples per pixel (the table above): a "
        "render's expected squared error is the variance per sample over the samples on every scene, so this RMS "
        "falls as 1/sqrt(spp) also where light arrives through rare bright paths (sky_spheres, material_spheres, "
        "caustic_glass). The error of ONE render of those scenes does not: at few samples it usually misses the rare "
        "paths and its error is then well below the RMS (sky_spheres, one seed at 4 to 256 spp: a slope of -0.18). "
        "Few seeds at 256 spp make the slopes move by a few hundredths.",
        "",
        "Against seconds the slope is not fitted: at 48 pixels a render of 16 samples takes a tenth of a second or "
        "less, and a render's fixed cost (its passes' start) weighs on it as much as the samples do.",
        "",
        "| scene | slope vs spp | seconds at 16 spp | seconds at 256 spp |",
        "|---|---|---|---|",
    ]
    for name, r in results.items():
        row16 = next(x for x in r["rows"] if x[0] == 16)
        row256 = next(x for x in r["rows"] if x[0] == 256)
        lines.append(f"| {name} | {r['slope_spp']:.3f} | {row16[1]:.2f} | {row256[1]:.2f} |")
    if not args.no_plots:
        try:
            plot(results, ROOT / "docs" / "accuracy")
            lines += ["", "![error against samples and seconds](accuracy/error_vs_spp_and_time.png)"]
        except ImportError:
            lines += ["", "(Plots need matplotlib: `pip install '.[docs]'`.)"]
    # The two integrators: error against seconds, on the scenes with lights.
    studies = {name: integrator_study(graphs[name][1], results[name]) for name in INTEGRATOR_SCENES if name in results}
    if studies:
        lines += ["", "## Integrators: light sampling against the books' estimator", "",
                  "The default integrator (`mis`) samples a point on a light at every diffuse or medium vertex and weighs "
                  "it against the path's own hits (multiple importance sampling); `path` is the books' estimator. Same "
                  "reference as above (rendered with `mis`; both converge to it); the error leaves out the pixels that see a "
                  "light, wholly or in part, and those brighter than 1 (their value is the light's, and their noise is where "
                  "in the pixel its edge falls, which light sampling does not change; `benchmarks/light_pixels.py`). *Ratio* is path's error over mis's at "
                  f"equal time (mis's time at {INTEGRATOR_SPP[-1]} spp). At full size, and against Mitsuba 3, see "
                  "[integrators.md](integrators.md) (`benchmarks/integrators.py`).", "",
                  "| scene | integrator | " + " | ".join(f"{n} spp: s, error" for n in INTEGRATOR_SPP) + " | ratio |",
                  "|---|---|" + "---|" * len(INTEGRATOR_SPP) + "---|"]
        for name, rows in studies.items():
            ratio = equal_time_ratio(rows)
            for integrator in ("path", "mis"):
                cells = [f"{r[2]:.2f}, {r[3]:.4f}" for r in rows if r[0] == integrator]
                lines.append(f"| {name} | {integrator} | " + " | ".join(cells) + f" | {ratio:.1f} |" if integrator == "mis"
                             else f"| {name} | {integrator} | " + " | ".join(cells) + " | |")
        if not args.no_plots:
            try:
                plot_integrators(studies, ROOT / "docs" / "accuracy")
                lines += ["", "![error against seconds, both integrators](accuracy/integrators_error_vs_time.png)"]
            except ImportError:
                pass
    # Max depth: bias against time, on two scenes where light bounces a lot.
    lines += ["", "## Max depth: bias against time", "",
              "Cutting paths short loses the light they would have gathered: the image gets darker but renders faster. "
              "Bias is the mean brightness relative to the reference, which uses the scene's own depth (so for the final "
              "scene, whose file keeps the book's quick depth of 4, deeper paths come out brighter). 256 spp.", ""]
    for name in [n for n in ("cornell_box", "final_scene", "weekend_glass") if n in results]:
        graph, small = graphs[name]
        rows = depth_study(small, results[name]["reference"])
        lines += [f"**{name}** (scene depth {graph.image.max_depth})", "", "| max depth | seconds | bias |", "|---|---|---|"]
        lines += [f"| {d} | {s:.2f} | {100 * b:+.2f}% |" for d, s, b in rows]
        lines.append("")
    # Resolution.
    if "cornell_box" in results:
        graph, _ = graphs["cornell_box"]
        lines += ["## Resolution", "", "Time grows with the number of pixels; the noise per pixel at a given spp does not "
                  "change with resolution. Cornell box, 16 spp.", "",
                  "| size | seconds | ns per sample |", "|---|---|---|"]
        lines += [f"| {w}x{h} | {s:.2f} | {ns:.0f} |" for w, h, s, ns in resolution_study(graph)]
        lines.append("")
    # BVH against brute force.
    lines += ["## BVH against brute force", "", "Same seed and samples (16 spp, 48 px wide): the images are identical "
              "bit for bit; the BVH saves the time.", "", "| scene | primitives | BVH seconds | brute-force seconds | speed-up | identical |",
              "|---|---|---|---|---|---|"]
    for name in [n for n in ("weekend_cover", "cornell_box", "final_scene") if n in results]:
        _, small = graphs[name]
        t_bvh, t_brute, same, prims = bvh_study(small)
        lines.append(f"| {name} | {prims} | {t_bvh:.3f} | {t_brute:.3f} | {t_brute / t_bvh:.1f}x | {'yes' if same else 'NO'} |")
    lines += ["", "Renders use float64 throughout; there is no float32 mode to compare.", ""]
    # How to choose.
    lines += ["## How to choose", "",
              "Noise falls as 1/sqrt(spp), so the samples a target needs follow from the true error measured at 256 spp: "
              "spp = 256 x (noise at 256 / target)^2. Seconds scale that by the measured time per sample at 48 px and "
              "by the number of pixels of the scene's own size (as `rt render scenes/NAME.yaml` renders it) on this 2-core "
              "machine. `rt render --noise 0.02` does this for you: it stops when the estimate reaches the target.", "",
              "| scene (own size) | " + " | ".join(f"{int(100 * t)}%: spp, time" for t in TARGETS) + " |",
              "|---|" + "---|" * len(TARGETS)]
    for name, r in results.items():
        graph, small = graphs[name]
        spp_row = next(x for x in r["rows"] if x[0] == 256)
        noise256, secs256 = spp_row[2], spp_row[1]
        scale = (graph.image.width * graph.image.pixel_height) / (small.image.width * small.image.pixel_height)
        cells = []
        for target in TARGETS:
            spp = max(1, math.ceil(256 * (noise256 / target) ** 2))
            seconds = secs256 / 256 * spp * scale
            cells.append(f"{spp} spp, {_fmt(seconds)}")
        lines.append(f"| {name} ({graph.image.width}x{graph.image.pixel_height}) | " + " | ".join(cells) + " |")
    lines.append("")
    page = ROOT / "docs" / "accuracy.md"
    page.write_text("\n".join(lines) + denoising_section(page.read_text() if page.exists() else ""))
    print("wrote docs/accuracy.md")
    return 0


def denoising_section(page: str) -> str:
    """The page's "Denoising" section as it stands (benchmarks/denoise_error.py writes its tables
    between markers; the prose around them is written by hand), from its heading to the next
    heading of its level or the page's end, to append after this study's own sections: rewriting
    the page keeps it. Empty where the page has none."""
    from denoise_error import HEADING

    start = page.find("\n" + HEADING + "\n")
    if start < 0:
        return ""
    end = page.find("\n## ", start + len(HEADING) + 1)
    return page[start:] if end < 0 else page[start:end] + "\n"


def _fmt(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.1f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


if __name__ == "__main__":
    raise SystemExit(main())
