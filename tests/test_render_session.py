"""The render session (renderer/session.py): one progressive loop for every front end and executor.

The loop's rules (samples, time budget, noise target, stop requests, failures, the kernel switch,
resume) are tested with a pure-numpy executor that adds constants, so they hold without Numba and
whatever runs the samples. The slow tests check that `rt render`, `rt.render` and the local
executor driven directly give the same film, bit for bit (import circles: tests/test_imports.py).
"""

import time
from pathlib import Path

import numpy as np
import pytest

from renderer.executor import ExecutorFailed, KernelTime, Step
from renderer.film import Film
from renderer.session import MIN_SAMPLES_FOR_NOISE, choose_kernel, render_progressively
from renderer.variants import GENERAL, KernelFeatures

ROOT = Path(__file__).resolve().parents[1]
NEEDED = KernelFeatures(motion=False, defocus=False, media=False)


class ConstantPasses:
    """An executor that adds `per_sample` samples of a fixed value per step (noise comes from
    alternating two values), with optional sleeps, stops and failures: no kernel at all."""

    can_switch_kernel = True
    stops_on_time_before_first_step = True

    def __init__(self, per_step=1, values=(0.5, 0.5), step_seconds=0.0, fail_at=None, stop_mid_step_at=None,
                 empty_steps=0, switch_seconds=0.0):
        self.per_step = per_step
        self.values = values
        self.step_seconds = step_seconds
        self.fail_at = fail_at
        self.stop_mid_step_at = stop_mid_step_at
        self.empty_steps = empty_steps
        self.switch_seconds = switch_seconds
        self.calls = []  # ("start" | "advance" | "switch" | "close", detail)

    def start(self, film, features, notify=None):
        self.film = film
        self.calls.append(("start", features))
        return KernelTime(0.0, 0.0)

    def advance(self, plan, should_stop=None):
        self.calls.append(("advance", self.film.samples))
        if self.empty_steps > 0:  # an asynchronous executor with nothing finished yet
            self.empty_steps -= 1
            time.sleep(self.step_seconds)
            return Step(0, 0, 0, 0.0)
        if self.fail_at is not None and self.film.samples >= self.fail_at:
            raise ExecutorFailed("the fake executor failed")
        if self.stop_mid_step_at is not None and self.film.samples >= self.stop_mid_step_at:
            return None
        time.sleep(self.step_seconds)
        n = min(self.per_step, plan.target - self.film.samples)
        for s in range(self.film.samples, self.film.samples + n):
            value = self.values[s % len(self.values)]
            self.film.total += value
            self.film.total_sq += value * value
        self.film.samples += n
        pixels = self.film.width * self.film.height
        return Step(n, rays=pixels * n, bad_samples=0, seconds=max(self.step_seconds, 1e-6))

    def switch_kernel(self, features, notify=None):
        self.calls.append(("switch", features))
        time.sleep(self.switch_seconds)
        return KernelTime(self.switch_seconds, self.switch_seconds)

    def close(self):
        self.calls.append(("close", None))


def test_the_loop_stops_at_the_samples_asked_for_and_counts_rays():
    executor = ConstantPasses(per_step=3)
    film = Film.empty(4, 2)
    result = render_progressively(executor, film, target=10, kernel="general")
    assert result.stats.stop_reason == "samples" and not result.stats.interrupted
    assert film.samples == result.stats.samples == 10
    assert result.stats.rays == 4 * 2 * 10
    assert np.array_equal(film.total, np.full((2, 4, 3), 5.0))
    assert [c for c, _ in executor.calls] == ["start"] + ["advance"] * 4 + ["close"]


def test_progress_is_shown_after_every_step_with_the_samples_so_far():
    seen = []
    render_progressively(ConstantPasses(per_step=2), Film.empty(3, 3), target=7, kernel="general",
                         progress=lambda stats: seen.append(stats.samples))
    assert seen == [2, 4, 6, 7]


def test_a_noise_target_stops_once_enough_samples_are_trusted():
    # Constant samples: the estimated noise is 0 from the second sample on, but the loop trusts
    # the estimate only from MIN_SAMPLES_FOR_NOISE samples.
    result = render_progressively(ConstantPasses(), Film.empty(4, 4), target=1000, kernel="general", noise_target=0.01)
    assert result.stats.stop_reason == "noise"
    assert result.film.samples == MIN_SAMPLES_FOR_NOISE
    assert result.stats.noise == 0.0


def test_a_noisy_film_does_not_stop_on_a_noise_target_it_has_not_reached():
    result = render_progressively(ConstantPasses(values=(0.0, 1.0)), Film.empty(4, 4), target=40, kernel="general",
                                  noise_target=0.01)
    assert result.stats.stop_reason == "samples" and result.film.samples == 40
    assert result.stats.noise > 0.1  # 1/sqrt(40) of a unit spread around 0.5


def test_a_time_budget_stops_the_render_between_steps():
    result = render_progressively(ConstantPasses(step_seconds=0.02), Film.empty(2, 2), target=10_000, kernel="general",
                                  time_budget=0.1)
    assert result.stats.stop_reason == "time"
    assert 1 <= result.film.samples <= 5  # a step starts only while less than 0.1 s is spent
    assert result.stats.seconds >= 0.1


def test_an_executor_that_waits_for_its_first_step_is_not_stopped_by_a_spent_budget():
    # A cluster's first round may finish after the budget: the render keeps it rather than end empty.
    executor = ConstantPasses(step_seconds=0.03, empty_steps=3)
    executor.stops_on_time_before_first_step = False
    result = render_progressively(executor, Film.empty(2, 2), target=100, kernel="general", time_budget=0.01)
    assert result.stats.stop_reason == "time" and result.film.samples == 1
    executor = ConstantPasses(step_seconds=0.03, empty_steps=3)
    result = render_progressively(executor, Film.empty(2, 2), target=100, kernel="general", time_budget=0.01)
    assert result.stats.stop_reason == "time" and result.film.samples == 0


def test_a_stop_request_keeps_every_finished_step():
    steps = []
    result = render_progressively(ConstantPasses(per_step=2), Film.empty(2, 2), target=100, kernel="general",
                                  progress=lambda stats: steps.append(stats.samples), should_stop=lambda: len(steps) == 3)
    assert result.stats.interrupted and result.stats.stop_reason == "interrupted"
    assert result.film.samples == 6


def test_a_step_stopped_midway_ends_the_render_with_the_film_as_it_was():
    executor = ConstantPasses(stop_mid_step_at=5)
    result = render_progressively(executor, Film.empty(2, 2), target=100, kernel="general")
    assert result.stats.stop_reason == "interrupted" and result.film.samples == 5
    assert executor.calls[-1] == ("close", None)


def test_a_failing_executor_hands_back_the_film_so_far_and_is_closed():
    executor = ConstantPasses(fail_at=4)
    with pytest.raises(ExecutorFailed) as caught:
        render_progressively(executor, Film.empty(2, 2), target=100, kernel="general")
    partial = caught.value.partial
    assert partial is not None and partial.film.samples == 4 and partial.stats.samples == 4
    assert np.array_equal(partial.film.total, np.full((2, 2, 3), 2.0))
    assert executor.calls[-1] == ("close", None)


def test_a_resumed_film_counts_from_its_samples_and_a_full_one_asks_for_nothing():
    film = Film.empty(2, 2)
    film.total += 3.0
    film.samples = 6
    executor = ConstantPasses(per_step=4)
    result = render_progressively(executor, film, target=6, kernel="general")
    assert result.stats.samples == 6 and ("advance", 6) not in executor.calls
    result = render_progressively(ConstantPasses(per_step=4), film, target=12, kernel="general")
    assert result.film.samples == 12 and result.stats.rays == 2 * 2 * 6


def test_auto_switches_kernels_once_and_the_switch_is_not_rendering_time(monkeypatch):
    import renderer.session as session

    monkeypatch.setattr(session, "worth_specialising", lambda seconds: True)
    monkeypatch.setattr(session, "first_kernel", lambda needed, choice: GENERAL)  # as if none were compiled
    executor = ConstantPasses(switch_seconds=0.3)
    lines = []
    result = render_progressively(executor, Film.empty(2, 2), target=5, needed=NEEDED, kernel="auto", notify=lines.append)
    assert executor.calls[0] == ("start", GENERAL)
    assert [c for c in executor.calls if c[0] == "switch"] == [("switch", NEEDED)]  # after the first step, once
    assert executor.calls[2] == ("switch", NEEDED)
    assert result.stats.features == NEEDED and result.stats.compile_seconds == pytest.approx(0.3, abs=0.01)
    assert result.stats.seconds < 0.3
    assert any("switching" in line for line in lines)
    assert result.film.samples == 5


def test_an_executor_that_cannot_switch_keeps_its_kernel(monkeypatch):
    import renderer.session as session

    monkeypatch.setattr(session, "worth_specialising", lambda seconds: True)
    monkeypatch.setattr(session, "first_kernel", lambda needed, choice: GENERAL)
    executor = ConstantPasses()
    executor.can_switch_kernel = False
    result = render_progressively(executor, Film.empty(2, 2), target=5, needed=NEEDED, kernel="auto")
    assert result.stats.features == GENERAL and not any(c[0] == "switch" for c in executor.calls)


def test_the_kernel_choice():
    assert choose_kernel(NEEDED, "general") == (GENERAL, False)
    assert choose_kernel(NEEDED, "specialised") == (NEEDED, False)
    assert choose_kernel(NEEDED, "auto", GENERAL) == (GENERAL, False)  # named outright: no switch
    with pytest.raises(ValueError, match="lacks paths"):
        choose_kernel(GENERAL, "auto", NEEDED)


# -- the process environment


def test_import_rt_leaves_the_environment_alone():
    import subprocess
    import sys

    code = "import os; before = dict(os.environ); import rt; assert dict(os.environ) == before, 'changed'"
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


def test_the_command_line_still_asks_for_one_blas_thread():
    import subprocess
    import sys

    code = ("import os, sys; sys.argv = ['rt', '--help']; import rt.__main__ as m\n"
            "try:\n    m.run()\nexcept SystemExit:\n    pass\n"
            "print(os.environ.get('OPENBLAS_NUM_THREADS'), os.environ.get('OMP_NUM_THREADS'))")
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert done.stdout.strip().splitlines()[-1] == "1 1", done.stderr


# -- every front end through the same session, bit for bit

SMALL = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 24, aspect_ratio: 2, samples_per_pixel: 5, max_depth: 6, seed: 11}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}, g: {type: dielectric, ior: 1.5},
            l: {type: diffuse_light, emit: [4, 4, 4]}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: g}
  - {type: sphere, center: [1, 2, 0], radius: 0.3, material: l}
"""


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["mis", "path"])
def test_cli_api_and_the_local_executor_give_the_same_film(tmp_path, integrator):
    from typer.testing import CliRunner

    import rt
    from renderer.flat import Frame
    from renderer.local_passes import LocalPasses
    from renderer.session import flatten_loaded
    from renderer.variants import features_of
    from rt.cli import app

    scene = tmp_path / "small.yaml"
    scene.write_text(SMALL)
    state = tmp_path / "small.npz"
    result = CliRunner().invoke(app, ["render", str(scene), "-o", str(tmp_path / "small.png"), "--save-state", str(state),
                                      "--integrator", integrator, "--kernel", "general"])
    assert result.exit_code == 0, result.output
    with np.load(state) as saved:
        cli_total, cli_total_sq = saved["total"], saved["total_sq"]

    image = rt.render(scene, integrator=integrator, kernel="general")

    graph, flat = flatten_loaded(rt.load(scene), integrator=integrator)
    frame = Frame.of(graph)
    executor = LocalPasses(flat, frame.width, frame.height, seed=frame.seed, depth=frame.max_depth, estimator=frame.estimator,
                           pass_seconds=1e-7, threads=2)  # a pass in many bands: the split changes no bit
    direct = render_progressively(executor, Film.empty(frame.width, frame.height), target=frame.samples,
                                  needed=features_of(graph), kernel="general")
    assert direct.film.samples == image.samples == 5
    assert direct.film.total.sum() > 0
    for total, total_sq in ((cli_total, cli_total_sq), (image.film.total, image.film.total_sq)):
        assert np.array_equal(total, direct.film.total) and np.array_equal(total_sq, direct.film.total_sq)
    assert image.stats.stop_reason == direct.stats.stop_reason == "samples"
    assert image.stats.rays == direct.stats.rays > 0
