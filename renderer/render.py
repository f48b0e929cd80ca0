"""Render a scene graph in progressive passes into a Film.

Each pass adds a few samples to every pixel; passes are sized to take about a quarter of a
second, so progress can be shown and a render can stop cleanly between passes. A pass that
takes longer (one sample of a very large image can take a minute) is rendered in bands of rows
that each take about as long, and a stop request is honoured between bands: the unfinished
pass is taken back, so that every pixel of the film keeps the same number of samples. Because
the random numbers are keyed by (seed, pixel, sample, dimension), neither the passes' nor the
bands' split changes the image.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Optional

import numpy as np

from .film import Film, relative_noise
from .flat import FlatScene, Frame
from .jit_cache import configure as kernel_cache_folder
from .variants import (GENERAL, KernelFeatures, features_of, first_kernel, is_compiled, kernels_for, mark_compiled, seconds_left,
                       worth_specialising)

if TYPE_CHECKING:
    from scenefmt.graph import SceneGraph

PASS_SECONDS = 0.25
MIN_SAMPLES_FOR_NOISE = 8
# The first band of a render, before its speed is known, in rows per render thread: small, so
# that a stop right after the start waits little, and enough to give every thread rows.
FIRST_BAND_ROWS_PER_THREAD = 2
# A band may be this many times the rows of the band before it: the first bands' speed is
# measured on few rows.
BAND_GROWTH = 8


@dataclass
class RenderStats:
    samples: int = 0
    target_samples: int = 0
    seconds: float = 0.0
    rays: int = 0
    bad_samples: int = 0  # samples that were not finite (a bug): dropped and reported
    interrupted: bool = False
    stop_reason: str = "samples"  # samples | time | noise | interrupted
    noise: float = float("inf")  # relative RMS noise estimate at the end (see film.estimate_noise)
    kernel_seconds: float = 0.0  # compiling the kernels, or loading them from Numba's disk cache
    compile_seconds: float = 0.0  # the part of kernel_seconds spent compiling: never counted in `seconds`
    first_pass_seconds: float = 0.0
    features: Optional[KernelFeatures] = None  # the kernel's feature set

    @property
    def rays_per_second(self) -> float:
        return self.rays / self.seconds if self.seconds > 0 else 0.0


@dataclass
class RenderResult:
    film: Film
    stats: RenderStats = field(default_factory=RenderStats)


def render(graph: SceneGraph, *, flat: Optional[FlatScene] = None, **options) -> RenderResult:
    """Render `graph` (its image settings, unless overridden) until `samples` per pixel are done.

    `flat` is the graph already flattened (compile.compile_scene); `options` are those of
    `render_flat` (samples, max_depth, seed, film, progress, should_stop, pass_seconds,
    time_budget, noise_target, features).
    """
    if flat is None:
        from .compile import compile_scene

        flat = compile_scene(graph)
    return render_flat(flat, Frame.of(graph), needed=features_of(graph), **options)


def report_progress(film: Film, stats: RenderStats, progress: Optional[Callable[[RenderStats], None]],
                    noise_target: Optional[float], last_noise: float) -> tuple[bool, float]:
    """After samples were added to `film`: refresh the noise estimate where it is needed, show
    progress, and say whether the noise target is reached; also the time of the last estimate.

    The estimate costs a pass over the film: it is made for a noise target, else for the
    progress display at most once a second. It needs a few samples before it is trusted to stop on.
    """
    now = time.perf_counter()
    if noise_target is not None or (progress is not None and now - last_noise >= 1.0):
        stats.noise = relative_noise(film)
        last_noise = now
    if progress is not None:
        progress(stats)
    reached = noise_target is not None and film.samples >= MIN_SAMPLES_FOR_NOISE and stats.noise <= noise_target
    return reached, last_noise


class Bands:
    """Where each band of rows of a pass ends: bands of about `seconds`, at the speed measured on
    the bands before (a band's rows are positions in the kernel's row order, spread over the
    whole image, so their speed is the image's)."""

    def __init__(self, height: int, seconds: float, threads: int):
        self.height = height
        self.seconds = seconds
        self.least = min(height, max(1, threads))  # a row for each thread
        self.rows = min(height, FIRST_BAND_ROWS_PER_THREAD * self.least)  # the last band's rows
        self.row_seconds = 0.0  # seconds per row and sample, once measured

    def end(self, start: int, samples: int) -> int:
        """The end of the band that starts at row position `start` of a pass of `samples`."""
        rows = self.rows
        if self.row_seconds > 0:
            rows = min(BAND_GROWTH * self.rows, int(self.seconds / (self.row_seconds * samples)))
        rows = max(rows, self.least)
        if self.height - start - rows < rows // 2:  # no sliver of a band at the end of the pass
            rows = self.height - start
        return min(self.height, start + rows)

    def measured(self, rows: int, samples: int, seconds: float) -> None:
        self.rows = rows
        self.row_seconds = seconds / (rows * samples)


class PassUndo:
    """The film rows and counts a pass has overwritten, band by band, so that a pass stopped
    halfway can be taken back. It holds at most a copy of the film's sums, and only while a pass
    of more than one band is under way."""

    def __init__(self, film: Film, row_rays: np.ndarray, row_bad: np.ndarray):
        self.film = film
        self.counts = (row_rays, row_bad, row_rays.copy(), row_bad.copy())
        self.saved: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def keep(self, rows: np.ndarray) -> None:
        """Before a band renders into the film's `rows`."""
        self.saved.append((rows, self.film.total[rows], self.film.total_sq[rows]))

    def undo(self) -> None:
        for rows, total, total_sq in self.saved:
            self.film.total[rows] = total
            self.film.total_sq[rows] = total_sq
        row_rays, row_bad, rays, bad = self.counts
        row_rays[:] = rays
        row_bad[:] = bad
        self.saved.clear()


def render_flat(
    flat: FlatScene,
    frame: Frame,
    *,
    samples: Optional[int] = None,
    max_depth: Optional[int] = None,
    seed: Optional[int] = None,
    film: Optional[Film] = None,
    progress: Optional[Callable[[RenderStats], None]] = None,
    should_stop: Optional[Callable[[], bool]] = None,
    pass_seconds: float = PASS_SECONDS,
    time_budget: Optional[float] = None,
    noise_target: Optional[float] = None,
    needed: KernelFeatures = GENERAL,
    features: Optional[KernelFeatures] = None,
    kernel: str = "auto",
    notify: Optional[Callable[[str], None]] = None,
) -> RenderResult:
    """Render the flat scene `flat` with the settings of `frame` (unless overridden) until
    `samples` per pixel are done.

    `film` continues an earlier render with the same seed; `should_stop` is polled between
    passes and between the bands of rows of a long pass, and ends the render early: the film
    then holds every finished pass (a pass it interrupts is taken back). With
    `time_budget` (seconds of rendering) or `noise_target` (relative RMS noise, see
    `film.estimate_noise`) the render also stops when the time is spent or the estimated noise
    falls below the target; `samples` is then the cap. `pass_seconds` is about how long a pass,
    and a band of a pass, should take.

    `needed` is the kernel paths the scene reaches (`variants.features_of` of its graph; every
    path if not given). Any kernel that has them gives the same image. `kernel` chooses
    ("auto", "general" or "specialised", see `variants.first_kernel`); with "auto" a render
    that starts with the general kernel switches to the specialised one when the rest of it,
    as forecast from the speed and noise measured so far (`variants.seconds_left`), is long
    enough to repay the compile (`variants.worth_specialising`). `features` names a kernel
    outright. `notify` receives a line before a compile or a switch. Time spent compiling or
    loading kernels is never counted as rendering time (`stats.seconds`, the time budget).
    """
    import numba

    from .kernels.integrator import row_stride

    width, height = frame.width, frame.height
    target = samples if samples is not None else frame.samples
    depth = max_depth if max_depth is not None else frame.max_depth
    seed = seed if seed is not None else frame.seed
    estimator = frame.estimator
    stats = RenderStats(target_samples=target)
    if features is not None and not features.covers(needed):
        raise ValueError(f"the kernel {features.tag!r} lacks paths the scene reaches: {needed.tag!r}")
    stats.features = features if features is not None else first_kernel(needed, kernel)
    may_switch = features is None and kernel == "auto" and stats.features != needed
    if film is None:
        film = Film.empty(width, height)
    stats.samples = film.samples
    row_rays = np.zeros(height, np.int64)
    row_bad = np.zeros(height, np.int64)
    stride = row_stride(height)
    bands = Bands(height, pass_seconds, numba.get_num_threads())

    def load(chosen: KernelFeatures):
        """The render pass of kernel `chosen`, compiled or loaded before anything is timed."""
        compiling = not is_compiled(chosen)
        if notify is not None and compiling:
            notify(f"compiling the renderer's {chosen.tag!r} kernel: 8 to 30 seconds on 2 cores, once; cached in "
                   f"{kernel_cache_folder()}")
        t0 = time.perf_counter()
        chosen_pass = kernels_for(chosen).render_pass
        chosen_pass(flat, 1, 1, seed, 0, 0, depth, estimator, np.zeros((1, 1, 3)), np.zeros((1, 1, 3)), row_rays[:1], row_bad[:1], 0, 1)
        spent = time.perf_counter() - t0
        stats.kernel_seconds += spent
        if compiling:
            stats.compile_seconds += spent
        mark_compiled(chosen)
        return chosen_pass, spent

    def one_pass(n: int) -> bool:
        """Add n samples per pixel in bands of rows; False, with the film as it was, if
        `should_stop` asked to stop between two bands."""
        undo = None
        start = 0
        while start < height:
            if start > 0 and should_stop is not None and should_stop():
                undo.undo()
                return False
            end = bands.end(start, n)
            if end - start < height:
                undo = undo or PassUndo(film, row_rays, row_bad)
                undo.keep((np.arange(start, end) * stride) % height)
            t0 = time.perf_counter()
            render_pass(flat, width, height, seed, film.samples, n, depth, estimator, film.total, film.total_sq, row_rays, row_bad,
                        start, end)
            bands.measured(end - start, n, time.perf_counter() - t0)
            start = end
        return True

    render_pass, _ = load(stats.features)
    batch = 1
    stats_start_samples = film.samples
    render_start = time.perf_counter()
    paused = 0.0  # seconds spent switching kernels since render_start: not rendering time

    def clock() -> float:
        return time.perf_counter() - render_start - paused

    last_noise = render_start
    while film.samples < target:
        if should_stop is not None and should_stop():
            stats.interrupted = True
            stats.stop_reason = "interrupted"
            break
        elapsed = clock()
        if time_budget is not None and elapsed >= time_budget:
            stats.stop_reason = "time"
            break
        n = min(batch, target - film.samples)
        if time_budget is not None and stats.first_pass_seconds > 0 and film.samples > 0:
            # Fit the pass into the time left, at the speed measured so far.
            per_sample = stats.seconds / max(1, film.samples - stats_start_samples)
            n = max(1, min(n, int((time_budget - elapsed) / per_sample))) if per_sample > 0 else n
        t0 = time.perf_counter()
        if not one_pass(n):
            stats.interrupted = True
            stats.stop_reason = "interrupted"
            break
        dt = time.perf_counter() - t0
        if stats.first_pass_seconds == 0.0:
            stats.first_pass_seconds = dt
        film.samples += n
        stats.samples = film.samples
        stats.rays = int(row_rays.sum())
        stats.bad_samples = int(row_bad.sum())
        stats.seconds = clock()
        reached, last_noise = report_progress(film, stats, progress, noise_target, last_noise)
        if reached:
            stats.stop_reason = "noise"
            break
        # Size the next pass to take about pass_seconds.
        per_sample = dt / n if n else dt
        if may_switch:
            left = seconds_left(per_sample, film.samples, target, noise=stats.noise, noise_target=noise_target,
                                time_left=time_budget - clock() if time_budget is not None else None)
            if left is not None and worth_specialising(left):
                may_switch = False
                if notify is not None:
                    notify(f"switching to the kernel specialised to this scene ({needed.tag}): about {left:.0f} s of rendering left")
                render_pass, spent = load(needed)
                paused += spent
                stats.features = needed
        batch = max(1, min(4 * n, int(pass_seconds / per_sample) if per_sample > 0 else 4 * n))
    stats.seconds = clock()
    stats.rays = int(row_rays.sum())
    stats.bad_samples = int(row_bad.sum())
    stats.noise = relative_noise(film)
    return RenderResult(film, stats)
