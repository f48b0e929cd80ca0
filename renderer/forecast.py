"""How long a render needs to reach a noise target, and the noise a budget of time or samples will
reach, forecast from a short pilot (numpy only; no kernel, no pydantic).

A Monte Carlo pixel's standard error falls as one over the square root of its samples, so the
image's relative RMS noise after n samples per pixel is about c / sqrt(n). A pilot of n0 samples
that measured the noise e0 therefore forecasts n0 (e0 / target)^2 samples for a target, at the
time per sample it measured. The pilot's e0 is itself an estimate, with an uncertainty of its own:
the interval [low, high] that the noise estimate gives (`noise_interval`) becomes a range of
samples, n0 (low / target)^2 to n0 (high / target)^2, and the spread of the pilot's step times a
range of seconds. The forecast is made again after every step of the render (`ForecastTracker`),
so it sharpens as the samples grow; docs/forecast.md says how far it was from the real time.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import NamedTuple, Optional

import numpy as np

from .quantiles import chi2_quantile

# A forecast waits for this many samples per pixel of the render (two rounds of the eight
# interleaved batches: the batch estimate needs a full round, and one round is noisy), or for
# PILOT_SECONDS of rendering with at least PILOT_LEAST_SAMPLES, whichever comes first.
PILOT_SAMPLES = 16
PILOT_LEAST_SAMPLES = 4
PILOT_SECONDS = 3.0
# The confidence of the ranges a forecast gives.
CONFIDENCE = 0.95
# The noise interval is refreshed (a pass over the film) at most this often during a render.
INTERVAL_SECONDS = 1.0


@dataclass(frozen=True)
class Reading:
    """What a pilot measured: at `samples` per pixel the image's relative RMS noise was `noise`
    (between `low` and `high` at CONFIDENCE), and one sample per pixel over the whole image took
    `sample_seconds` (`timing_spread`: the relative spread of that time between steps)."""

    samples: int
    noise: float
    low: float
    high: float
    sample_seconds: float
    timing_spread: float = 0.0
    warning: Optional[str] = None  # the noise estimate's own word that it cannot be trusted
    # A noise target stops when the estimate's upper end (this many times the noise) reaches it.
    stop_factor: float = 1.0

    @property
    def usable(self) -> bool:
        return (self.samples > 0 and self.sample_seconds > 0 and math.isfinite(self.sample_seconds)
                and 0 < self.noise < math.inf and 0 < self.low <= self.noise <= self.high < math.inf)


@dataclass(frozen=True)
class Forecast:
    """Where a render is expected to stop, with ranges at CONFIDENCE: the samples per pixel and
    rendering seconds in all (`forecast`: from the film's first sample at today's speed;
    `ForecastTracker`: by the render's own clock), and the relative RMS noise of the image then. `stop` says what ends it:
    "noise" (the target), "time" (the budget) or "samples" (the cap, or the samples asked for)."""

    stop: str
    samples: float
    samples_low: float
    samples_high: float
    seconds: float
    seconds_low: float
    seconds_high: float
    noise: float
    noise_low: float
    noise_high: float
    warning: Optional[str] = None

    def left(self, elapsed: float, which: str = "seconds") -> float:
        """Seconds still to render after `elapsed` (never below 0), at the forecast's middle or at
        `which` end ("seconds_low", "seconds_high")."""
        return max(0.0, getattr(self, which) - elapsed)


def samples_for_noise(samples: float, noise: float, target: float) -> float:
    """Samples per pixel at which a noise of `noise` after `samples` falls to `target`, as noise
    falls with one over the square root of the samples (fewer than `samples` if it is below)."""
    if not (target > 0 and 0 <= noise < math.inf):
        return math.inf
    return samples * (noise / target) ** 2


def noise_after(samples: float, noise: float, more: float) -> float:
    """The noise after `more` samples per pixel in all, of a render whose noise was `noise` after `samples`."""
    if more <= 0:
        return math.inf
    return noise * math.sqrt(samples / more)


def forecast(reading: Reading, *, cap: float, noise_target: Optional[float] = None,
             time_budget: Optional[float] = None, least: float = 1.0) -> Forecast:
    """Where a render stops: the first of the sample cap, the noise target and the time budget
    (seconds of rendering in all), from what `reading` measured, and never before `least`
    samples per pixel (a render does not stop on its noise before a few samples). A noise target
    is reached when the noise times `reading.stop_factor` (the estimate's upper end) falls to it:
    the noise forecast at the end is the target over that factor. The middle of each range uses
    the middle of the pilot's noise and speed and its stop factor, its ends their ends; the low
    ends take the stop factor as 1, since the upper end comes down toward the noise as the
    estimate gains degrees of freedom (material_spheres' render stopped at 0.6 times the samples
    its pilot's factor forecast). A time budget bounds every end of the range of seconds, a cap every
    end of the range of samples."""
    per = reading.sample_seconds
    slow, fast = per * (1 + reading.timing_spread), per * max(0.0, 1 - reading.timing_spread)
    n0 = reading.samples

    def stop_at(noise: float, speed: float, factor: float) -> tuple[float, float, float, str]:
        """(samples, seconds, noise at the end, what stops it) for a noise of `noise` at n0,
        `speed` seconds per sample and a stop factor `factor`."""
        ends = [(float(cap), "samples")]
        if noise_target is not None:
            ends.append((max(least, samples_for_noise(n0, noise, noise_target / factor)), "noise"))
        if time_budget is not None and speed > 0:
            ends.append((max(least, time_budget / speed), "time"))
        samples, stop = min(ends, key=lambda end: end[0])
        seconds = samples * speed
        if time_budget is not None:
            seconds = min(seconds, time_budget)
        end_noise = noise_target / factor if stop == "noise" else noise_after(n0, noise, samples)
        return samples, seconds, end_noise, stop

    samples, seconds, noise, stop = stop_at(reading.noise, per, reading.stop_factor)
    # The ranges: every pairing of the ends of the noise's interval (with the stop factor's) and of the speed's.
    corners = [stop_at(x, speed, factor) for x, factor in ((reading.low, 1.0), (reading.high, reading.stop_factor))
               for speed in (fast, slow)]
    return Forecast(stop, samples, min(c[0] for c in corners), max(c[0] for c in corners),
                    seconds, min(c[1] for c in corners), max(c[1] for c in corners),
                    noise, min(c[2] for c in corners), max(c[2] for c in corners), reading.warning)


def pooled_interval(variances: np.ndarray, dof: float, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The interval, as factors on the square root of its sum, of a sum of independent variance
    estimates (`variances`, one per pixel, each with `dof` degrees of freedom): Satterthwaite's
    effective degrees of freedom, (sum v)^2 / sum(v^2 / dof), and a chi-square interval on them.
    A few pixels that hold most of the sum leave few effective degrees of freedom and so a wide
    interval: the pilot knows little about a noise that a handful of pixels make."""
    v = np.asarray(variances, np.float64).ravel()
    v = v[np.isfinite(v)]
    total = float(v.sum())
    if total <= 0 or dof <= 0:
        return 1.0, 1.0
    effective = total * total / float(np.dot(v, v) / dof)
    alpha = 1 - confidence
    low = effective / chi2_quantile(1 - alpha / 2, effective)
    high = effective / max(chi2_quantile(alpha / 2, effective), 1e-12)
    return math.sqrt(low), math.sqrt(high)


def unbiased_noise(noise: float) -> float:
    """The relative RMS noise `noise` (sqrt(sum se^2 / sum mean^2)) with its signal made unbiased.
    A pixel's squared mean overstates its squared value by its own variance, se^2, on average, so
    sum mean^2 - sum se^2 is the unbiased signal, and the noise over it is noise / sqrt(1 - noise^2).
    At 16 samples per pixel of a sample spread as large as the value it is 3% more, which a
    forecast, squared, makes 6% more samples; at the end of a render it is nothing. Above 0.7 the
    correction is held at its value there (x1.4): so noisy a pilot says little anyway."""
    if not 0 < noise < math.inf:
        return noise
    return noise / math.sqrt(1 - min(noise * noise, 0.5))


class NoiseReading(NamedTuple):
    """A film's noise as a forecast reads it: the relative RMS noise (`unbiased_noise`), the
    interval at CONFIDENCE for the noise the samples truly have (not yet known: the estimate's
    own uncertainty), the estimate's warning, and `stop_factor`: how far above the noise the
    figure a noise target stops on sits (the upper end of the interval for the render's realised
    error, film.estimate_noise's `high`), as a multiple of it."""

    noise: float
    low: float
    high: float
    warning: Optional[str] = None
    stop_factor: float = 1.0


def noise_interval(film) -> NoiseReading:
    """The noise of a film as a forecast reads it (NoiseReading), from its error estimate
    (`film.estimate_noise`). The interval is a chi-square one on the estimate's own degrees of
    freedom (`estimate_dof`: from the spread of the batch means' variance), or, for an estimate
    that does not state them, pooled from each pixel's variance estimate (`pooled_interval`, with
    samples - 1 degrees of freedom each). A few pixels that hold most of the noise leave few
    degrees of freedom, and so a wide interval."""
    from .film import estimate_noise

    estimate = estimate_noise(film)
    value = estimate.relative_rms
    warning = getattr(estimate, "warning", None)
    if not 0 < value < math.inf:
        return NoiseReading(value, value, value, warning)
    dof = getattr(estimate, "estimate_dof", 0.0)
    if dof > 0:
        alpha = 1 - CONFIDENCE
        lo = math.sqrt(dof / chi2_quantile(1 - alpha / 2, dof))
        hi = math.sqrt(dof / max(chi2_quantile(alpha / 2, dof), 1e-12))
    else:  # each pixel's squared standard error (channels averaged) from its samples' sums of squares
        lo, hi = pooled_interval(np.square(estimate.error), film.samples - 1)
    unbiased = unbiased_noise(value)
    high = getattr(estimate, "high", math.inf)
    stop_factor = max(1.0, high / unbiased) if math.isfinite(high) else 1.0
    return NoiseReading(unbiased, unbiased * lo, unbiased * hi, warning, stop_factor)


def timing_spread(step_seconds: list[float]) -> float:
    """The relative spread of the time per sample between a render's steps: their standard
    deviation over their mean, over the square root of their number (the error of the mean
    speed), doubled for the confidence, and at least 5% (other processes share the machine)."""
    times = np.asarray(step_seconds, np.float64)
    times = times[np.isfinite(times) & (times > 0)]
    if len(times) < 2:
        return 0.25
    spread = float(times.std(ddof=1) / times.mean()) / math.sqrt(len(times))
    return max(0.05, min(0.5, 2 * spread))


class ForecastTracker:
    """The forecast of a render, refreshed after each of its steps (renderer/session.py).

    It stays None until the pilot is done (PILOT_SAMPLES of this render, or PILOT_SECONDS with
    PILOT_LEAST_SAMPLES); then each update forecasts from what was measured so far: the speed over
    the latter half of this render's samples (`recent_sample_seconds`; a resumed film's earlier
    samples were timed by another run), the noise over the whole film."""

    def __init__(self, *, cap: int, start_samples: int, noise_target: Optional[float] = None,
                 time_budget: Optional[float] = None, clock=time.perf_counter):
        self.cap = cap
        self.start = start_samples
        self.noise_target = noise_target
        self.time_budget = time_budget
        self.clock = clock
        self.step_times: list[float] = []  # seconds per sample of each step
        self.history: list[tuple[int, float]] = [(start_samples, 0.0)]  # (film samples, render seconds) after each step
        # (film samples, NoiseReading) of the last measurement of the film's noise
        self.measured: Optional[tuple] = None
        self.interval_at = -math.inf
        self.forecast: Optional[Forecast] = None

    def recent_sample_seconds(self) -> float:
        """Rendering seconds per sample per pixel over the latter half of this render's samples:
        what the samples still to render will cost. Adaptive sampling stops pixels as it goes, so
        a sample index costs less late in a render than early; the first pass's start-up is left
        out too. The time between steps (noise estimates, progress) counts."""
        samples, seconds = self.history[-1]
        half = self.start + (samples - self.start) / 2
        since = next(((n, t) for n, t in self.history if n >= half and n < samples), self.history[0])
        return (seconds - since[1]) / max(1, samples - since[0])

    def pilot_done(self, samples: int, seconds: float) -> bool:
        done = samples - self.start
        return done >= PILOT_SAMPLES or (seconds >= PILOT_SECONDS and done >= PILOT_LEAST_SAMPLES)

    def update(self, film, seconds: float, step_samples: int, step_seconds: float) -> Optional[Forecast]:
        """After a step of `step_samples` that took `step_seconds` (`seconds`: the render's clock
        now): the render's forecast, or None before the pilot is done (or while the film has no
        noise to measure). The noise and its interval are measured on the film when the pilot is
        done and then at most every INTERVAL_SECONDS; between, the forecast goes on from the last
        measurement, made at the samples it was made at, and from the speed now."""
        if step_samples > 0:
            self.step_times.append(step_seconds / step_samples)
        samples = film.samples
        self.history.append((samples, seconds))
        if not self.pilot_done(samples, seconds):
            return self.forecast
        now = self.clock()
        if self.measured is None or now - self.interval_at >= INTERVAL_SECONDS:
            self.measured = (samples, noise_interval(film))
            self.interval_at = now
        at, measured = self.measured
        reading = Reading(at, measured.noise, measured.low, measured.high, self.recent_sample_seconds(),
                          timing_spread(self.step_times), measured.warning, measured.stop_factor)
        if reading.usable:
            # `forecast` counts seconds from the film's first sample at today's speed; this render's
            # clock has counted `seconds` for what it holds now: the rest is at today's speed.
            offset = seconds - samples * reading.sample_seconds
            budget = self.time_budget - offset if self.time_budget is not None else None
            whole = forecast(reading, cap=self.cap, noise_target=self.noise_target, time_budget=budget,
                             least=samples)
            self.forecast = shifted(whole, offset)
        return self.forecast


def adaptive_forecast(f: Forecast, counts: np.ndarray, held: np.ndarray, cap: int, elapsed: float,
                      sample_seconds: float) -> Forecast:
    """The forecast `f` (made as for uniform sampling) for an adaptive render whose pixels are expected
    to end holding `counts` samples (adaptive_plan.predicted_counts) and hold `held` now: the samples
    are their mean, the seconds those still to render at `sample_seconds` per sample of every pixel,
    after the `elapsed` ones; both ranges keep the uniform forecast's relative width."""
    import dataclasses

    counts = np.minimum(counts, cap)
    mean = float(np.mean(counts))
    seconds = elapsed + float(np.mean(np.maximum(counts - held, 0))) * sample_seconds
    wide = (lambda value, low, high, of: (value * low / of if of > 0 else value, value * high / of if of > 0 else value))
    samples_low, samples_high = wide(mean, f.samples_low, f.samples_high, f.samples)
    seconds_low, seconds_high = wide(seconds, f.seconds_low, f.seconds_high, f.seconds)
    return dataclasses.replace(f, stop="noise", samples=mean, samples_low=min(mean, samples_low),
                               samples_high=min(float(cap), max(mean, samples_high)), seconds=seconds,
                               seconds_low=max(elapsed, min(seconds, seconds_low)), seconds_high=max(seconds, seconds_high))


def shifted(f: Forecast, seconds: float) -> Forecast:
    """The forecast with `seconds` added to each of its times (clamped at 0)."""
    import dataclasses

    return dataclasses.replace(f, seconds=max(0.0, f.seconds + seconds), seconds_low=max(0.0, f.seconds_low + seconds),
                               seconds_high=max(0.0, f.seconds_high + seconds))


def scaled_to(reading: Reading, pixels_ratio: float) -> Reading:
    """A pilot rendered at a smaller size, as a forecast of the full image: the time per sample
    grows with the pixel count (`pixels_ratio`, the full image's pixels over the pilot's), and the
    relative noise per sample is taken as the same (each pixel's samples see the same light
    paths; docs/forecast.md measures how close that holds)."""
    import dataclasses

    return dataclasses.replace(reading, sample_seconds=reading.sample_seconds * pixels_ratio)
