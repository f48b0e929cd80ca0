"""`rt`: a thin command line over scenefmt and the renderer (argument parsing and presentation only).

`rt validate` never imports the renderer or Numba, so it answers in a fraction of a second.
"""

from __future__ import annotations

import json
import re
import sys
from enum import Enum
from pathlib import Path
from typing import List, Optional

import typer

app = typer.Typer(
    name="rt",
    help="Render declarative YAML/JSON scene files with a physically based path tracer.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    # Help texts are plain text: rich markup would take "[cluster]" in "pip install 'rt-render[cluster]'"
    # (or any other word in square brackets) for a style and print nothing in its place.
    rich_markup_mode=None,
    context_settings={"max_content_width": 120},  # plain help wraps at 80 columns unless told it may use more
)


def _meshes(group, seen: set) -> list:
    """(path, mesh data) of every mesh reachable from `group`, each group visited once."""
    from scenefmt.diagnostics import format_path

    out = []
    for member in group.members:
        if member.kind == "instance":
            if id(member.group) not in seen:
                seen.add(id(member.group))
                out += _meshes(member.group, seen)
        elif member.kind == "mesh" and member.mesh is not None:
            out.append((format_path(member.path), member.mesh))
    return out


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
    meshes = _meshes(graph.root, set())
    if meshes:
        from scenefmt.meshfile import describe

        for path, mesh in meshes:
            lines.append(f"  mesh at {path}: {describe(mesh)}")
    defs = ", ".join(f"{n} {k}" for k, n in summary.definition_counts.items() if n)
    if defs:
        lines.append(f"  named: {defs}")
    lines.append(
        f"  image: {image.width}x{image.pixel_height}, {image.samples_per_pixel} spp, max depth {image.max_depth}, "
        f"seed {image.seed}, integrator {image.integrator}"
        + (f", display {image.display}" if image.display != "gamma2" else "")  # the books' default goes unsaid
        + f"; background {summary.background}"
    )
    if graph.memory is not None:
        from scenefmt.bounds import gib, memory_limit

        memory = graph.memory
        expanded = f", {memory.placements:,} instance placements" if memory.placements > 1 else ""
        lines.append(f"  memory: about {gib(memory.total)} ({memory.describe()}{expanded}); at most {gib(memory_limit())} here")
    lines.append("  lights:" + ("" if summary.lights else " none (only the background lights the scene)"))
    lines += [f"    {light}" for light in summary.lights]
    lines.append("  effects:")
    lines += [f"    {effect}" for effect in summary.effects]
    return lines


_SET_OPTION = typer.Option(
    [], "--set", metavar="KEY.PATH=VALUE",
    help="Change a value of the scene, checked like the file's (repeatable; a later one wins): "
    "--set image.samples_per_pixel=64 --set materials.glass.ior=1.33 --set 'camera.look_from=[0, 1, 5]'.",
)


_ALLOW_OPTION = typer.Option(
    [], "--allow-path", metavar="DIR",
    help="Also let the scene read files (includes, textures, environment maps, meshes) from this folder "
    "(repeatable). By default a scene reads only files inside its own folder (the current folder for "
    "standard input), symbolic links resolved.",
)


class Syntax(str, Enum):
    """The two syntaxes of a scene file, for --format."""

    yaml = "yaml"
    json = "json"


_FORMAT_OPTION = typer.Option(
    None, "--format",
    help="The syntax of the scene (default: from the file's suffix, or detected from its first character).",
)


def _check_stdin_use(files) -> None:
    reads = sum(str(f) == "-" for f in files)
    if reads > 1:
        typer.echo("error: standard input (-) can be read only once", err=True)
        raise typer.Exit(2)
    # Started with its standard input closed (`rt validate - <&-`), Python has no sys.stdin at all.
    if reads and sys.stdin is None:
        typer.echo("error: standard input is closed, so - names no scene", err=True)
        raise typer.Exit(2)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        from scenefmt.scene import FORMAT_VERSION

        try:
            number = version("rt-render")
        except PackageNotFoundError:  # run from a checkout that is not installed
            number = "unknown (not installed)"
        typer.echo(f"rt {number} (scene format version {FORMAT_VERSION}, Python {sys.version.split()[0]})")
        raise typer.Exit(0)


@app.callback()
def main(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version of rt and of the scene format, and exit."
    ),
) -> None:
    """Render declarative YAML/JSON scene files with a physically based path tracer."""


@app.command(
    epilog="Example: rt validate scenes/cornell_box.yaml scenes/quads.json --json; "
    "rt validate scene.yaml --set image.width=1920",
)
def validate(
    files: List[Path] = typer.Argument(
        ..., help="Scene files (YAML or JSON) to check; - reads one from standard input.", show_default=False
    ),
    overrides: List[str] = _SET_OPTION,
    syntax: Optional[Syntax] = _FORMAT_OPTION,
    as_json: bool = typer.Option(False, "--json", help="Print machine-readable results (one JSON document)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print only errors."),
    allow_paths: List[Path] = _ALLOW_OPTION,
) -> None:
    """Check scene files and summarise each valid one; exit 1 if any is invalid."""
    from scenefmt.diagnostics import SceneError
    from scenefmt.effects import summarize
    from scenefmt.loading import STDIN_NAME
    from scenefmt.validation import load_source

    _check_stdin_use(files)
    results = []
    failed = False
    for path in files:
        shown = STDIN_NAME if str(path) == "-" else str(path)
        try:
            loaded = load_source(path, overrides, syntax.value if syntax else None, allow_paths)
        except MemoryError as exc:  # the estimates allowed the work, but the memory is not there
            from scenefmt.assets import memory_message
            from scenefmt.diagnostics import Diagnostic, escape_control

            failed = True
            message = memory_message(exc, "load the scene")
            diag = Diagnostic(shown, 0, 0, (), message)
            results.append({"file": shown, "valid": False, "errors": [diag.to_json()], "warnings": []})
            if not as_json:
                typer.echo(escape_control(f"error: {shown}: {message}"), err=True)
            continue
        except SceneError as exc:
            failed = True
            results.append({"file": shown, "valid": False, "errors": [d.to_json() for d in exc.diagnostics], "warnings": []})
            if not as_json:
                for diag in exc.diagnostics:
                    typer.echo(str(diag), err=True)
                count = len(exc.diagnostics)
                typer.echo(f"{shown}: invalid ({count} error{'s' if count != 1 else ''})", err=True)
            continue
        results.append(
            {
                "file": shown,
                "valid": True,
                "errors": [],
                "warnings": [d.to_json() for d in loaded.warnings],
                "summary": summarize(loaded.graph).to_json(),
                "memory_bytes": loaded.graph.memory.total if loaded.graph.memory is not None else None,
            }
        )
        if not as_json:
            for diag in loaded.warnings:
                typer.echo(str(diag), err=True)
            if not quiet:
                typer.echo(f"{shown}: valid")
                for line in _summary_lines(loaded):
                    typer.echo(line)
    if as_json:
        typer.echo(json.dumps({"valid": not failed, "files": results}, indent=2))
    raise typer.Exit(1 if failed else 0)


@app.command(
    epilog="Example: rt render scenes/cornell_box.yaml -o cornell.png --spp 64 --hdr cornell.exr; "
    "rt render scenes/*.yaml -o renders/ --hdr exr --spp 16 (several scenes in one process)",
)
def render(
    scenes: List[Path] = typer.Argument(
        ..., help="Scene files (YAML or JSON) to render; - reads one from standard input (its image is then stdin.png unless -o "
        "says). Several scenes render one after the other in this process, the kernels loaded once; each image is named after "
        "its scene.",
        show_default=False
    ),
    overrides: List[str] = _SET_OPTION,
    syntax: Optional[Syntax] = _FORMAT_OPTION,
    output: Optional[Path] = typer.Option(
        None, "--output", "-o", help="PNG file to write (default: the scene file's name with .png, in the current folder); "
        "with several scenes, the folder to write their images in.",
    ),
    hdr: Optional[Path] = typer.Option(
        None, "--hdr",
        help="Also write the linear, unclamped image: .exr (OpenEXR, float32 RGB; needs the openexr package) or .pfm "
        "(portable float map). With several scenes, give the format only (--hdr exr or --hdr pfm): each is written beside "
        "its PNG.",
    ),
    exposure: Optional[float] = typer.Option(
        None, "--exposure", help="Scale the PNG's brightness by 2^STOPS before its display transform (--display) and clamping (the --hdr image is not changed).",
        metavar="STOPS",
    ),
    display: Optional[str] = typer.Option(
        None, "--display", metavar="gamma2|srgb|agx|aces",
        help="How the PNG shows the linear image (overrides the file's image.display): gamma2 (the books' square root, the "
        "default), srgb (the sRGB curve), agx (a filmic curve: highlights roll off, bright colours go to white) or aces "
        "(the ACES filmic transform, darker mid tones). Applied after --exposure; the PNG's metadata names it; --hdr and "
        "the noise and samples maps are not changed.",
    ),
    spp: Optional[int] = typer.Option(None, "--spp", min=1, max=1_000_000, help="Samples per pixel (overrides the file)."),
    width: Optional[int] = typer.Option(None, "--width", min=1, max=32768, help="Image width; the height keeps the aspect ratio."),
    max_depth: Optional[int] = typer.Option(None, "--max-depth", min=1, max=10_000, help="Most bounces per path."),
    seed: Optional[int] = typer.Option(
        None, "--seed", min=0, max=2**63 - 1, help="Seed of the random numbers (0 to 2^63 - 1, as in a scene file)."
    ),
    threads: Optional[int] = typer.Option(None, "--threads", min=1, help="Worker threads (default: all cores)."),
    time_budget: Optional[str] = typer.Option(
        None, "--time", help="Render in passes until this much time is spent (30s, 2m, 1h); --spp is then the cap."
    ),
    noise: Optional[float] = typer.Option(
        None, "--noise", min=0.0, help="Render until the estimated relative RMS noise is below this (0.02 = 2%) at 95% confidence, and not while the estimate warns that rare bright paths make it untrustworthy; --spp is then the cap."
    ),
    noise_map: Optional[Path] = typer.Option(None, "--noise-map", help="Write the per-pixel noise estimate as a PNG."),
    samples_map: Optional[Path] = typer.Option(
        None, "--samples-map",
        help="Write each pixel's sample count: a PNG (grey, white at the most) or .exr/.pfm (the counts themselves).",
    ),
    adaptive: bool = typer.Option(
        True, "--adaptive/--no-adaptive",
        help="With --noise, spend samples where the noise is (the default): after a uniform pilot of 32 samples per "
        "pixel, each pixel stops once it has samples in proportion to its own noise; --no-adaptive gives every pixel "
        "every sample.",
    ),
    save_state: Optional[Path] = typer.Option(
        None, "--save-state", help="Save the render's sums (.npz) so it can be continued with --resume."
    ),
    resume: Optional[Path] = typer.Option(
        None, "--resume", help="Continue the render saved with --save-state, up to --spp samples in all."
    ),
    dry_run: bool = typer.Option(
        False, "--dry-run",
        help="Render only a short pilot (a few seconds; the kernel is compiled first if it is not yet) and say how long "
        "the render would take to its --noise target, or the noise its --time budget or samples would reach, with a 95% "
        "range; write no file.",
    ),
    explain: bool = typer.Option(
        False, "--explain",
        help="Print which effects the scene uses, the element that switches each on and the kernel chosen, and measure "
        "what each expensive effect costs (path depth, media, an environment map, defocus, motion blur, glossy "
        "materials: short renders with and without it, about 15 s in all), then render as usual (rt validate lists the effects without rendering).",
    ),
    integrator: Optional[str] = typer.Option(
        None, "--integrator",
        help="How light is found (overrides the file): mis (light sampling with multiple importance sampling, the "
        "default), path (the books' estimator, which finds lights only by chance), caustics (mis, with the light that "
        "reaches a matte surface through glass or mirror spheres traced from the lights: caustics, a lamp inside "
        "glass; one process only) or guided (mis whose bounces follow a learned guide; see docs/integrators.md).",
    ),
    sampler: Optional[str] = typer.Option(
        None, "--sampler",
        help="Where the samples fall (overrides the file): independent (fresh random numbers, the books') or sobol "
        "(Owen-scrambled Sobol points in independently scrambled batches); the same as --set image.sampler=NAME.",
    ),
    kernel: str = typer.Option(
        "auto", "--kernel",
        help="Which compiled kernel renders: auto (whatever is compiled; specialise a long render), general, or "
        "specialised (compile one for this scene's effects first).",
    ),
    cluster: Optional[str] = typer.Option(
        None, "--cluster", metavar="local|tcp://HOST:PORT",
        help="Render on a Dask cluster: local starts worker processes on this machine; an address uses a running "
        "dask scheduler. The image is the same as without, bit for bit. Needs the cluster extra (pip install '.[cluster]' in rt's folder); "
        "see docs/cluster.md.",
    ),
    allow_paths: List[Path] = _ALLOW_OPTION,
    denoise: bool = typer.Option(
        False, "--denoise",
        help="Also write a denoised image beside the raw one (NAME.denoised.png, and beside --hdr), through Intel Open "
        "Image Denoise guided by albedo and normal passes; the raw images are always written. Needs the denoise extra "
        "(pip install '.[denoise]' in rt's folder); its error is measured in docs/accuracy.md.",
    ),
    passes: Optional[str] = typer.Option(
        None, "--passes", metavar="albedo,normal,depth,samples,error",
        help="Also write render passes: albedo, normal (world space) and depth (along the view axis), traced after the "
        "render by rays of their own as Intel Open Image Denoise defines its auxiliary images (the image is unchanged); "
        "samples (each pixel's count) and error (each pixel's standard error). See docs/passes.md.",
    ),
    passes_as: Optional[str] = typer.Option(
        None, "--passes-as", metavar="layers|files",
        help="How --passes are written: layers of the --hdr OpenEXR image (channels albedo.R, normal.X, depth.Z, ...; "
        "the default with --hdr NAME.exr) or files beside the image, NAME.<pass>.exr with --hdr .exr, else .pfm (the "
        "default otherwise).",
    ),
) -> None:
    """Render a scene to a PNG image (and optionally a linear HDR image and a noise map)."""
    import time

    from .render_job import RenderOptions, Stop, run, run_batch
    from .rendering import sampler_override

    started = time.perf_counter()
    _check_stdin_use(scenes)
    opts = RenderOptions(
        scene=scenes[0], output=output, hdr=hdr, spp=spp, width=width, max_depth=max_depth, seed=seed, threads=threads,
        time_budget=time_budget, noise=noise, noise_map=noise_map, samples_map=samples_map, adaptive=adaptive,
        save_state=save_state, resume=resume, explain=explain, dry_run=dry_run,
        kernel=kernel, integrator=integrator, overrides=tuple(overrides) + sampler_override(sampler), exposure=exposure,
        syntax=syntax.value if syntax else None, cluster=cluster, allow_paths=tuple(allow_paths),
        passes=tuple(passes.split(",")) if passes is not None else (), passes_as=passes_as, denoise=denoise,
        display=display,
    )
    try:
        if len(scenes) == 1:
            run(opts, started)
        else:
            run_batch(opts, scenes)
    except Stop as stop:
        raise typer.Exit(stop.status)


@app.command(epilog="Example: rt watch scenes/cornell_box.yaml --width 300 --spp 64, then open http://127.0.0.1:8000/")
def watch(
    scene: Path = typer.Argument(..., help="Scene file (YAML or JSON) to show and watch.", show_default=False),
    port: int = typer.Option(8000, "--port", min=0, max=65535, help="Port of the page (0: any free one)."),
    host: str = typer.Option(
        "127.0.0.1", "--host", help="Address to listen on; other than the loopback address, anyone who can reach this machine sees the page."
    ),
    overrides: List[str] = _SET_OPTION,
    spp: Optional[int] = typer.Option(None, "--spp", min=1, max=1_000_000, help="Samples per pixel to refine to (overrides the file)."),
    width: Optional[int] = typer.Option(None, "--width", min=1, max=32768, help="Image width; the height keeps the aspect ratio."),
    integrator: Optional[str] = typer.Option(None, "--integrator", help="mis (the default), path, caustics or guided, as for rt render."),
    display: Optional[str] = typer.Option(
        None, "--display", metavar="gamma2|srgb|agx|aces", help="How the page shows the image (overrides the file's "
        "image.display), as for rt render.",
    ),
    allow_paths: List[Path] = _ALLOW_OPTION,
) -> None:
    """Serve a page that shows the scene refining, and render it again each time it (or a file it uses) is saved."""
    from .watch import WatchOptions, main_say, serve

    if str(scene) == "-":
        typer.echo("error: rt watch needs a scene file to watch, not standard input", err=True)
        raise typer.Exit(2)
    from renderer.flat import INTEGRATORS, integrator_choices

    if integrator is not None and integrator not in INTEGRATORS:
        typer.echo(f"error: --integrator {integrator!r}: expected {integrator_choices()}", err=True)
        raise typer.Exit(2)
    if display is not None:
        from renderer.display import DISPLAYS, unknown_display

        if display not in DISPLAYS:
            typer.echo(f"error: --display: {unknown_display(display)}", err=True)
            raise typer.Exit(2)
    opts = WatchOptions(scene=scene, spp=spp, width=width, integrator=integrator, overrides=tuple(overrides),
                        allow_paths=tuple(allow_paths), display=display)
    raise typer.Exit(serve(opts, host, port, main_say))


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


@app.command(
    "import",
    epilog="Example: rt import chair.glb -o chair.yaml, then rt render chair.yaml -o chair.png; "
    "rt import chair.glb -o chair_part.yaml --part for a file another scene can include:",
)
def import_model(
    model: Path = typer.Argument(..., help="The glTF 2.0 model: a .glb file, or a .gltf file with its .bin and image files.",
                                 show_default=False),
    output: Path = typer.Option(..., "--output", "-o", help="The scene file to write (.yaml); meshes and images go in "
                                "<its stem>_assets/ beside it.", show_default=False),
    part: bool = typer.Option(False, "--part", help="Write only what an included file may hold (textures, materials, "
                              "groups, shapes): no camera, image, background or lights."),
    prefix: Optional[str] = typer.Option(None, "--prefix", help="Put this before every name the file defines (default: "
                                         "the output's stem and _), so that several imported models can be included together."),
    width: int = typer.Option(640, "--width", min=1, max=16384, help="Image width written in the scene."),
    spp: int = typer.Option(64, "--spp", min=1, max=1_000_000, help="Samples per pixel written in the scene."),
    lumens_per_watt: float = typer.Option(
        683.0, "--lumens-per-watt", help="Divides KHR_lights_punctual's photometric intensities (candela, lux) into "
        "rt's W/sr and W/m^2; 1 takes them as radiometric already."),
    force: bool = typer.Option(False, "--force", help="Replace the scene file and its assets folder if they exist."),
) -> None:
    """Import a glTF 2.0 model as a scene file: meshes as PLY files, materials as principled materials,
    textures as image files, node transforms and instancing, cameras and KHR_lights_punctual lights.
    Needs the gltf extra: pip install '.[gltf]' in rt's folder (docs/import.md)."""
    from scenefmt.diagnostics import escape_control
    from scenefmt.gltf_read import GltfProblem

    if prefix is not None and not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_\-]{0,23}|", prefix):
        typer.echo("error: --prefix must start with a letter or _ and hold at most 24 letters, digits, _ or -", err=True)
        raise typer.Exit(2)
    try:
        from rt.importing import import_gltf

        result = import_gltf(model, output, part=part, prefix=prefix, width=width, samples=spp,
                             lumens_per_watt=lumens_per_watt, force=force)
    except GltfProblem as exc:
        typer.echo(escape_control(f"error: {model.name}: {exc}"), err=True)
        raise typer.Exit(1)
    except MemoryError:
        typer.echo(escape_control(f"error: {model.name}: not enough memory to import it"), err=True)
        raise typer.Exit(1)
    for line in result.warnings:
        typer.echo(escape_control(f"warning: ignored: {line}"), err=True)
    typer.echo(escape_control(f"wrote {result.scene} ({result.meshes} mesh file(s), {result.triangles:,} triangles, "
                              f"{result.images} image file(s) in {result.assets.name}/)"))


if __name__ == "__main__":
    app()
