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


def _fmt_seconds(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, sec = divmod(int(round(seconds)), 60)
    return f"{minutes}m{sec:02d}s" if minutes < 60 else f"{minutes // 60}h{minutes % 60:02d}m"


class _Progress:
    """A one-line progress bar on standard error (a line per 10% when it is not a terminal)."""

    def __init__(self, total: int):
        self.total = total
        self.tty = sys.stderr.isatty()
        self.last_decile = -1

    def __call__(self, stats) -> None:
        done = stats.samples
        frac = done / self.total if self.total else 1.0
        eta = stats.seconds / frac - stats.seconds if frac > 0 else 0.0
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        line = (
            f"[{bar}] {done}/{self.total} spp  {_fmt_seconds(stats.seconds)} elapsed  "
            f"ETA {_fmt_seconds(eta)}  {stats.rays_per_second / 1e6:.2f} Mrays/s"
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
) -> None:
    """Render a scene to a PNG image (and optionally a linear HDR image)."""
    import signal
    import time

    from scenefmt.diagnostics import SceneError
    from scenefmt.validation import load

    started = time.perf_counter()
    try:
        loaded = load(scene)
    except SceneError as exc:
        for diag in exc.diagnostics:
            typer.echo(str(diag), err=True)
        raise typer.Exit(1)
    out = output if output is not None else Path(scene.stem + ".png")
    for path, allowed in ((out, (".png",)), (hdr, (".pfm",))):
        if path is not None and path.suffix.lower() not in allowed:
            typer.echo(f"error: {path}: the file name must end in {' or '.join(allowed)}", err=True)
            raise typer.Exit(1)
        if path is not None and not (path.parent if str(path.parent) else Path(".")).is_dir():
            typer.echo(f"error: {path}: the folder {path.parent} does not exist", err=True)
            raise typer.Exit(1)

    import numba

    from renderer.film import write_image
    from renderer.render import kernels_cached, with_width
    from renderer.render import render as render_graph

    if threads is not None:
        if threads > numba.config.NUMBA_NUM_THREADS:
            typer.echo(f"error: --threads {threads}: at most {numba.config.NUMBA_NUM_THREADS} threads are available", err=True)
            raise typer.Exit(1)
        numba.set_num_threads(threads)
    graph = loaded.graph if width is None else with_width(loaded.graph, width)
    target = spp if spp is not None else graph.image.samples_per_pixel
    stop = {"requested": False}

    def on_interrupt(signum, frame):
        if stop["requested"]:
            raise KeyboardInterrupt
        stop["requested"] = True
        sys.stderr.write("\ninterrupted: finishing the current pass and saving what is rendered (Ctrl-C again to abort)\n")

    if not kernels_cached():
        typer.echo(
            f"compiling the renderer for this installation (about two minutes on 2 cores, once; cached in {numba.config.CACHE_DIR})",
            err=True,
        )
    previous = signal.signal(signal.SIGINT, on_interrupt)
    bar = _Progress(target)
    try:
        result = render_graph(
            graph, samples=spp, max_depth=max_depth, seed=seed, progress=bar, should_stop=lambda: stop["requested"]
        )
    finally:
        bar.close()
        signal.signal(signal.SIGINT, previous)
    stats, film = result.stats, result.film
    if film.samples == 0:
        typer.echo("interrupted before the first pass finished: nothing to save", err=True)
        raise typer.Exit(130)
    image = film.mean()
    write_image(out, image)
    if hdr is not None:
        write_image(hdr, image)
    total = time.perf_counter() - started
    written = str(out) + (f" and {hdr}" if hdr is not None else "")
    typer.echo(
        f"wrote {written}: {film.width}x{film.height}, {film.samples} spp, {_fmt_seconds(stats.seconds)} rendering "
        f"({_fmt_seconds(total)} in all), {stats.rays / 1e6:.1f} M rays, {stats.rays_per_second / 1e6:.2f} Mrays/s"
    )
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
