"""The progress bar of a render on standard error: `rt render`, and `rt.render(progress=True)`."""

from __future__ import annotations

import sys
from typing import Optional


def spoken_seconds(seconds: float) -> str:
    """A duration as a forecast says it, to about two figures: '0.4 s', '45 s', '2 min 10 s', '1 h 05 min'."""
    if seconds != seconds or seconds == float("inf"):
        return "an unbounded time"
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 600:
        minutes, sec = divmod(int(round(seconds / 10) * 10), 60)
        return f"{minutes} min {sec} s" if sec else f"{minutes} min"
    if seconds < 3600:
        return f"{int(round(seconds / 60))} min"
    hours, minutes = divmod(int(round(seconds / 60)), 60)
    return f"{hours} h {minutes:02d} min"


def percent(noise: float) -> str:
    """A relative noise as a percentage with two figures: 1%, 0.52%, 12%."""
    value = 100 * noise
    return f"{value:.2g}%" if value < 10 else f"{value:.0f}%"


def forecast_sentence(forecast, noise_target=None, with_warning: bool = True) -> str:
    """What a forecast (renderer.forecast.Forecast) says, in one line: the time to a noise target
    with its range, or the noise a budget of time or samples ends at with its range."""
    times = f"({spoken_seconds(forecast.seconds_low)} to {spoken_seconds(forecast.seconds_high)}, 95% range)"
    if forecast.stop == "noise":
        line = (f"about {spoken_seconds(forecast.seconds)} to {percent(noise_target)} noise {times}, "
                f"about {forecast.samples:,.0f} samples per pixel")
    else:
        why = {"time": "at the end of the time budget", "samples": f"at {forecast.samples:,.0f} samples per pixel"}[forecast.stop]
        line = (f"about {percent(forecast.noise)} noise {why} ({percent(forecast.noise_low)} to "
                f"{percent(forecast.noise_high)}), in about {spoken_seconds(forecast.seconds)}")
        if forecast.stop == "samples":
            line += f" {times}"
        if noise_target is not None:
            line += f": the sample cap comes before the {percent(noise_target)} target"
    if forecast.warning and with_warning:
        line += f"; {forecast.warning.rstrip('.')}, so it may take longer"
    return line


def fmt_seconds(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, sec = divmod(int(round(seconds)), 60)
    return f"{minutes}m{sec:02d}s" if minutes < 60 else f"{minutes // 60}h{minutes % 60:02d}m"


class Progress:
    """A one-line progress bar on standard error (a line per 10% when it is not a terminal)."""

    def __init__(self, total: int, seconds: Optional[float] = None, noise: Optional[float] = None):
        self.total = total
        self.seconds = seconds
        self.noise = noise
        self.tty = sys.stderr.isatty()
        self.last_decile = -1
        self.shown = (-1, "")  # the samples and noise figure of the last line drawn
        self.forecast_said = False  # the first forecast is said on a line of its own

    def __call__(self, stats) -> None:
        forecast = getattr(stats, "forecast", None)
        if forecast is not None and not self.forecast_said:
            self.forecast_said = True
            said = (f"forecast: {forecast_sentence(forecast, self.noise, with_warning=False)}, from a pilot of "
                    f"{stats.samples} samples per pixel; refined as the render goes")
            if forecast.warning:
                said += f"; {forecast.warning.rstrip('.')}, so it may take longer"
            warning = getattr(stats, "noise_warning", None)
            if self.noise and warning and not forecast.warning:  # the render's own doubt (a trend, the scene's rare paths)
                said += f"; {warning.rstrip('.')}: the render does not stop on its noise while that holds"
            self.notify(said)
        line, frac = self.line(stats)
        if self.tty:
            self.show(line, stats)
        elif int(frac * 10) > self.last_decile:
            self.last_decile = int(frac * 10)
            self.show(line, stats)

    @property
    def shown_any(self) -> bool:
        """Whether a pass has been shown, and so finished: the first is always drawn."""
        return self.shown[0] >= 0

    def finish(self, stats) -> None:
        """Draw the render's final figures: during the render the noise is estimated at most once a
        second, so the last update can show an older estimate than the summary's, or none."""
        if self.tty or (stats.samples, self.noise_text(stats)) != self.shown:
            self.show(self.line(stats)[0], stats)

    def show(self, line: str, stats) -> None:
        # Recorded before the line is written: a signal sent on seeing the line may run its handler
        # between the write and the next statement, and must find a pass shown (`shown_any`).
        self.shown = (stats.samples, self.noise_text(stats))
        sys.stderr.write("\r" + line if self.tty else line + "\n")
        sys.stderr.flush()

    @staticmethod
    def noise_text(stats) -> str:
        return f"  noise {100 * stats.noise:.2f}%" if stats.noise != float("inf") else ""

    def line(self, stats) -> tuple[str, float]:
        """The progress line for `stats`, and the share of the render done."""
        done = stats.samples
        frac = done / self.total if self.total else 1.0
        # Under a budget, progress is the share of the budget spent: time, or noise (which falls
        # as one over the square root of the samples).
        if self.seconds:
            frac = max(frac, stats.seconds / self.seconds)
        # A noise target stops on the upper end of the error's interval once one is known, and not
        # while the estimate warns: then only the samples measure progress.
        bound = stats.noise_high if stats.noise_high < float("inf") else stats.noise
        if self.noise and stats.noise_warning is None and 0 < bound < float("inf"):
            frac = max(frac, (self.noise / bound) ** 2)
        frac = min(frac, 1.0)
        eta = stats.seconds / frac - stats.seconds if frac > 0 else 0.0
        forecast = getattr(stats, "forecast", None)
        if forecast is not None:  # the pilot's forecast, refreshed each step: it knows the cap and the budget
            eta = forecast.left(stats.seconds)
            if forecast.seconds > 0:
                frac = min(1.0, max(frac if not self.noise else 0.0, stats.seconds / forecast.seconds))
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        noise = self.noise_text(stats)
        # A noise target's end is unknown until the pilot has measured the noise: no figure rather than a wild one.
        unknown = self.noise and forecast is None and not 0 < stats.noise < float("inf")
        if getattr(stats, "pixels_done", None) is not None:  # adaptive sampling: the pixels it has stopped
            noise += f"  {100 * stats.pixels_done:.0f}% of pixels done"
        line = (
            f"[{bar}] {done}/{self.total} spp  {fmt_seconds(stats.seconds)} elapsed  "
            f"ETA {'after the pilot' if unknown else fmt_seconds(eta)}  {stats.rays_per_second / 1e6:.2f} Mrays/s{noise}"
        )
        return line, frac

    def notify(self, message: str) -> None:
        """A line of its own, between progress updates."""
        sys.stderr.write(("\r\x1b[K" if self.tty else "") + message + "\n")
        sys.stderr.flush()

    def close(self) -> None:
        if self.tty:
            sys.stderr.write("\n")
