"""`rt`: a thin command line over scenefmt and the renderer (argument parsing and presentation only).

`rt validate` never imports the renderer or Numba, so it answers in a fraction of a second.
"""

from __future__ import annotations

import json
import os
import sys

# numpy's BLAS threads spin after a call; on a 2-core machine they would take a core from the
# renderer's own threads. The renderer does no heavy linear algebra, so one BLAS thread suffices.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
from pathlib import Path
from typing import List, Optional

import typer

app = typer.Typer(
    name="rt",
    help="Render declarative YAML/JSON scene files with a physically based path tracer.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _summary_lines(loaded) -> list[str]:
    from scenefmt.effects import summarize

    graph = loaded.graph
    summary = summarize(graph)
    image = graph.image
    counts = summary.shape_counts
    total = sum(counts.values())
    kinds = ", ".join(f"{n} {k}" for k, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
    lines = [f"  shapes: {total}" + (f" ({kinds})" if kinds else "")]
    if summary.instanced_shape_counts:
        inner = ", ".join(f"{n} {k}" for k, n in sorted(summary.instanced_shape_counts.items()))
        lines.append(f"  in groups: {inner}")
    defs = ", ".join(f"{n} {k}" for k, n in summary.definition_counts.items() if n)
    if defs:
        lines.append(f"  named: {defs}")
    lines.append(
        f"  image: {image.width}x{image.pixel_height}, {image.samples_per_pixel} spp, max depth {image.max_depth}, "
        f"seed {image.seed}; background {summary.background}"
    )
    lines.append("  effects:")
    lines += [f"    {effect}" for effect in summary.effects]
    return lines


def _tables_or_exit(outcome, scene: Path):
    """The (tables, frame) of a scene read by preload.read_scene, or its errors printed and exit 1."""
    kind, value = outcome
    if kind == "scene":
        for diag in value:
            typer.echo(str(diag), err=True)
        raise typer.Exit(1)
    if kind == "value":  # input the format cannot check, such as an unreadable image file
        typer.echo(f"error: {scene}: {value}", err=True)
        raise typer.Exit(1)
    return value


@app.command(
    epilog="Example: rt validate scenes/cornell_box.yaml scenes/quads.json --json",
)
def validate(
    files: List[Path] = typer.Argument(..., help="Scene files (YAML or JSON) to check.", show_default=False),
    as_json: bool = typer.Option(False, "--json", help="Print machine-readable results (one JSON document)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print only errors."),
) -> None:
    """Check scene files and summarise each valid one; exit 1 if any is invalid."""
    from scenefmt.diagnostics import SceneError
    from scenefmt.effects import summarize
    from scenefmt.validation import load

    results = []
    failed = False
    for path in files:
        try:
            loaded = load(path)
        except SceneError as exc:
            failed = True
            results.append({"file": str(path), "valid": False, "errors": [d.to_json() for d in exc.diagnostics], "warnings": []})
            if not as_json:
                for diag in exc.diagnostics:
                    typer.echo(str(diag), err=True)
                count = len(exc.diagnostics)
                typer.echo(f"{path}: invalid ({count} error{'s' if count != 1 else ''})", err=True)
            continue
        results.append(
            {
                "file": str(path),
                "valid": True,
                "errors": [],
                "warnings": [d.to_json() for d in loaded.warnings],
                "summary": summarize(loaded.graph).to_json(),
            }
        )
        if not as_json:
            for diag in loaded.warnings:
                typer.echo(str(diag), err=True)
            if not quiet:
                typer.echo(f"{path}: valid")
                for line in _summary_lines(loaded):
                    typer.echo(line)
    if as_json:
        typer.echo(json.dumps({"valid": not failed, "files": results}, indent=2))
    raise typer.Exit(1 if failed else 0)


BUDGET_SAMPLE_CAP = 1_000_000


def _parse_duration(text: str) -> Optional[float]:
    """Seconds in '45', '30s', '2m', '1h30m', '1.5h'; None if it is not a duration."""
    import re

    text = text.strip().lower()
    if re.fullmatch(r"\d+(\.\d+)?", text):
        return float(text)
    parts = re.findall(r"(\d+(?:\.\d+)?)([hms])", text)
    if not parts or "".join(n + u for n, u in parts) != text:
        return None
    return sum(float(n) * {"h": 3600, "m": 60, "s": 1}[u] for n, u in parts)


def _fmt_seconds(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, sec = divmod(int(round(seconds)), 60)
    return f"{minutes}m{sec:02d}s" if minutes < 60 else f"{minutes // 60}h{minutes % 60:02d}m"


class _Progress:
    """A one-line progress bar on standard error (a line per 10% when it is not a terminal)."""

    def __init__(self, total: int, seconds: Optional[float] = None, noise: Optional[float] = None):
        self.total = total
        self.seconds = seconds
        self.noise = noise
        self.tty = sys.stderr.isatty()
        self.last_decile = -1

    def __call__(self, stats) -> None:
        done = stats.samples
        frac = done / self.total if self.total else 1.0
        # Under a budget, progress is the share of the budget spent: time, or noise (which falls
        # as one over the square root of the samples).
        if self.seconds:
            frac = max(frac, stats.seconds / self.seconds)
        if self.noise and 0 < stats.noise < float("inf"):
            frac = max(frac, (self.noise / stats.noise) ** 2)
        frac = min(frac, 1.0)
        eta = stats.seconds / frac - stats.seconds if frac > 0 else 0.0
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        noise = f"  noise {100 * stats.noise:.2f}%" if stats.noise != float("inf") else ""
        line = (
            f"[{bar}] {done}/{self.total} spp  {_fmt_seconds(stats.seconds)} elapsed  "
            f"ETA {_fmt_seconds(eta)}  {stats.rays_per_second / 1e6:.2f} Mrays/s{noise}"
        )
        if self.tty:
            sys.stderr.write("\r" + line)
            sys.stderr.flush()
        elif int(frac * 10) > self.last_decile:
            self.last_decile = int(frac * 10)
            sys.stderr.write(line + "\n")

    def close(self) -> None:
        if self.tty:
            sys.stderr.write("\n")


@app.command(epilog="Example: rt render scenes/cornell_box.yaml -o cornell.png --spp 64 --hdr cornell.pfm")
def render(
    scene: Path = typer.Argument(..., help="Scene file (YAML or JSON) to render.", show_default=False),
    output: Optional[Path] = typer.Option(
        None, "--output", "-o", help="PNG file to write (default: the scene file's name with .png, in the current folder)."
    ),
    hdr: Optional[Path] = typer.Option(
        None, "--hdr", help="Also write the linear, unclamped image as a .pfm file (portable float map)."
    ),
    spp: Optional[int] = typer.Option(None, "--spp", min=1, max=1_000_000, help="Samples per pixel (overrides the file)."),
    width: Optional[int] = typer.Option(None, "--width", min=1, max=32768, help="Image width; the height keeps the aspect ratio."),
    max_depth: Optional[int] = typer.Option(None, "--max-depth", min=1, max=10_000, help="Most bounces per path."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Seed of the random numbers."),
    threads: Optional[int] = typer.Option(None, "--threads", min=1, help="Worker threads (default: all cores)."),
    time_budget: Optional[str] = typer.Option(
        None, "--time", help="Render in passes until this much time is spent (30s, 2m, 1h); --spp is then the cap."
    ),
    noise: Optional[float] = typer.Option(
        None, "--noise", min=0.0, help="Render until the estimated relative RMS noise is below this (0.02 = 2%); --spp is then the cap."
    ),
    noise_map: Optional[Path] = typer.Option(None, "--noise-map", help="Write the per-pixel noise estimate as a PNG."),
    save_state: Optional[Path] = typer.Option(
        None, "--save-state", help="Save the render's sums (.npz) so it can be continued with --resume."
    ),
    resume: Optional[Path] = typer.Option(
        None, "--resume", help="Continue the render saved with --save-state, up to --spp samples in all."
    ),
    explain: bool = typer.Option(
        False, "--explain", help="Print which effects the scene uses, and the element that switches each on."
    ),
) -> None:
    """Render a scene to a PNG image (and optionally a linear HDR image and a noise map)."""
    import signal
    import time

    started = time.perf_counter()
    out = output if output is not None else Path(scene.stem + ".png")
    budget_seconds = None
    if time_budget is not None:
        budget_seconds = _parse_duration(time_budget)
        if budget_seconds is None:
            typer.echo(f"error: --time {time_budget!r}: expected a duration such as 30s, 2m, 1h30m or 45", err=True)
            raise typer.Exit(1)
    for path, allowed in ((out, (".png",)), (hdr, (".pfm",)), (noise_map, (".png",)), (save_state, (".npz",))):
        if path is not None and path.suffix.lower() not in allowed:
            typer.echo(f"error: {path}: the file name must end in {' or '.join(allowed)}", err=True)
            raise typer.Exit(1)
        if path is not None and not (path.parent if str(path.parent) else Path(".")).is_dir():
            typer.echo(f"error: {path}: the folder {path.parent} does not exist", err=True)
            raise typer.Exit(1)

    from .preload import SceneLoader, can_fork, read_scene

    # The scene's models are needed only to explain its effects, or for the fingerprint that
    # --resume and --save-state check. Otherwise a child process reads the scene while this one
    # imports Numba (see preload.py), and sends back only its tables.
    needs_models = explain or resume is not None or save_state is not None
    loader = SceneLoader(scene, width) if not needs_models and can_fork() else None
    if loader is None:
        # Read here, before Numba loads: an invalid scene is reported at once.
        outcome, loaded = read_scene(scene, width)
        tables, frame = _tables_or_exit(outcome, scene)
    try:
        import numba

        from renderer.assemble import assemble
        from renderer.bvh import load_builders
        from renderer.film import estimate_noise, noise_map_image, write_image
        from renderer.render import kernels_cached, render_flat
        from renderer.variants import features_of

        if loader is not None:
            load_builders()
            outcome = loader.result()
    finally:
        if loader is not None:
            loader.close()
    if loader is not None:
        # (The scene's models, `loaded`, are used only where no child was started.)
        if outcome is None:  # the child gave no answer: read the scene here
            outcome, _ = read_scene(scene, width)
        tables, frame = _tables_or_exit(outcome, scene)
    if explain:
        from scenefmt.effects import summarize

        for effect in summarize(loaded.graph).effects:
            typer.echo(f"{effect}", err=True)

    if threads is not None:
        if threads > numba.config.NUMBA_NUM_THREADS:
            typer.echo(f"error: --threads {threads}: at most {numba.config.NUMBA_NUM_THREADS} threads are available", err=True)
            raise typer.Exit(1)
        numba.set_num_threads(threads)
    budgeted = budget_seconds is not None or noise is not None
    # With a time or noise budget the sample count is only a cap.
    target = spp if spp is not None else (BUDGET_SAMPLE_CAP if budgeted else frame.samples)

    def render_key():
        # The scene's fingerprint (its canonical JSON, hashed) is only needed to resume or save a
        # render's state: 25 ms for the final scene that other renders need not pay.
        from renderer.state import RenderKey, scene_fingerprint
        from scenefmt.writing import dumps

        return RenderKey(
            scene_fingerprint(dumps(loaded.scene, "json")),
            frame.width,
            frame.height,
            max_depth if max_depth is not None else frame.max_depth,
            seed if seed is not None else frame.seed,
        )

    film = None
    if resume is not None:
        from renderer.state import load_state

        try:
            film = load_state(resume, render_key())
        except (OSError, ValueError, KeyError) as exc:
            typer.echo(f"error: --resume: {exc}", err=True)
            raise typer.Exit(1)
        typer.echo(f"resuming {resume}: {film.samples} samples per pixel already rendered", err=True)
    stop = {"requested": False}

    def on_interrupt(signum, _stack_frame):
        if stop["requested"]:
            raise KeyboardInterrupt
        stop["requested"] = True
        sys.stderr.write("\ninterrupted: finishing the current pass and saving what is rendered (Ctrl-C again to abort)\n")

    flat = assemble(tables)
    features = features_of(flat)
    if explain:
        typer.echo(f"kernel: {features.tag} (the paths compiled in; see docs/performance.md)", err=True)
    if not kernels_cached(features):
        typer.echo(
            f"compiling the renderer for this feature set ({features.tag}): 10 to 20 seconds on 2 cores, once; "
            f"cached in {numba.config.CACHE_DIR}",
            err=True,
        )
    previous = signal.signal(signal.SIGINT, on_interrupt)
    bar = _Progress(target, budget_seconds, noise)
    try:
        result = render_flat(
            flat, frame, samples=target, max_depth=max_depth, seed=seed, progress=bar, should_stop=lambda: stop["requested"],
            film=film, time_budget=budget_seconds, noise_target=noise, features=features,
        )
    except ValueError as exc:
        failure = str(exc)
    else:
        failure = None
    finally:
        bar.close()
        signal.signal(signal.SIGINT, previous)
    if failure is not None:
        typer.echo(f"error: {scene}: {failure}", err=True)
        raise typer.Exit(1)
    stats, film = result.stats, result.film
    if film.samples == 0:
        typer.echo("interrupted before the first pass finished: nothing to save", err=True)
        raise typer.Exit(130)
    image = film.mean()
    write_image(out, image)
    if hdr is not None:
        write_image(hdr, image)
    estimate = estimate_noise(film)
    if noise_map is not None:
        write_image(noise_map, noise_map_image(estimate))
    if save_state is not None:
        from renderer.state import save_state as write_state

        write_state(save_state, film, render_key())
    total = time.perf_counter() - started
    written = ", ".join(str(p) for p in (out, hdr, noise_map, save_state) if p is not None)
    typer.echo(
        f"wrote {written}: {film.width}x{film.height}, {film.samples} spp, {_fmt_seconds(stats.seconds)} rendering "
        f"({_fmt_seconds(total)} in all), {stats.rays / 1e6:.1f} M rays, {stats.rays_per_second / 1e6:.2f} Mrays/s"
    )
    wx, wy = estimate.worst_pixel
    if film.samples < 2:
        typer.echo("noise: not estimated (it takes at least 2 samples per pixel)")
    else:
        typer.echo(
            f"noise: {100 * estimate.relative_rms:.2f}% relative RMS (estimated from the samples); worst at pixel "
            f"({wx}, {wy}), {100 * estimate.worst_relative:.0f}% of its value"
        )
    if stats.stop_reason == "time":
        typer.echo(f"stopped: the {time_budget} time budget is spent", err=True)
    elif stats.stop_reason == "noise":
        typer.echo(f"stopped: the estimated noise {100 * stats.noise:.2f}% is below the {100 * noise:.2f}% target", err=True)
    elif budgeted and not stats.interrupted:
        typer.echo(f"stopped at the cap of {target} samples per pixel before the budget was reached", err=True)
    if stats.bad_samples:
        typer.echo(f"warning: {stats.bad_samples} samples were not finite and were left out (please report this scene)", err=True)
    if stats.interrupted:
        typer.echo(f"interrupted: the image holds {film.samples} of {target} samples per pixel", err=True)
        raise typer.Exit(130)


@app.command(epilog="Example: rt schema -o scene.schema.json")
def schema(
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write to this file instead of standard output."),
) -> None:
    """Print the JSON Schema (draft-07) of scene files, for editors and CI."""
    from scenefmt.schema_export import shipped_schema_text

    text = shipped_schema_text()
    if output is None:
        sys.stdout.write(text)
    else:
        output.write_text(text, encoding="utf-8")
        typer.echo(f"wrote {output}", err=True)


if __name__ == "__main__":
    app()
