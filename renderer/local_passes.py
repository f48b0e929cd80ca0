"""The local executor: passes over the whole image in this process, in bands of rows.

It keeps the protocol of `executor.py`; the session (session.py) decides when to stop.
"""

from __future__ import annotations

import time
from typing import Optional

import numpy as np

from .executor import KernelTime, Plan, Step
from .film import Film
from .flat import INTEGRATOR_CAUSTICS, FlatScene
from .jit_cache import general_folder as kernel_cache_folder
from .sampling import Sampling, uniform_sampling
from .variants import KernelFeatures, compile_wait, is_compiled, kernel_set, mark_compiled

# The first band of a render, before its speed is known, in rows per render thread: small, so
# that a stop right after the start waits little, and enough to give every thread rows.
FIRST_BAND_ROWS_PER_THREAD = 2
# A band may be this many times the rows of the band before it: the first bands' speed is
# measured on few rows.
BAND_GROWTH = 8
# A pass should take about this long: short enough for progress and a stop between passes.
PASS_SECONDS = 0.25
# integrator caustics: the most memory a pass's photon shares may take (its samples x pixels x 3
# doubles); the photons' own values take 4/3 of it while they are added up (scenefmt.bounds counts both).
SPLAT_BYTES = 1 << 26


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
        self.saved.append((rows, [array[rows] for array in self.film.sums]))

    def undo(self) -> None:
        for rows, arrays in self.saved:
            for array, saved in zip(self.film.sums, arrays):
                array[rows] = saved
        row_rays, row_bad, rays, bad = self.counts
        row_rays[:] = rays
        row_bad[:] = bad
        self.saved.clear()


class LocalPasses:
    """The executor of this process: each step is a pass that adds a few samples to every pixel
    with the kernel's `render_pass`, sized to take about `pass_seconds`. A pass that takes
    longer is rendered in bands of rows (`Bands`), and a stop request is honoured between bands:
    the unfinished pass is taken back (`PassUndo`), so every pixel keeps the same number of
    samples. The random numbers are keyed by (seed, pixel, sample, dimension), so neither the
    passes' nor the bands' split changes the image."""

    can_switch_kernel = True
    stops_on_time_before_first_step = True

    def __init__(self, flat: FlatScene, width: int, height: int, *, seed: int, depth: int, estimator: int,
                 pass_seconds: float, threads: int, sampling: Optional[Sampling] = None):
        from .tracing.integrator import row_stride

        self.flat = flat
        self.sampling = sampling if sampling is not None else uniform_sampling()
        self.width, self.height = width, height
        self.seed, self.depth, self.estimator = seed, depth, estimator
        self.pass_seconds = pass_seconds
        self.row_rays = np.zeros(height, np.int64)
        self.row_bad = np.zeros(height, np.int64)
        self.stride = row_stride(height)
        self.bands = Bands(height, pass_seconds, threads)
        self.batch = 1  # samples in the next pass
        self.film: Optional[Film] = None
        self.render_pass = None
        self.kernels = None

    @classmethod
    def for_frame(cls, flat: FlatScene, frame, *, seed: Optional[int] = None, max_depth: Optional[int] = None,
                  pass_seconds: float = PASS_SECONDS) -> "LocalPasses":
        """The executor for `flat` with the image settings of `frame` (a flat.Frame), `seed` and
        `max_depth` overriding the scene's, on Numba's render threads."""
        from . import target

        return cls(flat, frame.width, frame.height, seed=seed if seed is not None else frame.seed,
                   depth=max_depth if max_depth is not None else frame.max_depth, estimator=frame.estimator,
                   pass_seconds=pass_seconds, threads=target.thread_count(), sampling=uniform_sampling(frame.sampler))

    def _load(self, chosen: KernelFeatures, notify) -> KernelTime:
        """The render pass of kernel `chosen`, compiled or loaded (and run once on one pixel)
        before anything is timed."""
        compiling = not is_compiled(chosen)
        if notify is not None and compiling:
            notify(f"compiling the renderer's {chosen.tag!r} kernel: {compile_wait(chosen)}, once; cached in "
                   f"{kernel_cache_folder()}")
        t0 = time.perf_counter()
        kernels = kernel_set(chosen)
        chosen_pass = kernels.render_pass
        chosen_pass(self.flat, 1, 1, self.seed, 0, 0, self.depth, self.estimator, self.sampling, Film.empty(1, 1).sums,
                    self.row_rays[:1], self.row_bad[:1], 0, 1)
        if self.estimator == INTEGRATOR_CAUSTICS:
            # The photons' kernel too, before anything is timed (no sample asked: it only compiles or loads).
            kernels.caustic_splats(self.flat, 1, 1, self.seed, 0, 0, self.depth)
        spent = time.perf_counter() - t0
        mark_compiled(chosen)
        self.render_pass = chosen_pass
        self.kernels = kernels
        return KernelTime(spent, spent if compiling else 0.0)

    def prepare(self, notify=None):
        """Before the first sample: a guided render's training (guide_training.train_guide), with
        the kernel `start` loaded; the guide goes into this executor's flat scene. What the
        training cost, or None for any other estimator."""
        from .flat import INTEGRATOR_GUIDED

        if self.estimator != INTEGRATOR_GUIDED:
            return None
        from .guide_training import train_guide

        if notify is not None:
            notify("learning where light comes from (the guide's training passes)")
        self.flat, training = train_guide(self.flat, self.width, self.height, self.seed, self.depth,
                                          self.sampling.sampler, self.kernels)
        return training

    def set_sampling(self, sampling: Sampling) -> None:
        """Render the next passes with `sampling` (adaptive sampling's rule, once its pilot is in).
        Pixels it stops cost next to nothing in later passes (the kernel leaves them at once), so
        the passes, sized by their measured time, grow as pixels finish."""
        self.sampling = sampling

    def start(self, film: Film, features: KernelFeatures, notify=None) -> KernelTime:
        self.film = film
        return self._load(features, notify)

    def switch_kernel(self, features: KernelFeatures, notify=None) -> KernelTime:
        return self._load(features, notify)

    def _samples_wanted(self, plan: Plan) -> int:
        """The next pass's samples: the batch, within the samples left and, under a time budget,
        the time left at the speed measured so far."""
        film = self.film
        n = min(self.batch, plan.target - film.samples)
        if self.estimator == INTEGRATOR_CAUSTICS:
            # A pass holds its photons' shares of every pixel for each of its samples: at most
            # SPLAT_BYTES of them.
            n = max(1, min(n, SPLAT_BYTES // (24 * self.width * self.height)))
        if plan.time_left is not None and plan.steps > 0 and film.samples > 0:
            per_sample = plan.seconds / max(1, film.samples - plan.start)
            n = max(1, min(n, int(plan.time_left() / per_sample))) if per_sample > 0 else n
        return n

    def _one_pass(self, n: int, should_stop) -> bool:
        """Add n samples per pixel in bands of rows; False, with the film as it was, if
        `should_stop` asked to stop between two bands."""
        film, height = self.film, self.height
        undo = None
        start = 0
        splats = None
        if self.estimator == INTEGRATOR_CAUSTICS and len(self.flat.caustic_f) and len(self.flat.caustic_lf):
            # Every sample's photons first: they land anywhere in the image (tracing/caustics.py).
            # A scene with no target or no light to send photons has none: it renders as mis.
            splats = self.kernels.caustic_splats(self.flat, self.width, height, self.seed, film.samples, n, self.depth)
        while start < height:
            if start > 0 and should_stop is not None and should_stop():
                undo.undo()
                return False
            end = self.bands.end(start, n)
            if end - start < height:
                undo = undo or PassUndo(film, self.row_rays, self.row_bad)
                undo.keep((np.arange(start, end) * self.stride) % height)
            t0 = time.perf_counter()
            self.render_pass(self.flat, self.width, height, self.seed, film.samples, n, self.depth, self.estimator,
                             self.sampling, film.sums, self.row_rays, self.row_bad, start, end, splats=splats)
            self.bands.measured(end - start, n, time.perf_counter() - t0)
            start = end
        return True

    def advance(self, plan: Plan, should_stop=None) -> Optional[Step]:
        n = self._samples_wanted(plan)
        rays, bad = int(self.row_rays.sum()), int(self.row_bad.sum())
        t0 = time.perf_counter()
        if not self._one_pass(n, should_stop):
            return None
        dt = time.perf_counter() - t0
        self.film.samples += n
        # Size the next pass to take about pass_seconds.
        per_sample = dt / n if n else dt
        self.batch = max(1, min(4 * n, int(self.pass_seconds / per_sample) if per_sample > 0 else 4 * n))
        return Step(n, int(self.row_rays.sum()) - rays, int(self.row_bad.sum()) - bad, dt)

    def close(self) -> None:
        pass
