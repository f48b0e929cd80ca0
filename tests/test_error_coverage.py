"""The reported error interval covers the true error at its stated rate, or the render warns (issue 32).

On every shipped scene and the caustic benchmark scene, 48 pixels wide, at 16, 64 and 256 samples per
pixel and a few seeds each, `estimate_noise(film)` reports an interval [low, high] for the image's
relative RMS error at `confidence`, and a `warning` when its own figure cannot be trusted. A trial
passes when the interval holds the TRUE error, measured against the scene's converged reference
(tests/renderer/converged/, made by tests/renderer/converged.py, with the reference's own variance
taken out), or when the warning fires. The trials are independent (each its own seed), so with a
correct interval the misses are binomial with p = 1 - confidence: the test fails when there are more
than that distribution's 95% bound allows, over all trials, and over the 16 spp trials of sky_spheres
and caustic_glass alone (the rate must hold where rare bright paths make it hard, not only in a total
padded by the easy scenes).

A warning is not free: one that fired on every render would pass any interval. So the warning may
fire on at most MAX_WARNED of the trials (the scenes lit through rare bright paths, sky_spheres,
material_spheres and caustic_glass, are 3 of 25).

The check must be able to fail: `test_the_check_rejects_todays_estimate` gives it the estimate rt
reported before issue 32 (one figure from the spread of single samples, no warning), with a band of
+-25% around that figure as if it were an interval, and asserts that the check rejects it, on
sky_spheres at 16 spp among others.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import pytest

from tests.renderer.converged import load_reference, reference_path, scene_files, small_graph, true_error

# (samples per pixel, seeds): more seeds where renders are cheap; 544 samples a pixel a scene in all,
# 250 trials. The seeds are the first of those the accuracy study renders (benchmarks/accuracy.py,
# REPORTED_TRIALS), so the page's table shows these trials among its own.
TRIALS = ((16, 6), (64, 3), (256, 1))
MAX_WARNED = 0.25
# Where the issue saw the report at half the truth with no warning (sky_spheres at 16 spp), and a
# caustic: checked on their own at 16 spp as well as in the total.
HARD_SCENES = ("sky_spheres", "caustic_glass")
BOUND_LEVEL = 0.95

pytestmark = pytest.mark.slow


@dataclass(eq=False)
class Trial:
    scene: str
    spp: int
    seed: int
    truth: float
    film: object
    # What the render itself said about its estimate's trust (RenderStats.noise_warning: the trend of the
    # spread per sample, the rare-path prior of the scene), as `rt render` and rt.render show it beside
    # the estimate's own warning.
    render_warning: Optional[str] = None


def trial_seed(spp: int, index: int) -> int:
    return 1000 * spp + index  # distinct from the references' seeds and from each other


@pytest.fixture(scope="module")
def trials() -> list[Trial]:
    from renderer.compile import compile_scene
    from renderer.render import render

    missing = [p.stem for p in scene_files() if not reference_path(p.stem).exists()]
    assert not missing, f"no converged reference for {', '.join(missing)}: run tests/renderer/converged.py"
    out = []
    for path in scene_files():
        reference = load_reference(path.stem)
        graph = small_graph(path)
        flat = compile_scene(graph)
        for spp, seeds in TRIALS:
            for index in range(seeds):
                seed = trial_seed(spp, index)
                result = render(graph, flat=flat, samples=spp, seed=seed, kernel="general")
                film = result.film
                out.append(Trial(path.stem, spp, seed, true_error(film.mean(), reference), film, result.stats.noise_warning))
    return out


@dataclass
class Reported:
    low: float
    high: float
    warning: Optional[str]
    confidence: float


def reported(trial: Trial) -> Reported:
    """What rt reports about a render's error (issue 32's NoiseEstimate fields, and the render's own warning)."""
    from renderer.film import estimate_noise

    estimate = estimate_noise(trial.film)
    missing = [name for name in ("low", "high", "warning", "confidence") if not hasattr(estimate, name)]
    if missing:
        pytest.fail(f"estimate_noise(film) reports no {', '.join(missing)}: the error interval and warning "
                    "of issue 32 (renderer/film.py, the statistics helper's part) are not there yet")
    return Reported(float(estimate.low), float(estimate.high), estimate.warning or trial.render_warning,
                    float(estimate.confidence))


def todays_estimate(trial: Trial) -> Reported:
    """The estimate rt reported before issue 32, given a generous band as if it were an interval."""
    from renderer.film import relative_noise

    figure = relative_noise(trial.film)  # the samples' own spread, as rt reported it before issue 32
    return Reported(0.8 * figure, 1.25 * figure, None, 0.95)


def allowed_misses(n: int, p: float, level: float = BOUND_LEVEL) -> int:
    """The least k with P(X > k) <= 1 - level for X ~ Binomial(n, p): more misses than this reject
    the claim that each trial misses with probability p (at most)."""
    below = 0.0
    for k in range(n + 1):
        below += math.comb(n, k) * p**k * (1.0 - p) ** (n - k)
        if 1.0 - below <= 1.0 - level:
            return k
    return n


def coverage_failures(trials: list[Trial], report) -> tuple[list[str], list[Trial], list[Trial], float]:
    """(reasons the check fails, the trials missed, the trials warned, the stated confidence)."""
    missed, warned, problems = [], [], []
    confidence = None
    for trial in trials:
        r = report(trial)
        confidence = r.confidence
        for value in (r.low, r.high):
            if not math.isfinite(value):
                problems.append(f"{trial.scene} at {trial.spp} spp, seed {trial.seed}: a bound is {value}")
        if r.warning:
            warned.append(trial)
        elif not (r.low <= trial.truth <= r.high):
            missed.append(trial)
    n = len(trials)
    bound = allowed_misses(n, 1.0 - confidence)
    if len(missed) > bound:
        lines = [f"{t.scene} at {t.spp} spp (seed {t.seed}): true {t.truth:.4f} outside "
                 f"[{report(t).low:.4f}, {report(t).high:.4f}]" for t in missed[:12]]
        problems.append(f"{len(missed)} of {n} intervals miss the true error without a warning, more than the "
                        f"{bound} a {confidence:.0%} interval allows (binomial bound at {BOUND_LEVEL:.0%}):\n  "
                        + "\n  ".join(lines))
    if len(warned) > MAX_WARNED * n:
        problems.append(f"the warning fires on {len(warned)} of {n} trials, more than {MAX_WARNED:.0%}: "
                        + ", ".join(sorted({f'{t.scene}@{t.spp}' for t in warned})))
    return problems, missed, warned, confidence


def test_reported_interval_covers_the_true_error_or_warns(trials):
    problems, missed, warned, confidence = coverage_failures(trials, reported)
    assert not problems, "\n".join(problems)
    # The scenes lit through rare bright paths are where an estimate from the samples fails first:
    # at 16 spp the stated rate must hold on them too, not only in a total padded by the easy scenes.
    hard = [t for t in trials if t.scene in HARD_SCENES and t.spp == 16]
    bad = [t for t in missed if t.scene in HARD_SCENES and t.spp == 16]
    assert len(bad) <= allowed_misses(len(hard), 1.0 - confidence), \
        f"{len(bad)} of the {len(hard)} renders of {' and '.join(HARD_SCENES)} at 16 spp miss the true error " \
        "without a warning: " + ", ".join(f"{t.scene} seed {t.seed}: true {t.truth:.3f}" for t in bad)


def test_the_check_rejects_todays_estimate(trials):
    problems, missed, _, _ = coverage_failures(trials, todays_estimate)
    print(f"today's estimate with a +-25% band: {len(missed)} of {len(trials)} trials missed: "
          + ", ".join(f"{t.scene}@{t.spp}" for t in missed))
    assert problems, "the coverage check passed the estimate rt reported before issue 32"
    assert any(t.scene == "sky_spheres" and t.spp == 16 for t in missed), \
        "today's estimate on sky_spheres at 16 spp was not caught"


def test_the_references_are_converged_enough(trials):
    """Each reference's own error (one of its two renders', from their difference) is at most a
    quarter of a 256 spp render's true error. That error is taken from every trial of the scene:
    a render's expected squared error is the per-sample variance over its spp at any sample count
    (rare bright paths included), so the mean of error^2 x spp over the trials, / 256, estimates it
    with all ten renders rather than the one at 256 spp (on the Cornell boxes ten pixels of the
    lamp's edge hold two thirds of the error, so one render's figure moves a lot)."""
    for path in scene_files():
        own = load_reference(path.stem).own_error()
        mine = [t for t in trials if t.scene == path.stem]
        at_256 = math.sqrt(sum(t.truth**2 * t.spp for t in mine) / len(mine) / 256)
        assert math.isfinite(own) and own <= 0.25 * at_256, \
            f"{path.stem}: the reference's own error {own:.4f} is over a quarter of a 256 spp render's {at_256:.4f}"
