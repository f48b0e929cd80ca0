"""`rt render`: check the options, read and flatten the scene, render it, write the images.

Each step prints its own errors and ends early with `Stop`; the command line turns that into
the exit status. This module does without typer, so it can be driven from Python too.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Optional

from .outputs import BY_SUFFIX, PNG, needs_exr, suffixes_of
from .progress import Progress, fmt_seconds
from .rendering import max_threads, option_problem, parse_duration, render_scene, sample_target

if TYPE_CHECKING:
    from renderer.flat import FlatScene, Frame
    from renderer.variants import KernelFeatures

@dataclass(frozen=True)
class RenderOptions:
    """The options of one `rt render`, as parsed."""

    scene: Path
    output: Optional[Path] = None
    hdr: Optional[Path] = None
    spp: Optional[int] = None
    width: Optional[int] = None
    max_depth: Optional[int] = None
    seed: Optional[int] = None
    threads: Optional[int] = None
    time_budget: Optional[str] = None
    noise: Optional[float] = None
    noise_map: Optional[Path] = None
    samples_map: Optional[Path] = None  # --samples-map: each pixel's sample count (PNG normalised, EXR/PFM raw)
    adaptive: bool = True  # --no-adaptive: with --noise, every pixel takes every sample
    save_state: Optional[Path] = None
    resume: Optional[Path] = None
    explain: bool = False
    dry_run: bool = False  # --dry-run: a pilot and a forecast, no image (rt/dry_run.py)
    kernel: str = "auto"
    integrator: Optional[str] = None
    overrides: tuple[str, ...] = ()  # --set KEY.PATH=VALUE, in order
    exposure: Optional[float] = None  # --exposure: stops applied to the PNG only
    syntax: Optional[str] = None  # --format: yaml or json
    cluster: Optional[str] = None  # --cluster: local or a Dask scheduler's address (rt/cluster.py)
    allow_paths: tuple = ()  # --allow-path: folders besides the scene's that its files may be read from
    denoise: bool = False  # --denoise: also write NAME.denoised.png (and beside --hdr) through rt/denoise.py
    passes: tuple[str, ...] = ()  # --passes: render passes to write (rt/passes.py), as given
    passes_as: Optional[str] = None  # --passes-as: layers (of the --hdr EXR) or files; None: by --hdr
    display: Optional[str] = None  # --display: the PNG's display transform (renderer/display.py); None: the scene's

    @property
    def from_stdin(self) -> bool:
        return str(self.scene) == "-"

    @property
    def out(self) -> Path:
        """The PNG to write: --output, or the scene file's name with .png in the current folder
        (`stdin.png` for a scene read from standard input)."""
        if self.output is not None:
            return self.output
        return Path(("stdin" if self.from_stdin else self.scene.stem) + PNG)

    @property
    def denoised(self) -> tuple[Path, ...]:
        """The denoised images --denoise writes, beside the PNG and the --hdr image (none without it)."""
        if not self.denoise:
            return ()
        from .denoise import denoised_path

        return tuple(denoised_path(p) for p in (self.out, self.hdr) if p is not None)

    @property
    def pass_outputs(self) -> list[tuple[str, Path]]:
        """(pass, file) of each pass written as a file of its own; none when they are layers of
        the --hdr EXR, or when --passes is not valid (which `prepare` reports)."""
        if not self.passes:
            return []
        from .passes import layout_of, parse_passes, pass_files

        try:
            names = parse_passes(self.passes)
            if layout_of(self.passes_as, self.hdr) != "files":
                return []
        except ValueError:
            return []
        return pass_files(self.out, names, self.hdr)


@dataclass(frozen=True)
class PreparedScene:
    """A scene ready to render: its flat tables, image settings and kernel features."""

    flat: FlatScene
    frame: Frame
    features: KernelFeatures
    budget_seconds: Optional[float]  # --time in seconds
    # sha256 of the scene's canonical JSON, for --resume and --save-state (None without them).
    fingerprint: Optional[str]
    # The scene as data for cluster workers (rt.cluster.package_scene), with --cluster only.
    package: Optional[object] = None
    # The models and parsed file, held until the render ends: freeing a generated scene's
    # millions of objects takes a second that the first sample need not wait for.
    loaded: Optional[object] = None
    # The PNG's display transform: --display, else the scene's image.display.
    display: str = "gamma2"


def budget_text(text: str) -> str:
    """A --time value as written, with its unit named when it has none: '2' -> '2 s', '1h30m' as is."""
    import re

    text = text.strip()
    return f"{text} s" if re.fullmatch(r"\d+(\.\d+)?", text) else text


def noise_reached(noise: float, target: float, bound: bool = False) -> str:
    """Why a --noise render stopped, with enough digits that the estimate and the target differ
    ('1.996%' below '2.000%', never '2.00%' below '2.00%'). `bound`: `noise` is the upper end of
    the error's 95% interval (what the render session stops on), and the sentence says so."""
    for digits in range(2, 7):
        shown, wanted = f"{100 * noise:.{digits}f}", f"{100 * target:.{digits}f}"
        if shown != wanted:  # the estimate is at most the target, so it shows as less
            if bound:
                return f"the estimated noise is below the {wanted}% target at 95% confidence (its upper bound is {shown}%)"
            return f"the estimated noise {shown}% is below the {wanted}% target"
    if bound:
        return f"the estimated noise has reached the {100 * target:.2f}% target at 95% confidence"
    return f"the estimated noise has reached the {100 * target:.2f}% target"


def noise_line(estimate) -> str:
    """The noise figure of a render as `rt render` prints it: the relative RMS error with its 95%
    interval (which covers the true error of this render at that rate) and the worst pixel."""
    wx, wy = estimate.worst_pixel
    interval = ""
    if math.isfinite(estimate.high):
        interval = f" ({100 * estimate.low:.2f}-{100 * estimate.high:.2f}% at {100 * estimate.confidence:.0f}%)"
    return (f"noise: {100 * estimate.relative_rms:.2f}% relative RMS{interval}, estimated from the samples; worst at pixel "
            f"({wx}, {wy}), {100 * estimate.worst_relative:.0f}% of its value")


class Stop(Exception):
    """The command ends with exit status `status`; what it had to say is printed already."""

    def __init__(self, status: int):
        super().__init__(status)
        self.status = status


# A render stopped by a signal writes what it has rendered, then exits with 128 + the signal's
# number, as a shell reports a process that signal ended: 130 for Ctrl-C (SIGINT), 143 for
# SIGTERM (what `timeout`, systemd and Slurm send). A script can tell the two from an error (1).
STOP_SIGNALS = ("SIGINT", "SIGTERM")
INTERRUPTED = (130, 143)


class Aborted(BaseException):
    """A stop signal that ends the command at once, saving nothing more: a second one, or a first
    one (`first`) before any sample could be saved. It derives from BaseException, as
    KeyboardInterrupt does, so that no handler of errors catches it on its way."""

    def __init__(self, signum: int, first: bool = False):
        import signal

        super().__init__(signum)
        self.name = signal.Signals(signum).name
        self.status = 128 + signum
        self.first = first


class StopSignals:
    """Within a `with` block, SIGINT and SIGTERM ask the render to stop. The first sets the flag
    that `requested` reports: the render polls it between bands of rows (a fraction of a second
    apart) and keeps its finished passes, which are then written. A second raises Aborted.

    A handler runs in the main thread between two Python steps, so during a kernel's compile
    (up to a minute or more) the flag would wait for the compile to end. While `nothing_to_save`
    says so (no pass finished, none resumed), the first signal therefore raises Aborted at once:
    stopping later would save nothing either."""

    def __init__(self, notify, nothing_to_save):
        self.notify = notify
        self.nothing_to_save = nothing_to_save
        self.signum: Optional[int] = None
        self.previous: dict = {}

    def __enter__(self) -> "StopSignals":
        import signal

        for name in STOP_SIGNALS:
            number = getattr(signal, name)
            self.previous[number] = signal.signal(number, self.handle)
        return self

    def __exit__(self, *exc) -> None:
        import signal

        for number, handler in self.previous.items():
            signal.signal(number, handler)

    def handle(self, signum: int, _stack_frame) -> None:
        import signal

        if self.signum is not None:
            raise Aborted(signum)
        self.signum = signum
        if self.nothing_to_save():
            raise Aborted(signum, first=True)
        name = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
        try:  # the handler may run inside a write to standard error, which cannot be entered twice
            self.notify(f"interrupted ({name}): stopping, and saving the passes rendered so far "
                        f"(a second Ctrl-C or SIGTERM aborts without saving)")
        except RuntimeError:
            pass

    def requested(self) -> bool:
        return self.signum is not None

    @property
    def status(self) -> int:
        """The exit status of a stopped render: 128 + the signal's number (130 without one)."""
        import signal

        return 128 + (self.signum if self.signum is not None else signal.SIGINT)


def say(message: str, err: bool = False) -> None:
    stream = sys.stderr if err else sys.stdout
    stream.write(message + "\n")
    stream.flush()


def fail(message: str) -> Stop:
    from scenefmt.diagnostics import escape_control  # file names and keys come from files

    say(escape_control(message), err=True)
    return Stop(1)


def samples_fingerprint(scene) -> str:
    """The fingerprint a saved state is keyed by (--save-state, --resume): sha256 of the scene's
    canonical JSON, leaving out `image.display`, which shapes only the PNG made from the samples,
    so that a render saved under one display transform resumes under another. A scene that does
    not set it has the fingerprint it had before display transforms existed."""
    from renderer.state import scene_fingerprint
    from scenefmt.writing import dumps

    if "display" in scene.image.model_fields_set:
        image = scene.image
        kept = {name: getattr(image, name) for name in image.model_fields_set if name != "display"}
        scene = scene.model_copy(update={"image": type(image).model_validate(kept)})
    return scene_fingerprint(dumps(scene, "json"))


def prepare(opts: RenderOptions) -> PreparedScene:
    """Check the options, read and flatten the scene; print its errors and raise Stop(1) if any."""
    budget_seconds = None
    if opts.time_budget is not None:
        budget_seconds = parse_duration(opts.time_budget)
        if budget_seconds is None:
            raise fail(f"error: --time {opts.time_budget!r}: expected a duration such as 30s, 2m, 1h30m or 45")
    if opts.dry_run and (opts.cluster is not None or opts.resume is not None):
        which = "--cluster" if opts.cluster is not None else "--resume"
        raise fail(f"error: --dry-run forecasts a fresh render in this process: it cannot be combined with {which}")
    problem = option_problem(opts.kernel, opts.integrator, opts.threads)
    if problem == "kernel":
        from renderer.variants import KERNEL_CHOICES

        raise fail(f"error: --kernel {opts.kernel!r}: expected one of {', '.join(KERNEL_CHOICES)}")
    if problem == "integrator":
        from renderer.flat import integrator_choices

        raise fail(f"error: --integrator {opts.integrator!r}: expected {integrator_choices()}")
    if problem == "threads":
        raise fail(f"error: --threads {opts.threads}: at most {max_threads()} threads are available")
    # A dry run writes nothing, so its outputs are not checked (nor a batch's folder made).
    outputs = () if opts.dry_run else ((opts.out, "image"), (opts.hdr, "hdr"), (opts.noise_map, "image"),
                                       (opts.samples_map, "image+hdr"), (opts.save_state, "state"))
    for path, role in outputs:
        allowed = sum((suffixes_of(part) for part in role.split("+")), ())
        if path is not None and path.suffix.lower() not in allowed:
            raise fail(f"error: {path}: the file name must end in {' or '.join(allowed)}")
        if path is not None and not (path.parent if str(path.parent) else Path(".")).is_dir():
            raise fail(f"error: {path}: the folder {path.parent} does not exist")
    for name, path in (("--hdr", opts.hdr), ("--samples-map", opts.samples_map)):
        if path is not None and needs_exr(path):
            from scenefmt.hdr_files import EXR_MISSING, exr_available

            if not exr_available():
                raise fail(f"error: {name} {path}: {EXR_MISSING}")
    if opts.passes:
        from .passes import layout_of, parse_passes

        try:
            parse_passes(opts.passes)
            layout_of(opts.passes_as, opts.hdr)
        except ValueError as exc:
            raise fail(f"error: --passes: {exc}")
    elif opts.passes_as is not None:
        raise fail("error: --passes-as says how the passes are written: name them with --passes too "
                   "(such as --passes albedo,normal)")
    if opts.exposure is not None and not -30 <= opts.exposure <= 30:
        raise fail(f"error: --exposure {opts.exposure:g}: expected a number of stops from -30 to 30")
    if opts.display is not None:
        from renderer.display import DISPLAYS, unknown_display

        if opts.display not in DISPLAYS:
            raise fail(f"error: --display: {unknown_display(opts.display)}")
    if opts.denoise and not opts.dry_run:  # refused before rendering: a render spent for nothing otherwise
        from .denoise import DenoiserMissing, check_available

        try:
            check_available()
        except DenoiserMissing as exc:
            raise fail(f"error: {exc}")
    from .outputs import input_problem, output_problem  # every output is checked before rendering

    problem = None if opts.dry_run else output_problem(opts)
    if problem:
        raise fail(problem)

    from renderer.flat import Frame
    from renderer.session import flatten_loaded
    from renderer.variants import features_of
    from scenefmt.diagnostics import SceneError
    from scenefmt.validation import load_source

    from scenefmt.files import recording_reads

    try:
        with recording_reads() as reads:  # the files a cluster's workers need
            loaded = load_source(opts.scene, opts.overrides, opts.syntax, opts.allow_paths)
            # Every input is known once the scene is read: check the outputs before any texture is decoded.
            problem = None if opts.dry_run else input_problem(opts, reads)
            if problem:
                raise fail(problem)
            graph, flat = flatten_loaded(loaded, opts.width, opts.integrator)
    except SceneError as exc:
        for diag in exc.diagnostics:
            say(str(diag), err=True)
        raise Stop(1)
    except ValueError as exc:  # input the format cannot check, such as an image that does not decode
        raise fail(f"error: {opts.scene}: {exc}")
    except MemoryError as exc:  # reading the scene file itself
        from scenefmt.assets import memory_message

        raise fail(f"error: {opts.scene}: {memory_message(exc, 'load the scene')}")
    for diag in loaded.warnings:  # as `rt validate` prints them: an empty scene renders, with a word
        say(str(diag), err=True)
    if opts.explain:
        from scenefmt.effects import summarize

        follows = "a dry run follows" if opts.dry_run else "the render follows"
        say(f"explain: the effects this scene uses, the kernel that renders it and what each expensive effect costs; "
            f"{follows} (rt validate lists the effects without rendering)", err=True)
        say(f"integrator: {graph.image.integrator}", err=True)
        summary = summarize(graph)
        for effect in summary.effects:
            say(f"{effect}", err=True)
        say("lights: " + (", ".join(str(light) for light in summary.lights) or "none (only the background lights the scene)"), err=True)
    fingerprint = None
    if opts.resume is not None or opts.save_state is not None:
        # The scene's canonical JSON, hashed: 25 ms for the final scene that other renders skip.
        fingerprint = samples_fingerprint(loaded.scene)
    package = None
    if opts.cluster is not None:
        from .cluster import package_scene

        package = package_scene(None if opts.from_stdin else str(opts.scene), reads, loaded, flat, opts.overrides, opts.syntax,
                                opts.width, opts.integrator)
    display = opts.display if opts.display is not None else graph.image.display
    return PreparedScene(flat, Frame.of(graph), features_of(graph), budget_seconds, fingerprint, package, loaded, display)


def run(opts: RenderOptions, started: float) -> None:
    """The whole command; `started` is when it started (time.perf_counter), for the summary.
    Raises Stop for any end but success."""
    scene = prepare(opts)  # a scene error is reported here, once, before any cluster is asked
    if opts.cluster is None:
        render_prepared(opts, scene, started)
        return
    connection = cluster_connection(opts.cluster)
    try:
        render_prepared(opts, scene, started, connection)
    finally:
        connection.close()


def cluster_connection(spec: str):
    """The cluster --cluster names (rt/cluster.py), said on standard error; Stop(1) if it cannot be reached."""
    from .cluster import ClusterError, connect

    try:
        connection = connect(spec)
        say(f"cluster: {connection.description}", err=True)
    except ClusterError as exc:
        raise fail(f"error: {exc}")
    return connection


def cluster_failure(opts: RenderOptions, scene: PreparedScene, exc) -> Stop:
    """Say why a cluster render failed (an rt.cluster.ClusterError) and keep the samples merged before
    it, as a failed write keeps them (rt/outputs.py): in --save-state if given, else rescued to
    a temporary file. The scheduler or the workers going away is the cluster's fault and is said
    without the scene's name; a chunk that fails is said about the scene."""
    from .cluster import ClusterLost

    head = "error: " if isinstance(exc, ClusterLost) else f"error: {opts.scene}: "
    partial = exc.partial
    if partial is None or partial.film.samples == 0:
        nothing = "; no samples were merged, so there is nothing to save" if partial is not None else ""
        return fail(f"{head}{exc}{nothing}")
    return fail(f"{head}{exc}; {save_merged(opts, scene, partial.film)}")


def render_key_of(opts: RenderOptions, frame, fingerprint: str):
    """What a saved state of this render must match (renderer.state.RenderKey)."""
    from renderer.state import RenderKey

    return RenderKey(fingerprint, frame.width, frame.height, opts.max_depth if opts.max_depth is not None else frame.max_depth,
                     opts.seed if opts.seed is not None else frame.seed, frame.integrator, frame.sampler)


def save_merged(opts: RenderOptions, scene: PreparedScene, film) -> str:
    """Save `film` as a state to resume from: in --save-state, else (or if that fails) where
    outputs.rescue finds room. Where it went, as the end of an error line."""
    from renderer.state import save_state
    from scenefmt.files import describe_os_error

    from .outputs import rescue

    fingerprint = scene.fingerprint or samples_fingerprint(scene.loaded.scene)
    key = render_key_of(opts, scene.frame, fingerprint)
    problem = ""
    if opts.save_state is not None:
        try:
            save_state(opts.save_state, film, key)
            return (f"the {film.samples} samples per pixel merged are saved in {opts.save_state} "
                    f"(continue with --resume {opts.save_state})")
        except OSError as exc:
            problem = f"{opts.save_state} cannot be written ({describe_os_error(exc)}), so "
    rescued = rescue(film, key, "stdin" if opts.from_stdin else Path(str(opts.scene)).stem)
    if not rescued:
        return f"{problem}no folder could hold a copy of the {film.samples} samples per pixel merged"
    return (f"{problem}the {film.samples} samples per pixel merged are saved in {' and '.join(str(p) for p in rescued)} "
            f"(continue with --resume {rescued[0]})")


def explain_costs(opts: RenderOptions, scene: PreparedScene, kernel) -> None:
    """--explain: what each expensive effect of the scene costs (rt/effect_costs.py), from short
    renders with `kernel` (the one the render starts with), said on standard error."""
    from renderer.session import scene_graph_with

    from .effect_costs import costs

    graph = scene_graph_with(scene.loaded, opts.width, opts.integrator)
    found = costs(graph, kernel, max_depth=opts.max_depth, seed=opts.seed, threads=opts.threads,
                  say=lambda line: say(line, err=True))
    if not found:
        say("explain: no expensive effect to measure (path depth above 4, media, an environment map, defocus, motion blur, "
            "glossy materials)", err=True)
    for cost in found:
        say(f"cost: {cost.sentence()}", err=True)


def render_prepared(opts: RenderOptions, scene: PreparedScene, started: float, connection=None) -> None:
    """Render a prepared scene and write its images, on the cluster of `connection` if given
    (rt.cluster.Connection). Raises Stop for any end but success; Ctrl-C (SIGINT) or SIGTERM stops
    the render and writes what is rendered (`StopSignals`)."""
    from renderer.variants import first_kernel

    from .cluster import ClusterError  # dask itself is imported only for a cluster

    frame = scene.frame
    budgeted = scene.budget_seconds is not None or opts.noise is not None
    target = sample_target(opts.spp, frame, budgeted)
    if opts.dry_run:
        from .dry_run import dry_run

        # Nothing is kept from a dry run: a stop signal ends it at once (StopSignals' first signal, Aborted).
        with StopSignals(lambda line: say(line, err=True), lambda: True):
            try:
                if opts.explain:
                    chosen = first_kernel(scene.features, opts.kernel)
                    say(f"kernel: {chosen.tag} (the paths compiled in; this scene needs {scene.features.tag}; see "
                        "docs/performance.md)", err=True)
                    explain_costs(opts, scene, chosen)
                dry_run(opts, scene, target, say)
            except ValueError as exc:
                raise fail(f"error: {opts.scene}: {exc}")
            except Aborted as exc:
                say(f"interrupted by {exc.name}: the dry run is stopped", err=True)
                raise Stop(exc.status)
        return

    def render_key():
        assert scene.fingerprint is not None  # prepare computes it for --resume and --save-state
        return render_key_of(opts, frame, scene.fingerprint)

    film = None
    if opts.resume is not None:
        from renderer.state import load_state

        try:
            film = load_state(opts.resume, render_key())
        except (OSError, ValueError, KeyError) as exc:
            raise fail(f"error: --resume: {exc}")
        say(f"resuming {opts.resume}: {film.samples} samples per pixel already rendered", err=True)
        if film.samples >= target:
            # A saved state holds sums, which cannot give samples back: say so rather than
            # write an image with more samples than asked for without a word.
            asked = f"--spp {opts.spp}" if opts.spp is not None else f"the scene's samples_per_pixel {target}"
            say(f"warning: --resume {opts.resume} already holds {film.samples} samples per pixel, "
                f"{'more than' if film.samples > target else 'as many as'} {asked} asks for: nothing more is rendered, "
                f"and the images hold all {film.samples} (a saved state cannot drop samples)", err=True)
    flat, features = scene.flat, scene.features
    if opts.explain:
        chosen = first_kernel(features, opts.kernel)
        say(f"kernel: {chosen.tag} (the paths compiled in; this scene needs {features.tag}; see docs/performance.md)", err=True)
    bar = Progress(target, scene.budget_seconds, opts.noise)
    resumed = film is not None
    with StopSignals(bar.notify, lambda: not resumed and not bar.shown_any) as stop:
        step = "rendering"
        try:
            if opts.explain:  # a signal here ends the command at once: nothing is rendered yet
                explain_costs(opts, scene, first_kernel(features, opts.kernel))
            try:
                result = render_scene(
                    flat, frame, features, target=target, kernel=opts.kernel, threads=opts.threads, connection=connection,
                    package=scene.package, progress=bar, max_depth=opts.max_depth, seed=opts.seed, film=film,
                    should_stop=stop.requested, time_budget=scene.budget_seconds, noise_target=opts.noise,
                    notify=bar.notify, adaptive=opts.adaptive,
                )
            except ValueError as exc:
                raise fail(f"error: {opts.scene}: {exc}")
            except MemoryError as exc:  # the film and the kernels' buffers, allowed by the estimate but not there
                from scenefmt.assets import memory_message

                raise fail(f"error: {opts.scene}: {memory_message(exc, 'render it')}")
            except ClusterError as exc:
                if connection is not None and connection.client.status != "running":
                    connection.close()  # now: a client left trying to reconnect would log its failure later
                raise cluster_failure(opts, scene, exc)
            stats, film = result.stats, result.film
            if film.samples == 0:
                say("interrupted before the first pass finished: nothing to save", err=True)
                raise Stop(stop.status)
            from .outputs import write_outputs  # the state first; a failed write rescues the samples

            passes, passes_failed = None, None
            if opts.passes:
                step = "passes"
                passes, passes_failed = compute_passes_for(opts, scene, film, bar.notify)
            step = "writing"
            estimate = write_outputs(opts, film, render_key() if scene.fingerprint is not None else None, fail, passes, scene.display)
            # After the raw images, which a failure here leaves written; not after a stop signal, which
            # asked for what is rendered to be saved, and no more (the passes may take a compile first).
            denoised = None
            if opts.denoise and not stop.requested():
                from .denoised_files import write_denoised

                denoised = write_denoised(opts, film, flat, fail, passes, scene.display)
        except Aborted as exc:
            # Each file is written under a temporary name and renamed: one is whole or not written.
            if exc.first:
                say("interrupted before the first pass finished: nothing to save", err=True)
            elif step == "writing":
                say(f"aborted by a second {exc.name} while writing: a file not yet in place is not written", err=True)
            else:
                say(f"aborted by a second {exc.name}: nothing is saved", err=True)
            raise Stop(exc.status)
    total = time.perf_counter() - started
    extra = opts.denoised if denoised is not None else ()
    written = ", ".join(str(p) for p in (opts.out, opts.hdr, *extra, opts.noise_map, opts.samples_map, opts.save_state)
                        if p is not None)
    if passes:
        from .passes import layout_of

        if layout_of(opts.passes_as, opts.hdr) == "layers":
            written = written.replace(str(opts.hdr), f"{opts.hdr} (with the layers {', '.join(passes)})", 1)
        else:
            written += "".join(f", {path}" for _, path in opts.pass_outputs)
    # A kernel compiled during the render is not rendering time (nor counted against --time).
    compiling = f"+ {fmt_seconds(stats.compile_seconds)} compiling; " if stats.compile_seconds >= 0.05 else ""
    say(
        f"wrote {written}: {film.width}x{film.height}, {film.samples} spp ({frame.integrator}), {fmt_seconds(stats.seconds)} rendering "
        f"({compiling}{fmt_seconds(total)} in all), {stats.rays / 1e6:.1f} M rays, {stats.rays_per_second / 1e6:.2f} Mrays/s"
    )
    if denoised is not None:
        say(f"denoise: {denoised.sentence()}", err=True)
    elif opts.denoise:
        say("denoise: not done, the render was stopped by a signal (the raw images are written)", err=True)
    if film.samples < 2:
        say("noise: not estimated (it takes at least 2 samples per pixel)")
    else:
        say(noise_line(estimate))
    untrusted = estimate.warning or stats.noise_warning
    if untrusted is not None and film.samples >= 2:
        say(f"warning: {untrusted}", err=True)
    training = stats.guide_training
    if training is not None:
        say(f"guide: learned from {sum(training.paths):,} training paths in {fmt_seconds(training.total_seconds)} "
            f"(part of the rendering time), {training.guide_rows:,} rows", err=True)
    if stats.pixels_done is not None:
        say(f"adaptive sampling: {100 * stats.pixels_done:.0f}% of the pixels stopped before {film.samples} spp, "
            f"{film.counts.mean():.0f} samples per pixel on average", err=True)
    if stats.stop_reason == "time":
        say(f"stopped: the {budget_text(opts.time_budget or '')} time budget is spent", err=True)
    elif stats.stop_reason == "noise":
        say(f"stopped: {noise_reached(stats.noise_high, opts.noise or 0.0, bound=True)}", err=True)
    elif budgeted and not stats.interrupted:
        say(f"stopped at the cap of {target} samples per pixel before the budget was reached", err=True)
    if stats.bad_samples:
        say(f"warning: {stats.bad_samples} samples were not finite and were left out (please report this scene)", err=True)
    if stats.interrupted:
        say(f"interrupted: the image holds {film.samples} of {target} samples per pixel", err=True)
        raise Stop(stop.status)
    if opts.denoise and denoised is None:  # the signal came after the last pass, before the denoise
        raise Stop(stop.status)
    if passes_failed is not None:
        raise fail(passes_failed)


def compute_passes_for(opts: RenderOptions, scene: PreparedScene, film, notify) -> tuple[Optional[dict], Optional[str]]:
    """--passes of a finished render: (the passes, None), or (None, the error line) if they could
    not be computed, in which case the other outputs are still written and the command fails
    after them (the render is never lost to its passes)."""
    from .passes import compute_passes

    seed = opts.seed if opts.seed is not None else scene.frame.seed
    try:
        return compute_passes(opts.passes, scene.flat, film, seed=seed, notify=notify), None
    except MemoryError as exc:
        from scenefmt.assets import memory_message

        return None, f"error: --passes: {memory_message(exc, 'compute the passes')}; the other files are written"
    except ValueError as exc:
        return None, f"error: --passes: {exc}; the other files are written"


def batch_options(opts: RenderOptions, scenes: list) -> list[RenderOptions]:
    """The options of each scene of a batch (`rt render a.yaml b.yaml ...`): its image named after it,
    in the folder -o names; --hdr gives only the format of the linear image written beside it.
    Raises Stop(2) for options that name one file, or two scenes whose images would share a name."""
    import dataclasses
    import os

    for name, value in (("--save-state", opts.save_state), ("--resume", opts.resume), ("--noise-map", opts.noise_map),
                        ("--samples-map", opts.samples_map)):
        if value is not None:
            say(f"error: {name} names one file: render one scene at a time to use it", err=True)
            raise Stop(2)
    folder = opts.output
    # A missing folder is made below; an existing file, or a name that reads as an image, is a mistake.
    if folder is not None and not folder.is_dir() and (folder.exists() or folder.suffix.lower() in suffixes_of("image") + suffixes_of("hdr")):
        raise fail(f"error: -o {folder}: with several scenes, -o names the folder to write their images in, and this is not one")
    hdr_suffix = None
    if opts.hdr is not None:
        hdr_suffix = "." + str(opts.hdr).lower().lstrip(".")
        if hdr_suffix not in suffixes_of("hdr"):
            raise fail(f"error: --hdr {opts.hdr}: with several scenes, give the format only: --hdr exr or --hdr pfm")
        if BY_SUFFIX[hdr_suffix].needs_exr:  # once for the batch, rather than once for each scene
            from scenefmt.hdr_files import EXR_MISSING, exr_available

            if not exr_available():
                raise fail(f"error: --hdr {opts.hdr}: {EXR_MISSING}")
    from .outputs import file_key

    # An image may not replace a scene of the batch: one rendered earlier would be lost, a later one changed.
    scene_files = {file_key(scene): scene for scene in scenes if str(scene) != "-"}
    out = []
    seen: dict[str, Path] = {}
    for scene in scenes:
        stem = "stdin" if str(scene) == "-" else Path(scene).stem
        png = (folder or Path(".")) / f"{stem}{PNG}"
        # --denoise's image too: a.yaml's a.denoised.png is a.denoised.yaml's image.
        for written in (png, *dataclasses.replace(opts, output=png, hdr=None).denoised):
            key = os.path.abspath(written)
            if key in seen:
                raise fail(f"error: {seen[key]} and {scene} would both write {written}: rename one, or render them apart")
            seen[key] = scene
        hdr = png.with_suffix(hdr_suffix) if hdr_suffix else None
        for image in (png, hdr):
            if image is not None and file_key(image) in scene_files:
                raise fail(f"error: the image {image} of {scene} is the scene file {scene_files[file_key(image)]} of this batch: "
                           "rendering would overwrite it; write the images elsewhere with -o DIR")
        out.append(dataclasses.replace(opts, scene=Path(scene), output=png, hdr=hdr))
    if folder is not None and not folder.is_dir() and not opts.dry_run:  # `-o renders/` on a fresh checkout
        try:  # after every other check, so that a refused batch leaves nothing behind
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:  # a parent that is a file, a read-only place
            raise fail(f"error: -o {folder}: cannot create the folder ({exc.strerror or exc})")
    return out


def run_batch(opts: RenderOptions, scenes: list) -> None:
    """Render several scenes one after the other in this process (the kernels load once). A scene
    that fails, for whatever reason, is reported in one line and the others still render; raises
    Stop(1) at the end if any failed, Stop(130 or 143) at once on Ctrl-C or SIGTERM."""
    each = batch_options(opts, scenes)
    failed = []
    connection = cluster_connection(opts.cluster) if opts.cluster is not None else None
    try:
        for i, scene_opts in enumerate(each, 1):
            say(f"[{i}/{len(each)}] {scene_opts.scene}", err=True)
            started = time.perf_counter()
            try:
                render_prepared(scene_opts, prepare(scene_opts), started, connection)
            except Stop as stop:
                if stop.status in INTERRUPTED:
                    say(f"interrupted: {len(each) - i} scene(s) not rendered", err=True)
                    raise
                failed.append(str(scene_opts.scene))
            except Exception as exc:  # a fault of one scene (a bug, a full disk) must not cost the others
                # Its kind only: the text of an exception nobody foresaw may hold anything, a file's lines too.
                fail(f"error: {scene_opts.scene}: an unexpected failure ({type(exc).__name__}); the other scenes go on "
                     "(please report this scene)")
                failed.append(str(scene_opts.scene))
    finally:
        if connection is not None:
            connection.close()
    if failed:
        raise fail(f"error: {len(failed)} of {len(each)} scenes failed: {', '.join(failed)}")
