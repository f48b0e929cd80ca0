"""Stopping a render (Ctrl-C, SIGTERM) within a pass, and planning the specialised kernel's compile.

A long pass is rendered in bands of rows, and a stop request is honoured between bands: the
unfinished pass is taken back and the finished ones are saved. The first signal, SIGINT or
SIGTERM, stops and saves (exit 130 or 143); a second aborts at once. Under `--noise` the
switch to a specialised kernel is planned from the noise measured so far, not from the cap of a
million samples, and no compile counts as rendering time.
"""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from renderer.variants import seconds_left, worth_specialising

ROOT = Path(__file__).resolve().parents[1]

SMALL = """
camera: {look_from: [0, 2, 9], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 48, aspect_ratio: 1.5, samples_per_pixel: 6, max_depth: 8, seed: 3}
background: {type: sky}
materials:
  ground: {type: lambertian, albedo: [0.5, 0.5, 0.5]}
  glass: {type: dielectric, ior: 1.5}
  lamp: {type: diffuse_light, emit: [4, 4, 4]}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: ground}
  - {type: sphere, center: [-1, 0.6, 0], radius: 0.6, material: glass}
  - {type: quad, q: [-1, 2.5, -1], u: [2, 0, 0], v: [0, 0, 2], material: lamp}
"""


# ---- planning the specialised kernel's compile (no kernel runs) ----


def test_a_noise_budget_forecasts_from_the_noise_measured_not_from_the_cap():
    # Measured: cornell_box at 64 px, one sample per pixel in 1.34 ms, 11.85% noise after 21
    # samples, target 5%. Planned for the cap of a million samples, the render has 1339 s left
    # (and compiled the specialised kernel, 22 s here, for a render of a second); the noise says
    # it needs about 21 * (11.85 / 5)^2 = 118 samples in all: 0.13 s.
    per_sample = 1339.0 / 999_999
    assert worth_specialising(seconds_left(per_sample, 1, 1_000_000))
    left = seconds_left(per_sample, 21, 1_000_000, noise=0.1185, noise_target=0.05)
    assert left == pytest.approx(per_sample * (21 * (0.1185 / 0.05) ** 2 - 21))
    assert 0.1 < left < 0.2
    assert not worth_specialising(left)


def test_the_forecast_waits_for_a_noise_estimate_and_takes_the_least_of_the_limits():
    assert seconds_left(0.5, 1, 1000, noise=float("inf"), noise_target=0.01) is None  # not estimated yet
    assert seconds_left(0.5, 0, 1000, noise=None, noise_target=0.01) is None
    assert seconds_left(0.5, 40, 1000, noise=0.009, noise_target=0.01) == 0.0  # reached already
    # 40 samples at 10% need 4000 for 1%, but the cap is 1000: 960 more at 0.5 s.
    assert seconds_left(0.5, 40, 1000, noise=0.1, noise_target=0.01) == pytest.approx(480.0)
    # A time budget: what is left of it, unless the cap or the noise come first.
    assert seconds_left(0.5, 40, 1_000_000, time_left=600.0) == 600.0
    assert seconds_left(0.5, 40, 100, time_left=600.0) == pytest.approx(30.0)
    assert seconds_left(0.5, 40, 1_000_000, time_left=-3.0) == 0.0


def test_bands_take_about_the_time_asked_and_leave_no_sliver():
    from renderer.render import Bands

    bands = Bands(height=2000, seconds=0.25, threads=2)
    assert bands.end(0, 1) == 4  # before any speed is known: two rows a thread
    bands.measured(4, 1, 4 / 256)  # 1/256 s a row: 64 rows take 0.25 s
    assert bands.end(4, 1) == 4 + 32  # at most 8 times the last band while the speed is new
    bands.measured(32, 1, 32 / 256)
    assert bands.end(36, 1) == 36 + 64
    assert bands.end(36, 2) == 36 + 32  # a band of two samples a pixel takes twice as long a row
    assert bands.end(1960, 1) == 2000  # the last 40 rows
    assert bands.end(1940, 1) == 2000  # 60 rows: one band, not 64 and a sliver
    assert bands.end(1900, 1) == 1964
    bands.measured(64, 1, 1e-6)
    bands.measured(512, 1, 1e-6)
    assert bands.end(0, 1) == 2000  # a fast image is one band


# ---- bands, in this process ----


@pytest.fixture(scope="module")
def small():
    from renderer.compile import compile_scene
    from renderer.flat import Frame
    from renderer.variants import features_of
    from scenefmt.validation import loads

    graph = loads(SMALL).graph
    return compile_scene(graph), Frame.of(graph), features_of(graph)


def whole_image(small, samples):
    """Today's pass: the general kernel over every row at once, all samples in one call."""
    from renderer.tracing.integrator import render_pass

    from renderer.film import Film
    from renderer.sampling import uniform_sampling

    flat, frame, _ = small
    film = Film.empty(frame.width, frame.height)
    rays, bad = np.zeros(frame.height, np.int64), np.zeros(frame.height, np.int64)
    render_pass(flat, frame.width, frame.height, frame.seed, 0, samples, frame.max_depth, frame.estimator, uniform_sampling(),
                film.sums, rays, bad, 0, frame.height)
    return film.total, film.total_sq, int(rays.sum())


@pytest.mark.slow
def test_a_pass_in_many_bands_is_the_whole_pass_bit_for_bit(small, monkeypatch):
    import renderer.render as render_module

    flat, frame, needed = small
    sizes = []
    measured = render_module.Bands.measured
    monkeypatch.setattr(render_module.Bands, "measured", lambda self, rows, n, s: (sizes.append(rows), measured(self, rows, n, s)))
    banded = render_module.render_flat(flat, frame, samples=6, needed=needed, kernel="general", pass_seconds=1e-7)
    assert len(sizes) >= 6 * 2 and max(sizes) < frame.height  # every pass was split
    total, total_sq, rays = whole_image(small, 6)
    assert banded.film.total.sum() > 0
    assert np.array_equal(banded.film.total, total) and np.array_equal(banded.film.total_sq, total_sq)
    assert banded.stats.rays == rays


@pytest.mark.slow
def test_a_stop_between_bands_takes_the_unfinished_pass_back(small):
    from renderer.render import render_flat

    flat, frame, needed = small
    passes, polls = [], []

    def should_stop():  # poll 0 is before the first pass; stop in the middle of the third pass
        polls.append(len(passes))
        return len(passes) == 2 and polls.count(2) > 3

    result = render_flat(flat, frame, samples=1000, needed=needed, kernel="general", pass_seconds=1e-7,
                         should_stop=should_stop, progress=lambda stats: passes.append(stats.samples))
    assert result.stats.interrupted and polls.count(2) == 4  # three bands of the third pass were rendered, then taken back
    done = passes[-1]
    assert result.film.samples == done == 2  # two passes of a sample each (passes of 0.1 us hold one sample)
    total, total_sq, rays = whole_image(small, done)
    assert np.array_equal(result.film.total, total) and np.array_equal(result.film.total_sq, total_sq)
    assert result.stats.rays == rays


@pytest.mark.slow
def test_compiling_is_not_rendering_time(small, monkeypatch):
    """A kernel compiled during the render (here: a load made to take a second, as a compile
    does) is counted apart from the rendering time, which a time budget spends."""
    import renderer.local_passes as executor_module
    import renderer.render as render_module
    import renderer.session as session_module

    flat, frame, needed = small
    from renderer.variants import GENERAL

    real = executor_module.kernel_set

    def slow_kernel_set(features):  # the general kernel, whatever is asked: no real compile
        time.sleep(1.0)
        return real(GENERAL)

    monkeypatch.setattr(executor_module, "kernel_set", slow_kernel_set)
    monkeypatch.setattr(session_module, "first_kernel", lambda needed, choice: GENERAL)
    monkeypatch.setattr(executor_module, "is_compiled", lambda features: False)
    monkeypatch.setattr(executor_module, "mark_compiled", lambda features: None)  # nothing was compiled
    monkeypatch.setattr(session_module, "worth_specialising", lambda seconds: True)
    result = render_module.render_flat(flat, frame, samples=3, needed=needed, kernel="auto")
    assert result.stats.features == needed  # switched after the first pass: a second "compile"
    assert result.stats.compile_seconds >= 2.0
    assert result.stats.seconds < 0.9


# ---- the command, in a process of its own ----


def rt_command(*args):
    return [sys.executable, "-m", "rt", "render", *args]


# A pass of several seconds on one thread (5 to 8 s on a busy 2-core machine), of an image small
# enough to write in well under a second. The general kernel: "auto" would compile the
# specialised one for so long a render.
WIDE = ("scenes/cornell_knot.yaml", "--width", "1000", "--threads", "1", "--kernel", "general", "--spp", "1000")


def stop_mid_pass(tmp_path, signals, gap=0.0):
    """Start a long render, send `signals` (gap seconds apart) half a second into its second pass;
    (exit status, stderr, seconds from the first signal to the exit)."""
    process = subprocess.Popen(rt_command(*WIDE, "-o", str(tmp_path / "out.png"), "--save-state", str(tmp_path / "run.npz")),
                               cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        for line in process.stderr:  # the first progress line: the first pass is done
            lines.append(line)
            if " spp " in line:
                break
        time.sleep(0.5)
        sent = time.perf_counter()
        for i, number in enumerate(signals):
            if i:
                time.sleep(gap)
            process.send_signal(number)
        rest = process.stderr.read()
        process.wait(timeout=60)
        delay = time.perf_counter() - sent
        print(f"signals {[signal.Signals(n).name for n in signals]}: {delay:.2f} s to the exit")
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process.returncode, "".join(lines) + rest, delay


def state_samples(path):
    with np.load(path) as state:
        return json.loads(state["meta"].item())["samples"]


def held_samples(stderr):
    (line,) = [line for line in stderr.splitlines() if line.startswith("interrupted: the image holds")]
    return int(line.split()[4])


def first_pass_seconds(stderr):
    """The first pass's time, from the first progress line ('1/1000 spp  3.9s elapsed')."""
    match = re.search(r" 1/1000 spp\s+([0-9.]+)s elapsed", stderr)
    assert match, stderr
    return float(match.group(1))


def check_stopped_mid_pass(stderr, delay, tmp_path):
    """The second pass, of one sample like the first and as long, was stopped half a second in
    and taken back: the state holds the first pass only (waiting for the pass held two)."""
    assert first_pass_seconds(stderr) > 1.0, "the scene renders too fast here for a pass to be stopped in the middle"
    assert delay < 3.0, f"{delay:.1f} s from the signal to the end: {stderr}"
    assert held_samples(stderr) == 1
    assert state_samples(tmp_path / "run.npz") == 1
    assert (tmp_path / "out.png").stat().st_size > 0


def stop_one_signal_mid_pass(tmp_path, signum, status_wanted: int, name: str) -> None:
    """One signal in the middle of a pass: the exit status, the words said, and what was kept."""
    status, stderr, delay = stop_mid_pass(tmp_path, [signum])
    assert status == status_wanted, stderr
    assert "Traceback" not in stderr
    assert f"interrupted ({name}): stopping, and saving the passes rendered so far" in stderr
    check_stopped_mid_pass(stderr, delay, tmp_path)


@pytest.mark.slow
def test_ctrl_c_mid_pass_stops_within_seconds_and_the_state_resumes(tmp_path):
    stop_one_signal_mid_pass(tmp_path, signal.SIGINT, 130, "Ctrl-C")
    held = 1
    resumed = subprocess.run(rt_command("scenes/cornell_knot.yaml", "--width", "1000", "--kernel", "general", "--spp", str(held + 1),
                                        "--resume", str(tmp_path / "run.npz"), "-o", str(tmp_path / "more.png")),
                             cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{held} samples per pixel already rendered" in resumed.stderr
    assert f"1000x1000, {held + 1} spp" in resumed.stdout


@pytest.mark.slow
def test_sigterm_mid_pass_saves_what_is_rendered_and_exits_143(tmp_path):
    stop_one_signal_mid_pass(tmp_path, signal.SIGTERM, 143, "SIGTERM")
    # What was saved is the rendered pass itself: the whole 1000-pixel-wide image, lit (the knot's
    # lamp), and a state whose sums are finite and positive, not zeros written in a hurry.
    from PIL import Image

    with Image.open(tmp_path / "out.png") as png:
        pixels = np.asarray(png.convert("RGB"), np.float64)
    assert pixels.shape[1] == 1000
    assert pixels.mean() > 5.0, pixels.mean()
    with np.load(tmp_path / "run.npz") as state:
        sums = [state[name] for name in state.files if name != "meta" and state[name].dtype.kind == "f"]
    assert sums and all(np.isfinite(a).all() for a in sums)
    assert max(float(a.sum()) for a in sums) > 0.0


@pytest.mark.slow
def test_a_second_signal_aborts_at_once_and_leaves_no_file(tmp_path):
    status, stderr, delay = stop_mid_pass(tmp_path, [signal.SIGINT, signal.SIGTERM], gap=0.05)
    assert status == 143, stderr
    assert "Traceback" not in stderr
    # The first signal stops the render at the end of a band; the second comes before the
    # images are written (nothing is saved) or while they are (those in place are whole).
    assert "aborted by a second SIGTERM" in stderr
    assert delay < 2.0, stderr
    left = sorted(p.name for p in tmp_path.iterdir())
    assert set(left) <= {"out.png", "run.npz"}, left  # no temporary file
    if "nothing is saved" in stderr:
        assert left == []
    if "run.npz" in left:
        assert state_samples(tmp_path / "run.npz") == 1
    if "out.png" in left:
        assert (tmp_path / "out.png").read_bytes().endswith(b"IEND\xaeB`\x82")  # a whole PNG


def test_the_first_signal_stops_and_the_second_aborts_and_none_waits_before_a_pass_is_done():
    from rt.render_job import Aborted, StopSignals

    lines = []
    stop = StopSignals(lines.append, nothing_to_save=lambda: False)
    stop.handle(signal.SIGTERM, None)
    assert stop.requested() and stop.status == 143 and "interrupted (SIGTERM)" in lines[0]
    with pytest.raises(Aborted) as second:
        stop.handle(signal.SIGINT, None)
    assert (second.value.status, second.value.first) == (130, False)
    # Before the first pass (a kernel's compile can take a minute), the first signal ends at once.
    with pytest.raises(Aborted) as first:
        StopSignals(lines.append, nothing_to_save=lambda: True).handle(signal.SIGINT, None)
    assert (first.value.status, first.value.first) == (130, True)


@pytest.mark.slow
def test_a_signal_before_the_first_pass_is_done_ends_at_once_with_nothing_saved(tmp_path):
    process = subprocess.Popen(rt_command(*WIDE, "--explain", "-o", str(tmp_path / "out.png"), "--save-state", str(tmp_path / "run.npz")),
                               cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        for line in process.stderr:
            if line.startswith("kernel:"):  # said just before the kernel is loaded and the first pass starts
                break
        time.sleep(1.0)
        sent = time.perf_counter()
        process.send_signal(signal.SIGTERM)
        stderr = process.stderr.read()
        process.wait(timeout=60)
        delay = time.perf_counter() - sent
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 143, stderr
    assert "interrupted before the first pass finished: nothing to save" in stderr
    assert "Traceback" not in stderr and " spp " not in stderr
    assert delay < 2.0, f"{delay:.1f} s"
    assert list(tmp_path.iterdir()) == []


def general_kernel_only_cache(tmp_path):
    """A Numba cache folder holding the general kernel (compiled if need be) and no specialised one."""
    from renderer.jit_cache import general_folder

    scene = tmp_path / "warm.yaml"
    scene.write_text(SMALL)
    warm = subprocess.run(rt_command(str(scene), "--kernel", "general", "--spp", "1", "-o", str(tmp_path / "warm.png")),
                          cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert warm.returncode == 0, warm.stderr
    folder = tmp_path / "numba"
    shutil.copytree(general_folder(), folder, ignore=lambda where, names: ["variants"] if "variants" in names else [])
    assert list(folder.glob("rt-kernel-ready-all-*")), "the general kernel is not marked compiled"  # named per installation
    return folder


@pytest.mark.slow
def test_a_noise_budget_renders_with_the_compiled_kernel_and_compiles_nothing(tmp_path):
    # Before, the cap of a million samples made this second-long render compile the kernel
    # specialised to the Cornell box first ("about 1339 s of rendering left"): 22 s and more.
    cache = general_kernel_only_cache(tmp_path)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    result = subprocess.run(rt_command("scenes/cornell_box.yaml", "--width", "64", "--noise", "0.05", "-o", str(tmp_path / "n.png")),
                            cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert "switching" not in result.stderr and "compiling" not in result.stderr, result.stderr
    assert "stopped: the estimated noise" in result.stderr
    assert "compiling" not in result.stdout  # the summary names a compile only when there was one
    assert not (cache / "variants").exists()
