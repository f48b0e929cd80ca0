"""The files `rt render` writes: every one checked before rendering, none lost after it.

`output_problem` runs before the scene is rendered: each output path (the image, --hdr,
--noise-map, --save-state) must be a usable name, not a directory, in a folder that exists
and where a file can be created (tried for real, with a temporary file that is removed at
once: permissions, read-only file systems and quotas all answer the same way), and no two may
be the same file. `input_problem` runs once the scene is read, still before rendering: no output
may be a file the render reads (the scene, an include, a texture, the environment map, a mesh,
--resume), compared as files (`file_key`: links resolved, the same inode), not as names.

`write_outputs` runs after: it writes the saved state first (the samples are what took the
time), then the images. If a write still fails (the disk filled, the folder vanished), the
render is not lost: the film is saved elsewhere (`rescue`), as a state to `--resume` when the
scene's fingerprint is known and always as a linear PFM image, and the message says where.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Optional

from renderer.film import FILE_FORMATS, FORMAT_BY_SUFFIX, FileFormat

if TYPE_CHECKING:
    from renderer.film import Film, NoiseEstimate
    from renderer.state import RenderKey

    from .render_job import RenderOptions


# Every output format (renderer/film.py's table, the one place a suffix is spelt), in the order
# messages list them.
FORMATS = FILE_FORMATS
BY_SUFFIX = FORMAT_BY_SUFFIX
# The image's format, the one a rescued image is written in (needs no optional library) and the
# state's.
PNG = next(f.suffix for f in FORMATS if f.role == "image")
PFM = next(f.suffix for f in FORMATS if f.role == "hdr" and not f.needs_exr)
STATE = next(f.suffix for f in FORMATS if f.role == "state")


def suffixes_of(role: str) -> tuple[str, ...]:
    """The suffixes of the formats of `role` ("image", "hdr" or "state")."""
    return tuple(f.suffix for f in FORMATS if f.role == role)


def format_of(path) -> Optional[FileFormat]:
    """The format a file name asks for by its suffix (any case); None for none of ours."""
    return BY_SUFFIX.get(Path(path).suffix.lower())


def needs_exr(path) -> bool:
    """Whether writing `path` needs the optional OpenEXR library."""
    found = format_of(path)
    return found is not None and found.needs_exr


def _outputs(opts: "RenderOptions") -> list[tuple[str, Path]]:
    named = [("the image", opts.out), ("--hdr", opts.hdr), ("--noise-map", opts.noise_map), ("--samples-map", opts.samples_map),
             ("--save-state", opts.save_state)]
    named += [("the denoised image", path) for path in opts.denoised]  # --denoise: beside the PNG and --hdr
    named += [(f"the {name} pass", path) for name, path in opts.pass_outputs]
    return [(what, path) for what, path in named if path is not None]


def path_problem(path: Path) -> Optional[str]:
    """Why no file can be written at `path`, or None. Creates nothing that outlives the call."""
    from scenefmt.files import describe_os_error, kind_of
    from scenefmt.files import path_problem as name_problem

    problem = name_problem(path)
    if problem:
        return problem
    folder = path.parent if str(path.parent) else Path(".")
    try:
        if os.path.lexists(path):
            kind = kind_of(os.stat(path).st_mode) if os.path.exists(path) else None
            if kind is not None:
                return f"it is {kind}, not a file that can be replaced"
        if not folder.is_dir():
            return f"the folder {folder} does not exist"
        limit = os.pathconf(folder, "PC_NAME_MAX") if hasattr(os, "pathconf") else 255
        if len(os.fsencode(path.name)) > limit:
            return f"the file name is longer than the {limit} bytes the system allows"
        fd, probe = tempfile.mkstemp(prefix=".rt-", suffix=".tmp", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        return f"cannot write in {folder}: {describe_os_error(exc)}"
    return None


def file_key(path) -> tuple:
    """What makes two names the same file: its device and inode where it exists (a symbolic or
    hard link to it is the same file), else its path with every link resolved."""
    real = os.path.realpath(os.fsdecode(path))
    try:
        info = os.stat(real)
    except (OSError, ValueError):
        return ("path", real)
    return ("inode", info.st_dev, info.st_ino)


def output_problem(opts: "RenderOptions") -> Optional[str]:
    """The first output that cannot be written, as an error line; None if all can."""
    from scenefmt.diagnostics import escape_control

    seen: dict[tuple, tuple[str, Path]] = {}
    for what, path in _outputs(opts):
        problem = path_problem(path)
        if problem:
            return escape_control(f"error: {path}: {problem}")
        key = file_key(path)
        if key in seen:
            other, other_path = seen[key]
            same = "" if os.path.abspath(path) == os.path.abspath(other_path) else f" ({other_path}, through a link)"
            return escape_control(f"error: {path}: {what} and {other}{same} name the same file")
        seen[key] = (what, path)
    return None


def input_problem(opts: "RenderOptions", reads: list) -> Optional[str]:
    """An output that is a file the render reads, as an error line; None if none is. `reads`: every
    file the load opened (scenefmt.files.recording_reads: the scene, its includes, textures,
    environment map and meshes), and --resume, which only --save-state may name (continuing a
    state in place is its use, and the state is written atomically)."""
    from scenefmt.diagnostics import escape_control

    main = None if opts.from_stdin else file_key(opts.scene)
    inputs: dict[tuple, str] = {}
    for path in reads:
        inputs.setdefault(file_key(path), path)
    for what, path in _outputs(opts):
        key = file_key(path)
        if key == main:
            return escape_control(f"error: {what} {path} is the scene file {opts.scene} itself: rendering would overwrite it; "
                                  "name the image with -o")
        if key in inputs:
            return escape_control(f"error: {what} {path} is {inputs[key]}, a file the scene reads: rendering would overwrite "
                                  "it; choose another name")
        if opts.resume is not None and what != "--save-state" and key == file_key(opts.resume):
            return escape_control(f"error: {what} {path} is the state --resume {opts.resume} reads; choose another name")
    return None


def rescue(film: "Film", key: Optional["RenderKey"], stem: str) -> list[Path]:
    """Save `film` where it can be saved (the temporary folder, else the current one, else home):
    a state to resume from when `key` is known, and the linear image as PFM. The files written."""
    from renderer.film import write_pfm
    from renderer.state import save_state

    folders = [Path(tempfile.gettempdir()), Path.cwd(), Path.home()]
    name = f"rt-rescued-{stem[:64]}-{os.getpid()}"
    for folder in folders:
        written: list[Path] = []
        try:
            if key is not None:
                save_state(folder / f"{name}{STATE}", film, key)
                written.append(folder / f"{name}{STATE}")
            write_pfm(folder / f"{name}{PFM}", film.mean())
            written.append(folder / f"{name}{PFM}")
            return written
        except OSError:
            continue
    return []


def write_outputs(
    opts: "RenderOptions", film: "Film", key: Optional["RenderKey"], fail: Callable[[str], Exception],
    passes: Optional[dict] = None, display: str = "gamma2",
) -> "NoiseEstimate":
    """Write every output of the render; on a failure, rescue the film and raise `fail(message)`.
    `passes` (rt/passes.py: name -> array) go into the --hdr EXR as layers or beside the image as
    files, as --passes-as says. The image's PNG is made with the display transform `display`
    (renderer/display.py), after --exposure; the noise and samples maps keep gamma 2, which their
    grey is made for."""
    from renderer.film import NOISE_MAP_CONTENT, PNG_CONTENT_KEY, estimate_noise, noise_map_image, write_image
    from renderer.state import save_state
    from scenefmt.diagnostics import escape_control
    from scenefmt.files import describe_os_error

    image = film.mean()
    estimate = estimate_noise(film)
    steps = []
    if opts.save_state is not None:
        steps.append((opts.save_state, lambda: save_state(opts.save_state, film, key)))
    exposed = image if not opts.exposure else image * 2.0 ** opts.exposure  # the PNG only; --hdr stays as rendered
    shown = {"rt:exposure": f"{opts.exposure:g}"} if opts.exposure else None
    steps.append((opts.out, lambda: write_image(opts.out, exposed, display, shown)))
    layers = None
    if passes:
        from .passes import exr_layers, layout_of

        layers = exr_layers(passes) if layout_of(opts.passes_as, opts.hdr) == "layers" else None
    if opts.hdr is not None and layers is not None:
        from renderer.film import write_exr_layers

        steps.append((opts.hdr, lambda: write_exr_layers(opts.hdr, image, layers)))
    elif opts.hdr is not None:
        steps.append((opts.hdr, lambda: write_image(opts.hdr, image)))
    if opts.noise_map is not None:
        steps.append((opts.noise_map, lambda: write_image(opts.noise_map, noise_map_image(estimate), "gamma2",
                                                          {PNG_CONTENT_KEY: NOISE_MAP_CONTENT})))
    if opts.samples_map is not None:
        from renderer.sample_counts import SAMPLES_MAP_CONTENT, sample_count_image

        raw = format_of(opts.samples_map) is not None and format_of(opts.samples_map).role == "hdr"
        steps.append((opts.samples_map, lambda: write_image(opts.samples_map, sample_count_image(film.counts, raw), "gamma2",
                                                            {PNG_CONTENT_KEY: SAMPLES_MAP_CONTENT})))
    if passes and layers is None:
        from .passes import write_pass_file

        for name, path in opts.pass_outputs:
            steps.append((path, lambda path=path, name=name: write_pass_file(path, name, passes[name])))
    for path, step in steps:
        try:
            step()
        except (OSError, ValueError) as exc:
            reason = describe_os_error(exc) if isinstance(exc, OSError) else str(exc)
            saved_state = opts.save_state is not None and path != opts.save_state
            rescued = [] if saved_state else rescue(film, key, "stdin" if opts.from_stdin else Path(str(opts.scene)).stem)
            if saved_state:
                where = f"the samples are saved in {opts.save_state} (continue with --resume)"
            elif rescued:
                where = f"the {film.samples} samples per pixel are saved in " + " and ".join(str(p) for p in rescued)
            else:
                where = "and no folder could hold a copy of the samples"
            raise fail(escape_control(f"error: cannot write {path}: {reason}; {where}"))
    return estimate
