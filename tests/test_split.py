"""The `rt render` program in two processes (rt/split.py): the same output as one process, the
child's errors and exit statuses passed on, and any other failure of the child made good by
the parent running the whole command itself."""

import os
import pickle
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from rt import split
from rt.cli import app

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no os.fork on this platform: rt render runs in one process there (can_split)")

# Runs the `rt` program; notes on stderr when the front end hands over (and whether it imported
# numpy), and whether the parent imported typer, pydantic or the scene format. PROBE_FAIL=kill or raise makes the child's front half fail.
PROBE = """
import os, sys
parent = os.getpid()
import rt.split as s
hand_over = s.FrontEnd.hand_over
def noted(self, *args):
    sys.stderr.write("handed over by the front end\\n")
    sys.stderr.write(f"front end imported numpy {'numpy' in sys.modules}\\n")
    hand_over(self, *args)
s.FrontEnd.hand_over = noted
mode = os.environ.get("PROBE_FAIL")
if mode:
    import rt.render_job as job
    prepare = job.prepare
    def failing(opts):
        if os.getpid() != parent:
            if mode == "kill":
                os.kill(os.getpid(), 9)
            if mode == "sleep":
                open(os.environ["PROBE_PID_FILE"], "w").write(str(os.getpid()))
                __import__("time").sleep(60)
            raise RuntimeError("a bug in the front half")
        return prepare(opts)
    job.prepare = failing
fds = int(os.environ.get("PROBE_OPEN_FDS") or 0)
if fds:  # take the low descriptors, so the program's pipe gets one numbered above 1024
    import resource
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, fds + 64), hard))
    held = [os.dup(2) for _ in range(fds)]
from rt.__main__ import run
sys.argv = ["rt", *sys.argv[1:]]
code = 0
try:
    run()
except SystemExit as exc:
    code = exc.code
sys.stderr.write(f"parent imported typer {'typer' in sys.modules} pydantic {'pydantic' in sys.modules} "
                 f"scenefmt {'scenefmt' in sys.modules}\\n")
sys.exit(code)
"""
HANDED = "handed over by the front end"


def run_program(*args, cwd, fail=None, **env_extra):
    env = dict(os.environ, PROBE_FAIL=fail or "", **env_extra)
    return subprocess.run([sys.executable, "-c", PROBE, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


def program_lines(stderr):
    return [line for line in stderr.splitlines() if line != HANDED and not line.startswith(("parent imported", "front end imported"))]


def render_here(*args):
    # In this process Numba is already imported: both halves run here.
    import numba  # noqa: F401

    assert not split.can_split(["rt", "render"])
    return CliRunner().invoke(app, ["render", *args])


SCENE_ARGS = ("--width", "24", "--spp", "3")


def test_a_real_render_is_split_and_writes_the_image_one_process_does(tmp_path):
    scene = str(ROOT / "scenes" / "cornell_smoke.yaml")
    out = run_program("render", scene, "-o", "two.png", "--hdr", "two.pfm", *SCENE_ARGS, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert HANDED in out.stderr
    # The process that renders never needed the command line's libraries, nor the front end numpy
    # (the scene has no image textures: its tables are plain Python values, see renderer/tables.py).
    assert "parent imported typer False pydantic False scenefmt False" in out.stderr
    assert "front end imported numpy False" in out.stderr
    assert "wrote two.png, two.pfm: 24x24, 3 spp" in out.stdout
    here = render_here(scene, "-o", str(tmp_path / "one.png"), "--hdr", str(tmp_path / "one.pfm"), *SCENE_ARGS)
    assert here.exit_code == 0, here.stderr
    assert (tmp_path / "two.pfm").read_bytes() == (tmp_path / "one.pfm").read_bytes()
    assert (tmp_path / "two.png").read_bytes() == (tmp_path / "one.png").read_bytes()
    assert np.isfinite(np.frombuffer((tmp_path / "one.pfm").read_bytes()[-24 * 24 * 12:], np.float32)).all()


@pytest.mark.parametrize("name, images", [("earth", True), ("perlin_spheres", False)])
def test_image_and_noise_textures_cross_to_the_parent_as_one_process_renders_them(tmp_path, name, images):
    # Texels cross the pipe as numpy arrays (the front half imports numpy for images only); a
    # noise texture crosses as its seed, and the parent makes its lattice tables.
    scene = str(ROOT / "scenes" / f"{name}.yaml")
    out = run_program("render", scene, "-o", "two.png", "--hdr", "two.pfm", *SCENE_ARGS, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert HANDED in out.stderr and f"front end imported numpy {images}" in out.stderr
    here = render_here(scene, "-o", str(tmp_path / "one.png"), "--hdr", str(tmp_path / "one.pfm"), *SCENE_ARGS)
    assert here.exit_code == 0, here.stderr
    assert (tmp_path / "two.pfm").read_bytes() == (tmp_path / "one.pfm").read_bytes()
    assert np.frombuffer((tmp_path / "one.pfm").read_bytes()[-24 * 12 * 12:], np.float32).mean() > 0.01


def test_explain_prints_the_front_halfs_lines_before_the_back_halfs(tmp_path):
    scene = str(ROOT / "scenes" / "cornell_smoke.yaml")
    out = run_program("render", scene, "-o", "x.png", "--explain", *SCENE_ARGS, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    lines = program_lines(out.stderr)
    here = render_here(scene, "-o", str(tmp_path / "y.png"), "--explain", *SCENE_ARGS)
    expected = [line for line in here.stderr.splitlines() if not line.startswith("[")]
    assert [line for line in lines if not line.startswith("[")] == expected
    assert expected[0].startswith("motion blur") and expected[-1].startswith("kernel: ")


def test_an_invalid_scene_prints_the_diagnostics_one_process_does(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("materials: {glass: {type: dielectric, ior: -1}}\n"
                    "shapes:\n  - {type: sphere, center: [0, 0, 0], radious: 1, material: glass}\n")
    out = run_program("render", str(path), cwd=tmp_path)
    assert out.returncode == 1
    here = render_here(str(path))
    assert here.exit_code == 1
    assert program_lines(out.stderr) == here.stderr.splitlines() and len(here.stderr.splitlines()) >= 2
    assert HANDED not in out.stderr and not list(tmp_path.glob("*.png"))


@pytest.mark.parametrize("args, status", [(["--help"], 0), ([], 2), (["x.yaml", "--spp", "0"], 2), (["x.yaml", "-o", "x.jpg"], 1)])
def test_help_usage_errors_and_bad_options_end_with_the_childs_status_and_output(tmp_path, args, status):
    (tmp_path / "x.yaml").write_text("shapes: []\n")
    out = run_program("render", *args, cwd=tmp_path)
    here = CliRunner().invoke(app, ["render", *args], prog_name="rt")
    assert (out.returncode, here.exit_code) == (status, status)
    assert out.stdout == here.stdout
    assert program_lines(out.stderr) == here.stderr.splitlines()


@pytest.mark.parametrize("fail", ["kill", "raise"])
def test_when_the_front_half_dies_or_fails_the_parent_runs_the_whole_command(tmp_path, fail):
    scene = str(ROOT / "scenes" / "cornell_smoke.yaml")
    out = run_program("render", scene, "-o", "x.png", "--hdr", "x.pfm", *SCENE_ARGS, cwd=tmp_path, fail=fail)
    assert out.returncode == 0, out.stderr
    assert HANDED not in out.stderr and "Traceback" not in out.stderr
    here = render_here(scene, "-o", str(tmp_path / "y.png"), "--hdr", str(tmp_path / "y.pfm"), *SCENE_ARGS)
    assert (tmp_path / "x.pfm").read_bytes() == (tmp_path / "y.pfm").read_bytes()


def test_when_loading_the_renderer_fails_the_childs_output_and_status_come_first(tmp_path):
    # NUMBA_NUM_THREADS=0 makes importing Numba fail; one process reads the scene first and
    # reports its errors without ever importing Numba.
    path = tmp_path / "bad.yaml"
    path.write_text("shapes:\n  - {type: sphere, center: [0, 0, 0], radious: 1}\n")
    out = run_program("render", str(path), cwd=tmp_path, NUMBA_NUM_THREADS="0")
    assert out.returncode == 1, out.stderr
    assert "bad.yaml:2:39" in out.stderr and "Traceback" not in out.stderr
    help_out = run_program("render", "--help", cwd=tmp_path, NUMBA_NUM_THREADS="0")
    assert help_out.returncode == 0 and "Usage: rt render" in help_out.stdout and "Traceback" not in help_out.stderr


def test_the_program_works_when_its_pipe_gets_a_descriptor_above_1024(tmp_path):
    import resource

    if resource.getrlimit(resource.RLIMIT_NOFILE)[1] < 1200:
        pytest.skip("the hard limit on open files is below 1200")
    scene = str(ROOT / "scenes" / "cornell_smoke.yaml")
    out = run_program("render", scene, "-o", "x.png", *SCENE_ARGS, cwd=tmp_path, PROBE_OPEN_FDS="1100")
    assert out.returncode == 0, out.stderr
    assert HANDED in out.stderr


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the child ends with its parent through prctl (Linux)")
def test_a_parent_killed_alone_takes_the_child_with_it(tmp_path):
    import time

    pid_file = tmp_path / "child.pid"
    env = dict(os.environ, PROBE_FAIL="sleep", PROBE_PID_FILE=str(pid_file))
    proc = subprocess.Popen([sys.executable, "-c", PROBE, "render", str(ROOT / "scenes" / "cornell_smoke.yaml")], cwd=tmp_path,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while not pid_file.exists() or not pid_file.read_text():
        assert time.time() < deadline and proc.poll() is None
        time.sleep(0.05)
    child = int(pid_file.read_text())
    proc.kill()  # SIGKILL: the parent cannot pass anything on
    proc.wait()
    deadline = time.time() + 10
    while time.time() < deadline:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(child, signal.SIGKILL)
    pytest.fail("the front-end child outlived its parent")


def fork_child(body):
    """A child running body(write_fd) and ending; the parent's split._Child for it."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read_end)
        try:
            body(write_end)
        finally:
            os._exit(0)
    os.close(write_end)
    return split._Child(read_end, pid)


def test_a_message_cut_short_or_not_ours_is_no_message():
    whole = pickle.dumps(("exit", 3))
    assert fork_child(lambda fd: os.write(fd, whole)).message() == ("exit", 3)
    assert fork_child(lambda fd: os.write(fd, whole[:-3])).message() is None
    assert fork_child(lambda fd: os.write(fd, pickle.dumps(("other", 1)))).message() is None
    assert fork_child(lambda fd: None).message() is None


def test_the_message_is_kept_when_the_child_was_reaped_already():
    # A parent that ignores SIGCHLD has its children reaped by the system: waitpid then fails.
    previous = signal.signal(signal.SIGCHLD, signal.SIG_IGN)
    try:
        message = fork_child(lambda fd: os.write(fd, pickle.dumps(("exit", 0)))).message()
    finally:
        signal.signal(signal.SIGCHLD, previous)
    assert message == ("exit", 0)


def test_close_stops_a_child_still_working():
    child = fork_child(lambda fd: __import__("time").sleep(60))
    pid = child.pid
    child.close()
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, 0)  # already reaped


def test_a_child_that_has_sent_its_message_is_left_to_end_by_itself_and_reaped(tmp_path):
    mark = tmp_path / "ended"

    def body(fd):
        os.write(fd, pickle.dumps(("exit", 0)))
        os.close(fd)
        __import__("time").sleep(0.2)
        mark.write_text("ended by itself")

    child = fork_child(body)
    pid = child.pid
    assert child.message() == ("exit", 0)
    child.close()
    assert mark.read_text() == "ended by itself"  # not killed
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, 0)  # already reaped


def test_exit_statuses_are_the_interpreters():
    assert [split._exit_status(c) for c in (None, 0, 2, 130)] == [0, 0, 2, 130]


def test_only_a_render_in_a_fresh_process_is_split():
    import numba  # noqa: F401

    assert not split.can_split(["rt", "render", "x.yaml"])  # Numba is imported in this process
    assert not split.can_split(["rt", "validate", "x.yaml"])


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="limiting the probe to one core needs os.sched_setaffinity (Linux)")
def test_on_one_core_the_render_runs_in_one_process_and_an_invalid_scene_is_reported_before_numba_loads(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("shapes:\n  - {type: sphere, center: [0, 0, 0], radious: 1}\n")
    probe = (
        "import os, sys\n"
        "os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})\n"
        "from rt import split\n"
        "assert not split.can_split(['rt', 'render'])\n"
        "from rt.__main__ import run\n"
        "sys.argv = ['rt', 'render', sys.argv[1]]\n"
        "try:\n    run()\nexcept SystemExit as exc:\n    print('exit', exc.code, 'numba' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe, str(path)], capture_output=True, text=True)
    assert out.stdout.split() == ["exit", "1", "False"], out.stdout + out.stderr
    assert "bad.yaml:2:39" in out.stderr
