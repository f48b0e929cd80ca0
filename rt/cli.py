"""`rt`: a thin command line over scenefmt and the renderer (argument parsing and presentation only).

`rt validate` never imports the renderer or Numba, so it answers in a fraction of a second.
"""

from __future__ import annotations

import json
import sys
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


@app.command(epilog="Example: rt render scenes/cornell_box.yaml -o cornell.png")
def render(
    scene: Path = typer.Argument(..., help="Scene file (YAML or JSON) to render.", show_default=False),
) -> None:
    """Render a scene to an image."""
    from scenefmt.diagnostics import SceneError
    from scenefmt.validation import load

    try:
        load(scene)
    except SceneError as exc:
        for diag in exc.diagnostics:
            typer.echo(str(diag), err=True)
        raise typer.Exit(1)
    typer.echo(
        f"{scene} is valid, but rendering is not implemented yet: the renderer arrives with the "
        "renderer issue. Use `rt validate` to check scenes meanwhile.",
        err=True,
    )
    raise typer.Exit(2)


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
