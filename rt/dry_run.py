"""`rt render --dry-run`: render a short pilot of the scene, say how long the render would take (or
the noise it would reach), and write nothing.

The pilot renders the scene's own image for about PILOT_SECONDS, longer if it needs to for
PILOT_LEAST_SAMPLES (at most LONGEST_PILOT), and shorter if it reaches the render's own end (its
samples, or its noise target) before. Only an image too large for even that is piloted at a
smaller width, its time per sample scaled by the pixel count: a smaller image's relative noise is
higher (pixels that straddle the edge of a bright light are a larger share of it), and forecasts
from 64 px pilots were 1.7 to 15 times the real time (docs/forecast.md). A first, tiny probe (a few tenths of a second at PROBE_WIDTH) measures
the speed that sizes the pilot. The forecast itself is `renderer.forecast`'s, the one a render
refines as it goes.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional

from .progress import forecast_sentence, spoken_seconds

if TYPE_CHECKING:
    from renderer.forecast import Forecast, Reading

# The tiny first pilot that measures the speed: this width, this long.
PROBE_WIDTH = 48
PROBE_SECONDS = 0.4
# The longest a pilot may take to hold PILOT_LEAST_SAMPLES at the image's own size; an image that
# needs longer is piloted narrower, down to LEAST_PILOT_WIDTH.
LONGEST_PILOT = 12.0
LEAST_PILOT_WIDTH = 64
# The most samples per pixel a pilot renders: a fast scene's pilot spends its seconds on more
# samples, which narrows the forecast's range.
PILOT_CAP = 4096


@dataclass(frozen=True)
class Pilot:
    """What a dry run measured: the reading (scaled to the full image), the pilot's size, and the
    kernel seconds it spent (compiling, or loading from the cache)."""

    reading: "Reading"
    width: int
    height: int
    samples: int
    seconds: float
    compile_seconds: float


def pilot_size(width: int, height: int, pixel_sample_seconds: float) -> tuple[int, float]:
    """(width, seconds) of the pilot of a `width` x `height` image, at the speed measured
    (`pixel_sample_seconds`: one sample of one pixel): the image's own width, for PILOT_SECONDS or
    as long as PILOT_LEAST_SAMPLES take there (with a margin), up to LONGEST_PILOT; narrower only
    when even that is too short."""
    from renderer.forecast import PILOT_LEAST_SAMPLES, PILOT_SECONDS

    if pixel_sample_seconds <= 0 or not math.isfinite(pixel_sample_seconds):
        return width, PILOT_SECONDS
    least = 1.3 * PILOT_LEAST_SAMPLES * pixel_sample_seconds * width * height
    if least <= LONGEST_PILOT:
        return width, max(PILOT_SECONDS, least)
    scale = math.sqrt(LONGEST_PILOT / least)
    return max(min(width, LEAST_PILOT_WIDTH), int(width * scale)), LONGEST_PILOT


def render_pilot(loaded, opts, frame, features, *, width: int, samples: int, seconds: float, notify=None,
                 noise_target: Optional[float] = None):
    """Render the scene at `width` for at most `seconds` of rendering or `samples` samples per
    pixel (or until `noise_target`), with the render's own options (seed, depth, integrator,
    threads, kernel); a RenderResult, the pilot's Frame, and (samples, seconds) of each step."""
    from renderer.flat import Frame
    from renderer.session import flatten_loaded
    from renderer.variants import features_of

    from .rendering import render_scene

    graph, flat = flatten_loaded(loaded, width, opts.integrator)
    small = Frame.of(graph)
    steps: list[tuple[int, float]] = []
    last = [0, 0.0]

    def record(stats) -> None:  # the session calls this after each step
        done, spent = stats.samples - last[0], stats.seconds - last[1]
        if done > 0:
            steps.append((done, spent))
        last[:] = [stats.samples, stats.seconds]

    result = render_scene(flat, small, features_of(graph) if features is None else features, target=samples,
                          kernel=opts.kernel, threads=opts.threads, progress=record, max_depth=opts.max_depth, seed=opts.seed,
                          time_budget=seconds, noise_target=noise_target, notify=notify)
    return result, small, steps


def latter_half_speed(steps: list[tuple[int, float]]) -> float:
    """Seconds per sample per pixel over the steps (samples, seconds) that hold the latter half of
    the samples: the first pass's start-up left out, as the render's own forecast does."""
    total = sum(n for n, _ in steps)
    kept, spent = 0, 0.0
    for n, t in reversed(steps):
        kept, spent = kept + n, spent + t
        if 2 * kept >= total:
            break
    return spent / max(1, kept)


def run_pilot(loaded, opts, frame, features, *, target: int = PILOT_CAP, notify=None, width: Optional[int] = None) -> Pilot:
    """The dry run's pilot: a probe for the speed, then the pilot proper (see the module's
    docstring), which renders for its seconds unless it reaches the render's own end first: its
    `target` samples per pixel or its --noise target. `width` forces the pilot's width
    (benchmarks/forecast_error.py compares them)."""
    from renderer.forecast import (PILOT_LEAST_SAMPLES, PILOT_SAMPLES, PILOT_SECONDS, Reading, noise_interval, scaled_to,
                                   timing_spread)

    probe_width = min(frame.width, PROBE_WIDTH)
    probe, small, _ = render_pilot(loaded, opts, frame, features, width=probe_width, samples=PILOT_SAMPLES,
                                   seconds=PROBE_SECONDS, notify=notify)
    compile_seconds = probe.stats.compile_seconds
    per_pixel = probe.stats.seconds / max(1, probe.film.samples) / (small.width * small.height)
    chosen, seconds = pilot_size(frame.width, frame.height, per_pixel)
    width = chosen if width is None else width
    if width == probe_width and probe.film.samples >= min(target, PILOT_CAP):
        result, steps = probe, None
    else:
        samples = min(PILOT_CAP, max(target, PILOT_LEAST_SAMPLES))
        result, small, steps = render_pilot(loaded, opts, frame, features, width=width, samples=samples,
                                            seconds=seconds if width == chosen else PILOT_SECONDS, notify=notify,
                                            noise_target=opts.noise if width == frame.width else None)
        compile_seconds += result.stats.compile_seconds
    film = result.film
    measured = noise_interval(film)
    steps = steps or [(film.samples, result.stats.seconds)]
    reading = Reading(film.samples, measured.noise, measured.low, measured.high, latter_half_speed(steps),
                      timing_spread([t / n for n, t in steps]), measured.warning, measured.stop_factor)
    reading = scaled_to(reading, (frame.width * frame.height) / (small.width * small.height))
    return Pilot(reading, small.width, small.height, film.samples, result.stats.seconds, compile_seconds)


def dry_forecast(pilot: Pilot, *, cap: int, noise_target: Optional[float], time_budget: Optional[float]) -> Optional["Forecast"]:
    """The render's forecast from a dry run's pilot; None when the pilot could not measure the noise
    (a black image, or a single sample)."""
    from renderer.forecast import forecast
    from renderer.session import MIN_SAMPLES_FOR_NOISE

    if not pilot.reading.usable:
        return None
    return forecast(pilot.reading, cap=cap, noise_target=noise_target, time_budget=time_budget,
                    least=MIN_SAMPLES_FOR_NOISE if noise_target is not None else 1)


def dry_run(opts, scene, target: int, say) -> None:
    """Run the pilot of a prepared scene (rt.render_job.PreparedScene) and say the forecast on
    standard output; write no file."""
    from renderer.variants import compile_wait, first_kernel, is_compiled, worth_specialising

    frame = scene.frame
    chosen = first_kernel(scene.features, opts.kernel)
    compiled = is_compiled(chosen)
    say("dry run: a pilot of a few seconds renders the scene; no image is written", err=True)
    started = time.perf_counter()
    pilot = run_pilot(scene.loaded, opts, frame, scene.features, target=target, notify=lambda line: say(line, err=True))
    size = ("the image's own size" if pilot.width == frame.width else
            f"the image is {frame.width}x{frame.height}, too large for a pilot of a few seconds: its smaller pixels may "
            "make the forecast too long")
    say(f"pilot: {pilot.samples} samples per pixel at {pilot.width}x{pilot.height} ({size}) in "
        f"{spoken_seconds(pilot.seconds)} of rendering, {spoken_seconds(time.perf_counter() - started)} in all")
    result = dry_forecast(pilot, cap=target, noise_target=opts.noise, time_budget=scene.budget_seconds)
    if result is None:
        say("forecast: none (the pilot measured no noise: the image is black, or the same in every sample)")
    else:
        say(f"forecast: {forecast_sentence(result, opts.noise)}")
    if not compiled:
        say(f"kernel: the {chosen.tag!r} kernel was compiled for the pilot ({spoken_seconds(pilot.compile_seconds)}); "
            "the render loads it from the cache")
    if (result is not None and opts.kernel == "auto" and chosen != scene.features and not is_compiled(scene.features)
            and worth_specialising(result.seconds)):
        say(f"kernel: the render would also compile the kernel specialised to this scene ({compile_wait(scene.features)}, "
            "not counted above), and render a few per cent faster after it")
