"""`rt render --cluster` as a user runs it: a fresh process with no default Dask client, against
`--cluster local` or a scheduler and a worker started as `dask scheduler` / `dask worker`; and
what such a render keeps when its scheduler is killed, its workers all die or Ctrl-C stops it.

Every image is compared with the render of the same options without a cluster, bit for bit
(linear .pfm files, or the sums of saved states). Images are tiny and sample counts low where
the test allows; the fault tests need a render that lasts a few seconds, so that the fault
lands in its middle. Every process started here is ended in a `finally`.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CORNELL = ROOT / "scenes" / "cornell_box.yaml"
DASK = str(Path(sys.executable).with_name("dask"))
SMALL = ["--width", "12", "--spp", "2", "--kernel", "general"]
# Long enough on one worker thread (about 5 s at 8 x 8) that a fault lands mid-render, short
# enough to resume here in a few seconds.
LONG_SPP = 50000
LONG = ["--width", "8", "--spp", str(LONG_SPP), "--kernel", "general"]


def rt_command(*args, cwd, env=None, **kw):
    """`python -m rt ARGS` in a fresh process, as a user types it."""
    return subprocess.run([sys.executable, "-m", "rt", *map(str, args)], cwd=cwd, env=env, capture_output=True,
                          text=True, **kw)


def rt_process(*args, cwd, env=None):
    """`python -m rt ARGS` started, its standard error read line by line."""
    return subprocess.Popen([sys.executable, "-m", "rt", *map(str, args)], cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def end(process: subprocess.Popen) -> None:
    """End a process started here and its children (it leads its own session): SIGTERM, then SIGKILL."""
    if process.poll() is not None:
        return
    try:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=10)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        process.wait(timeout=10)


@contextmanager
def dask_cluster(folder: Path, nanny: bool = True):
    """A `dask scheduler` on 127.0.0.1 (a free port, read from its scheduler file) and one
    single-thread `dask worker`, as separate processes: (address, scheduler, worker)."""
    file = folder / "scheduler.json"
    logs = folder / "dask.log"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    processes = []
    with open(logs, "w") as log:
        try:
            scheduler = subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                          "--scheduler-file", str(file)], stdout=log, stderr=log, env=env,
                                         start_new_session=True, cwd=folder)
            processes.append(scheduler)
            deadline = time.monotonic() + 60
            while not file.exists() or not file.read_text().strip():
                assert scheduler.poll() is None and time.monotonic() < deadline, "the scheduler did not start"
                time.sleep(0.1)
            address = json.loads(file.read_text())["address"]
            worker = subprocess.Popen([DASK, "worker", "--scheduler-file", str(file), "--nthreads", "1", "--nworkers", "1",
                                       "--no-dashboard", "--host", "127.0.0.1", *([] if nanny else ["--no-nanny"])],
                                      stdout=log, stderr=log, env=env, start_new_session=True, cwd=folder)
            processes.append(worker)
            # `rt render` would wait for the worker to join, but it says how many workers it found
            # when it connects: wait until the worker has registered, so that figure is 1.
            while "Registered to:" not in logs.read_text():
                assert worker.poll() is None and time.monotonic() < deadline + 60, "the worker did not join"
                time.sleep(0.1)
            yield address, scheduler, worker
        finally:
            for process in reversed(processes):
                end(process)


def first_progress(process: subprocess.Popen, timeout: float = 120) -> list[str]:
    """The standard error lines of `rt render` up to its first progress line (a round merged)."""
    lines = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line:
            break
        lines.append(line)
        if re.search(r"\] \d+/\d+ spp", line):
            return lines
    raise AssertionError(f"no progress line: {''.join(lines)}")


def local_pfm(tmp_path: Path, name: str, options) -> bytes:
    out = rt_command("render", CORNELL, *options, "-o", f"{name}.png", "--hdr", f"{name}.pfm", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    return (tmp_path / f"{name}.pfm").read_bytes()


def same_state(a: Path, b: Path) -> bool:
    with np.load(a) as x, np.load(b) as y:
        return np.array_equal(x["total"], y["total"]) and np.array_equal(x["total_sq"], y["total_sq"])


def test_cluster_local_in_a_fresh_process_is_the_local_image(tmp_path):
    out = rt_command("render", CORNELL, *SMALL, "-o", "c.png", "--hdr", "c.pfm", "--cluster", "local", cwd=tmp_path,
                     timeout=300)
    assert out.returncode == 0, out.stderr
    assert "cluster: a local cluster" in out.stderr and "Traceback" not in out.stderr
    assert "wrote c.png, c.pfm: 12x12, 2 spp" in out.stdout
    assert (tmp_path / "c.pfm").read_bytes() == local_pfm(tmp_path, "l", SMALL)


def test_a_scheduler_and_worker_as_processes_give_the_local_image(tmp_path):
    with dask_cluster(tmp_path) as (address, _scheduler, _worker):
        out = rt_command("render", CORNELL, *SMALL, "-o", "c.png", "--hdr", "c.pfm", "--cluster", address, cwd=tmp_path,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert f"cluster: the scheduler at {address}: 1 workers, 1 threads" in out.stderr
    assert "Traceback" not in out.stderr
    assert (tmp_path / "c.pfm").read_bytes() == local_pfm(tmp_path, "l", SMALL)


def test_rt_render_with_cluster_local_from_a_fresh_python(tmp_path):
    code = f"""
import numpy as np, rt, distributed
a = rt.render({str(CORNELL)!r}, spp=2, width=12, kernel="general", cluster="local")
b = rt.render({str(CORNELL)!r}, spp=2, width=12, kernel="general")
same = a.film.samples == b.film.samples and np.array_equal(a.film.total, b.film.total) \\
    and np.array_equal(a.film.total_sq, b.film.total_sq)
try:
    distributed.default_client()
    default = "a default client was left"
except ValueError:
    default = "no default client"
print("same" if same else "different", default)
"""
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "same no default client"


def kill_scheduler_mid_render(tmp_path: Path, *args, env=None) -> tuple[subprocess.CompletedProcess, int, float]:
    """Start a long cluster render (`rt render ARGS`), kill its scheduler (SIGKILL) once a first
    round is merged: (the ended render, the samples merged when it said the scheduler went away,
    seconds from the kill to the end)."""
    with dask_cluster(tmp_path) as (address, scheduler, _worker):
        render = rt_process("render", *args, *LONG, "--cluster", address, cwd=tmp_path, env=env)
        try:
            before = first_progress(render)
            os.killpg(scheduler.pid, signal.SIGKILL)
            killed = time.monotonic()
            stdout, stderr = render.communicate(timeout=120)
            after = time.monotonic() - killed
        finally:
            if render.poll() is None:
                render.kill()
                render.wait()
    stderr = "".join(before) + stderr
    found = re.search(rf"error: the cluster's scheduler at {re.escape(address)} went away after (\d+) of {LONG_SPP} "
                      r"samples per pixel \(the connection to it is lost\); ", stderr)
    assert found, stderr
    return subprocess.CompletedProcess(render.args, render.returncode, stdout, stderr), int(found.group(1)), after


def test_a_killed_scheduler_saves_the_merged_samples_to_resume(tmp_path):
    out, merged, seconds = kill_scheduler_mid_render(tmp_path, CORNELL, "-o", "c.png", "--save-state", "s.npz")
    assert out.returncode == 1, out.stderr
    assert "Traceback" not in out.stderr and "CancelledError" not in out.stderr
    assert 1 <= merged < LONG_SPP
    assert out.stderr.splitlines()[-1].endswith(
        f"; the {merged} samples per pixel merged are saved in s.npz (continue with --resume s.npz)")
    assert seconds < 15
    assert not (tmp_path / "c.png").exists()  # an image of fewer samples than asked is not written as if done
    resumed = rt_command("render", CORNELL, *LONG, "-o", "r.png", "--resume", "s.npz", "--save-state", "r.npz",
                         cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming s.npz: {merged} samples per pixel already rendered" in resumed.stderr
    alone = rt_command("render", CORNELL, *LONG, "-o", "l.png", "--save-state", "l.npz", cwd=tmp_path)
    assert alone.returncode == 0, alone.stderr
    assert same_state(tmp_path / "r.npz", tmp_path / "l.npz")


def test_a_killed_scheduler_in_a_batch_rescues_the_samples(tmp_path):
    # Without --save-state (a batch takes none) the samples go to the temporary folder, as after
    # a failed write; the scenes after it fail in one line each, the client closed at once.
    rescue = tmp_path / "tmp"
    rescue.mkdir()
    out, merged, _ = kill_scheduler_mid_render(tmp_path, CORNELL, ROOT / "scenes" / "quads.json", "--hdr", "pfm",
                                               env={**os.environ, "TMPDIR": str(rescue)})
    assert out.returncode == 1
    assert "Traceback" not in out.stderr and "distributed" not in out.stderr
    saved = sorted(rescue.glob("rt-rescued-cornell_box-*"))
    assert [p.suffix for p in saved] == [".npz", ".pfm"]
    assert (f"the {merged} samples per pixel merged are saved in {saved[0]} and {saved[1]} (continue with --resume "
            f"{saved[0]})") in out.stderr
    with np.load(saved[0]) as state:  # a state as --save-state writes it, resumed in the test above
        assert json.loads(str(state["meta"]))["samples"] == merged
    assert "error: the cluster's scheduler went away during an earlier render: nothing more can run on it" in out.stderr
    assert out.stderr.splitlines()[-1] == "error: 2 of 2 scenes failed: " + f"{CORNELL}, {ROOT / 'scenes' / 'quads.json'}"


def test_every_worker_dead_ends_with_the_merged_samples(tmp_path, monkeypatch):
    # One worker without a nanny, killed mid-render: none is left to run the chunks. The CLI
    # runs in this process so that the wait for a worker to come back can be shortened.
    from typer.testing import CliRunner

    import rt.cluster
    from rt.cli import app

    monkeypatch.setattr(rt.cluster, "WORKERS_SECONDS", 3.0)
    monkeypatch.setattr(rt.cluster, "WORKERS_POLL_SECONDS", 0.5)
    with dask_cluster(tmp_path, nanny=False) as (address, _scheduler, worker):
        def kill_worker(stats):
            if worker.poll() is None:
                os.killpg(worker.pid, signal.SIGKILL)
                worker.wait()

        monkeypatch.setattr("rt.render_job.Progress.__call__", lambda self, stats: kill_worker(stats))
        started = time.monotonic()
        result = CliRunner().invoke(app, ["render", str(CORNELL), *LONG, "-o", str(tmp_path / "c.png"),
                                          "--save-state", str(tmp_path / "s.npz"), "--cluster", address])
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    found = re.search(rf"error: every worker left the cluster \(the scheduler at {re.escape(address)}\) after (\d+) of "
                      rf"{LONG_SPP} samples per pixel, and none joined within 3 s; the \1 samples per pixel merged are "
                      r"saved in \S+s\.npz", result.output)
    assert found, result.output
    assert time.monotonic() - started < 60
    with np.load(tmp_path / "s.npz") as state:
        assert json.loads(str(state["meta"]))["samples"] == int(found.group(1)) >= 1


def test_ctrl_c_on_a_cluster_render_writes_what_was_merged(tmp_path):
    with dask_cluster(tmp_path) as (address, _scheduler, _worker):
        render = rt_process("render", CORNELL, *LONG, "-o", "c.png", "--hdr", "c.pfm", "--save-state", "s.npz",
                            "--cluster", address, cwd=tmp_path)
        try:
            before = first_progress(render)
            render.send_signal(signal.SIGINT)
            stdout, stderr = render.communicate(timeout=60)
        finally:
            if render.poll() is None:
                render.kill()
                render.wait()
    stderr = "".join(before) + stderr
    assert render.returncode == 130, stderr
    assert "Traceback" not in stderr
    found = re.search(rf"interrupted: the image holds (\d+) of {LONG_SPP} samples per pixel", stderr)
    assert found, stderr
    merged = int(found.group(1))
    assert 1 <= merged < LONG_SPP
    assert f"{merged} spp" in stdout
    options = ["--width", "8", "--spp", str(merged), "--kernel", "general"]
    assert (tmp_path / "c.pfm").read_bytes() == local_pfm(tmp_path, "l", options)
