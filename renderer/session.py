"""One render session: a loaded scene -> flat tables -> kernel choice -> an executor's steps -> film -> result.

Every front end renders through here: `rt render`, `rt.render` and `rt watch` in this process
(`local_passes.LocalPasses`), and `--cluster` on Dask workers (`rt.cluster.ClusterRounds`); the
cluster's workers build their scene with the same `flatten_loaded`. The front ends load the
scene their own way (a file, standard input, a dict, a kept scene) and present the result their
own way; the steps between, and the progressive loop, are written once:

- `flatten_loaded`: the loaded scene with a width and an integrator applied, as flat tables;
- `choose_kernel`: the kernel to start with and whether `--kernel auto` may switch later;
- `render_progressively`: ask the executor for steps until the samples are done, the time
  budget is spent, the noise target is reached or a stop is asked for; keep the statistics, show
  progress, switch to the specialised kernel when the forecast says it pays.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Optional

from .executor import ExecutorFailed, KernelTime, Plan
from .error_estimate import VarianceTrend
from .film import Film, estimate_noise, relative_noise
from .forecast import ForecastTracker
from .rare_paths import RarePathPrior, image_mean
from .variants import GENERAL, KernelFeatures, first_kernel, seconds_left, worth_specialising

# Below this many samples per pixel the noise estimate is not trusted to stop a render on.
MIN_SAMPLES_FOR_NOISE = 8
# The progress display refreshes its noise estimate (a pass over the film) at most this often.
NOISE_DISPLAY_SECONDS = 1.0
# Under a noise target the full estimate (a pass over the film's batches) is made at most once a
# NOISE_DISPLAY_SECONDS, and at most once per this many times its own cost in rendering time.
FULL_ESTIMATE_SHARE = 10.0
# Films of at most this many pixels refresh the cheap estimate (under a millisecond) after every
# step, so that the trend of the spread per sample is seen on short renders too.
TREND_EVERY_STEP_PIXELS = 256 * 256


@dataclass
class RenderStats:
    samples: int = 0
    target_samples: int = 0
    seconds: float = 0.0
    rays: int = 0
    bad_samples: int = 0  # samples that were not finite (a bug): dropped and reported
    interrupted: bool = False
    stop_reason: str = "samples"  # samples | time | noise | interrupted
    noise: float = float("inf")  # relative RMS noise at the end: the cheap figure of film.relative_noise
    # The upper end of the error's 95% interval at the last full estimate (film.estimate_noise), what a
    # noise target stops on; inf until one is made (only under a noise target).
    noise_high: float = float("inf")
    # Why the error estimate cannot be trusted, when the render saw it: the spread per sample grew
    # as no sound estimate would (error_estimate.VarianceTrend), or the last full estimate warned.
    noise_warning: Optional[str] = None
    kernel_seconds: float = 0.0  # compiling the kernels, or loading them from Numba's disk cache
    compile_seconds: float = 0.0  # the part of kernel_seconds spent compiling: never counted in `seconds`
    first_pass_seconds: float = 0.0  # rendering seconds until the first step of samples was in the film
    features: Optional[KernelFeatures] = None  # the kernel's feature set
    # Where a render with a noise target or a time budget is expected to stop (renderer/forecast.py):
    # None until its pilot is done, then refreshed after each step.
    forecast: Optional[object] = None
    pixels_done: Optional[float] = None  # adaptive sampling: the share of pixels stopped (None: not adaptive)
    # A guided render's training (guide_training.GuideTraining): its paths and seconds, part of `seconds`.
    guide_training: Optional[object] = None

    @property
    def rays_per_second(self) -> float:
        return self.rays / self.seconds if self.seconds > 0 else 0.0


@dataclass
class RenderResult:
    film: Film
    stats: RenderStats = field(default_factory=RenderStats)


def scene_graph_with(loaded, width: Optional[int] = None, integrator: Optional[str] = None):
    """The scene graph of a loaded scene (scenefmt.validation.LoadedScene) with a width and an
    integrator applied (None keeps the file's)."""
    from .compile import with_integrator, with_width

    graph = loaded.graph if width is None else with_width(loaded.graph, width)
    if integrator is not None:
        graph = with_integrator(graph, integrator)
    return graph


def flatten_loaded(loaded, width: Optional[int] = None, integrator: Optional[str] = None):
    """(graph, flat tables) of a loaded scene with a width and an integrator applied; raises
    SceneError (the film too big for memory) or ValueError (an image that does not decode, or no
    memory left to flatten it). The one way from a loaded scene to the kernels' tables, for every
    front end and for the cluster's workers."""
    from scenefmt.bounds import check_memory

    from .compile import compile_scene

    graph = scene_graph_with(loaded, width, integrator)
    estimate = check_memory(graph, loaded.document)  # the width changes the film's size
    try:
        return graph, compile_scene(graph)
    except MemoryError as exc:  # the estimate allowed it, but the memory is not there (others use it)
        from scenefmt.assets import memory_message

        raise ValueError(memory_message(exc, "flatten the scene", estimate.total)) from None


def choose_kernel(needed: KernelFeatures, kernel: str = "auto",
                  features: Optional[KernelFeatures] = None) -> tuple[KernelFeatures, bool]:
    """The kernel to start with, and whether the render may switch to the one specialised to
    `needed` later. `features` names a kernel outright (it must cover `needed`); else `kernel`
    chooses ("auto", "general" or "specialised", see `variants.first_kernel`), and only "auto"
    switches."""
    if features is not None:
        if not features.covers(needed):
            raise ValueError(f"the kernel {features.tag!r} lacks paths the scene reaches: {needed.tag!r}")
        return features, False
    chosen = first_kernel(needed, kernel)
    return chosen, kernel == "auto" and chosen != needed


class NoiseTarget:
    """When a render with a noise target may stop: the upper end of the error's 95% interval
    (film.estimate_noise) is at or below the target, and nothing says the estimate cannot be
    trusted (neither the estimate's heavy-tail warning nor the trend of the spread per sample).

    The full estimate is a pass over the film and its batches (about 0.25 s of CPU at 600x600):
    it is made at most once a NOISE_DISPLAY_SECONDS and once per FULL_ESTIMATE_SHARE times its own
    cost, so it never takes more than a tenth of the rendering time; on a small film (at most
    TREND_EVERY_STEP_PIXELS, a few milliseconds), after every step.
    """

    def __init__(self, target: float):
        self.target = target
        self.next_at = float("-inf")  # the time before which no full estimate is made

    def reached(self, film: Film, stats: RenderStats, now: float) -> bool:
        if film.samples < MIN_SAMPLES_FOR_NOISE or now < self.next_at:
            return False
        t0 = time.perf_counter()
        estimate = estimate_noise(film)
        cost = time.perf_counter() - t0
        if film.width * film.height > TREND_EVERY_STEP_PIXELS:  # not a small film: at most once a second, a tenth of the time
            self.next_at = now + max(NOISE_DISPLAY_SECONDS, cost * FULL_ESTIMATE_SHARE)
        stats.noise_high = estimate.high
        stats.noise_warning = estimate.warning or stats.noise_warning
        return estimate.high <= self.target and stats.noise_warning is None


def report_progress(film: Film, stats: RenderStats, progress: Optional[Callable[[RenderStats], None]],
                    noise_target: Optional[float], last_noise: float, trend: Optional[VarianceTrend] = None,
                    target: Optional[NoiseTarget] = None, prior: Optional[RarePathPrior] = None,
                    tracker: Optional[ForecastTracker] = None, step=None) -> tuple[bool, float]:
    """After samples were added to `film` (by `step`): refresh the noise estimate where it is
    needed, the forecast (`tracker`) where there is one, show progress, and say whether the noise
    target is reached; also the time of the last estimate.

    The cheap estimate (film.relative_noise) costs a pass over the film's sums: it is made for a
    noise target or a small film after every step, else at most once a second (for the progress
    display and the trend), and each one feeds `trend`
    (whose warning goes to `stats.noise_warning`). The stop itself is `target`'s (a NoiseTarget of
    `noise_target`: the interval's upper end, no warning); without one, the cheap figure at or below
    `noise_target`. Either needs a few samples before it is trusted to stop on. The forecast makes
    its own full estimate when its pilot is done and at most once a second after.
    """
    now = time.perf_counter()
    small = film.width * film.height <= TREND_EVERY_STEP_PIXELS
    if noise_target is not None or small or now - last_noise >= NOISE_DISPLAY_SECONDS:
        stats.noise = relative_noise(film)
        last_noise = now
        if trend is not None:
            trend.add(film.samples, stats.noise)
            stats.noise_warning = trust_warning(film, trend, prior)
    if tracker is not None and step is not None:
        stats.forecast = tracker.update(film, stats.seconds, step.samples, step.seconds)
    if progress is not None:
        progress(stats)
    if noise_target is None or film.samples < MIN_SAMPLES_FOR_NOISE:
        return False, last_noise
    if target is not None:
        return target.reached(film, stats, now), last_noise
    return stats.noise <= noise_target, last_noise


def trust_warning(film: Film, trend: Optional[VarianceTrend], prior: Optional[RarePathPrior]) -> Optional[str]:
    """Why the error estimate of `film` cannot be trusted, from the render's history (the trend of
    the spread per sample) or from the scene (the rare-path prior, below the samples it needs)."""
    found = trend.warning() if trend is not None else None
    if found is None and prior is not None:
        found = prior.warning(image_mean(film), film.samples)
    return found


class RenderClock:
    """Seconds of rendering since the start, less the time spent switching kernels."""

    def __init__(self):
        self.start = time.perf_counter()
        self.paused = 0.0

    def __call__(self) -> float:
        return time.perf_counter() - self.start - self.paused


def _add_kernel_time(stats: RenderStats, spent: KernelTime) -> None:
    stats.kernel_seconds += spent.seconds
    stats.compile_seconds += spent.compiling


def render_progressively(
    executor,
    film: Film,
    *,
    target: int,
    needed: KernelFeatures = GENERAL,
    kernel: str = "auto",
    features: Optional[KernelFeatures] = None,
    progress: Optional[Callable[[RenderStats], None]] = None,
    should_stop: Optional[Callable[[], bool]] = None,
    time_budget: Optional[float] = None,
    noise_target: Optional[float] = None,
    notify: Optional[Callable[[str], None]] = None,
    prior: Optional[RarePathPrior] = None,
    adaptive: bool = False,
) -> RenderResult:
    """Render into `film` (empty, or an earlier render's with the same seed) with `executor` until
    it holds `target` samples per pixel: the progressive loop of every front end.

    `should_stop` is polled before each step (and by the executor within one) and ends the render
    early with every finished step kept. With `time_budget` (seconds of rendering) or
    `noise_target` (relative RMS noise, see `film.estimate_noise`) the render also stops when the
    time is spent or when the upper end of the error's 95% interval falls below the target while
    nothing says the estimate cannot be trusted (`NoiseTarget`); `target` is then the cap.
    `stats.stop_reason` says which ended it: samples, time, noise or interrupted.

    The kernel: `needed` is the paths the scene reaches, `kernel` and `features` choose as in
    `choose_kernel`. With "auto", an executor that can switch kernels switches to the specialised
    one when the rest of the render, as forecast from the speed measured so far and the samples
    left (`variants.seconds_left`), or with a noise target from the pilot's forecast
    (`forecast.ForecastTracker`, `stats.forecast`), is long enough to repay the compile (`variants.worth_specialising`).
    `notify` receives a line before a compile or a switch. Time spent getting kernels ready is never
    counted as rendering time (`stats.seconds`, the time budget). `prior` (rare_paths.rare_path_prior
    of the scene) says when the scene itself makes the estimate untrustworthy: it goes to
    `stats.noise_warning` with the trend's warnings, and a noise target does not stop while it holds.

    `adaptive` with a `noise_target`: adaptive sampling (adaptive_plan.AdaptiveRun): a uniform
    pilot, then passes over the pixels not done; the executor must have `sampling` and
    `set_sampling`. It ends when every pixel is done, or at a checkpoint where the estimate meets
    the target with no warning (stop_reason "noise" both), or at the cap or the time budget.
    """
    chosen, may_switch = choose_kernel(needed, kernel, features)
    may_switch = may_switch and executor.can_switch_kernel
    stats = RenderStats(target_samples=target, features=chosen, samples=film.samples)
    start_samples = film.samples
    run = _adaptive_run(executor, film, noise_target, target) if adaptive else None
    try:
        _add_kernel_time(stats, executor.start(film, chosen, notify))
        clock = RenderClock()
        # Work before the first sample that is part of the render's time: a guided render's training.
        prepare = getattr(executor, "prepare", None)
        if prepare is not None:
            stats.guide_training = prepare(notify)
        time_left = (lambda: time_budget - clock()) if time_budget is not None else None
        last_noise = clock.start
        trend = VarianceTrend()
        stop_on_noise = NoiseTarget(noise_target) if noise_target is not None else None
        steps = 0
        tracker = None
        if noise_target is not None or time_budget is not None:
            tracker = ForecastTracker(cap=target, start_samples=start_samples, noise_target=noise_target,
                                      time_budget=time_budget)
        try:
            while film.samples < target:
                if should_stop is not None and should_stop():
                    stats.interrupted = True
                    stats.stop_reason = "interrupted"
                    break
                if (time_budget is not None and clock() >= time_budget
                        and (executor.stops_on_time_before_first_step or film.samples > start_samples)):
                    stats.stop_reason = "time"
                    break
                step_target = run.step_target(film, target) if run is not None else target
                step = executor.advance(Plan(step_target, start_samples, steps, stats.seconds, time_left), should_stop)
                if step is None:
                    stats.interrupted = True
                    stats.stop_reason = "interrupted"
                    break
                if step.samples == 0:
                    continue
                steps += 1
                stats.samples = film.samples
                stats.rays += step.rays
                stats.bad_samples += step.bad_samples
                stats.seconds = clock()
                if stats.first_pass_seconds == 0.0:
                    stats.first_pass_seconds = stats.seconds
                if run is not None:
                    reached, last_noise = _adaptive_progress(run, executor, film, stats, progress, last_noise, prior,
                                                             lambda: _adaptive_forecast(tracker, film, stats, step, target)
                                                             if tracker is not None else None)
                else:
                    reached, last_noise = report_progress(film, stats, progress, noise_target, last_noise, trend, stop_on_noise,
                                                          prior, tracker, step)
                if reached:
                    stats.stop_reason = "noise"
                    break
                if may_switch:
                    if noise_target is not None:
                        # The samples a noise target needs are known only once the pilot has
                        # measured the noise (an estimate at 2 samples per pixel can be off
                        # several times): until then, no switch.
                        left = stats.forecast.left(stats.seconds) if stats.forecast is not None else None
                    else:
                        left = seconds_left(step.seconds / step.samples, film.samples, target,
                                            time_left=time_left() if time_left is not None else None)
                    if left is not None and worth_specialising(left):
                        may_switch = False
                        if notify is not None:
                            notify(f"switching to the kernel specialised to this scene ({needed.tag}): about {left:.0f} s of "
                                   "rendering left")
                        spent = executor.switch_kernel(needed, notify)
                        _add_kernel_time(stats, spent)
                        clock.paused += spent.seconds
                        stats.features = needed
        except ExecutorFailed as exc:
            stats.seconds = clock()
            stats.noise = relative_noise(film)
            exc.partial = RenderResult(film, stats)
            raise
    finally:
        executor.close()
    stats.seconds = clock()
    stats.noise = relative_noise(film)
    if film.samples:
        stats.noise_warning = stats.noise_warning or trust_warning(film, None, prior)
    return RenderResult(film, stats)


def _adaptive_forecast(tracker: ForecastTracker, film: Film, stats: RenderStats, step, cap: int):
    """The forecast of an adaptive render: the tracker's (as for uniform sampling) until the stopping
    rule is fixed, then the samples that rule is expected to leave each pixel holding, at the speed of
    a sample of every pixel."""
    from .adaptive_plan import predicted_counts
    from .forecast import adaptive_forecast

    found = tracker.update(film, stats.seconds, step.samples, step.seconds)
    counts = predicted_counts(film)
    if found is None or counts is None:
        return found
    # A sample index costs less as pixels stop: the speed of a sample of every pixel is the recent
    # speed over the share of pixels still rendering.
    live = max(0.05, 1.0 - float(film.done.mean()))
    return adaptive_forecast(found, counts, film.counts, cap, stats.seconds, tracker.recent_sample_seconds() / live)


def _adaptive_run(executor, film: Film, noise_target: Optional[float], target: int):
    """The adaptive sampling of a render toward `noise_target` (None without one), with the
    executor set to the film's stopping rule when it continues a render that has one."""
    from .adaptive_plan import AdaptiveRun, stopping_sampling

    if noise_target is None:
        return None
    if not hasattr(executor, "set_sampling"):
        raise ValueError("this executor cannot sample adaptively: render without adaptive sampling")
    if film.stopping is not None:
        executor.set_sampling(stopping_sampling(executor.sampling, film.stopping))
    return AdaptiveRun(noise_target, target)


def _adaptive_progress(run, executor, film: Film, stats: RenderStats, progress, last_noise: float,
                       prior: Optional[RarePathPrior] = None, forecast=None) -> tuple[bool, float]:
    """`report_progress` of an adaptive render: once the pilot is in, the stopping rule is fixed
    and handed to the executor; the image's estimate is made at the checkpoints, where the render
    may stop on it (the upper end of its interval at the target, no warning: as `NoiseTarget`,
    but at fixed sample counts, so the image does not depend on the passes; the trend of the
    spread per sample is not watched, since stopping pixels changes it), and the share of pixels
    done is shown."""
    from .adaptive_plan import is_checkpoint, stopping_sampling

    stopping = run.sampling_after(film, prior)
    if stopping is not None:
        film.stopping = stopping
        executor.set_sampling(stopping_sampling(executor.sampling, stopping))
    estimate = None
    now = time.perf_counter()
    if film.done.all():
        # Every pixel stopped, some way into the last pass: the film holds what the pixels took,
        # whatever the passes were (`samples` is the most any took, not where the pass ended).
        film.samples = stats.samples = int(film.counts.max())
    if is_checkpoint(film.samples) or film.done.all():
        estimate = estimate_noise(film)
        stats.noise = relative_noise(film)
        stats.noise_high = estimate.high
        stats.noise_warning = estimate.warning or trust_warning(film, None, prior)
        last_noise = now
    elif progress is not None and now - last_noise >= NOISE_DISPLAY_SECONDS:
        stats.noise = relative_noise(film)
        last_noise = now
    stats.pixels_done = run.share_done(film)
    if forecast is not None:  # after the rule is fixed, so the forecast counts the samples it will take
        stats.forecast = forecast()
    if progress is not None:
        progress(stats)
    return run.finished(film, estimate, stats.noise_warning), last_noise
