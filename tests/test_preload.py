"""`rt render` reads the scene in a child process (rt/preload.py): the same answer as in-process,
the scene's errors as diagnostics, and any other failure handed back to the caller."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from renderer.assemble import assemble
from rt import preload
from rt.cli import app

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no os.fork on this platform: rt render reads the scene in its own process there (can_fork)")


def same_flat(a, b):
    for name in a._fields:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), name


@pytest.mark.parametrize("stem", ["final_scene", "cornell_smoke", "earth"])
def test_the_child_gives_the_tables_this_process_would(stem):
    path = ROOT / "scenes" / f"{stem}.yaml"
    kind, (tables, frame) = preload.SceneLoader(path, 48).result()
    assert kind == "tables"
    here_tables, here_frame, _ = preload.load_tables(path, 48)
    assert frame == here_frame and frame.width == 48
    same_flat(assemble(tables), assemble(here_tables))


def test_scene_errors_come_back_as_diagnostics(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("shapes:\n  - {type: sphere, center: [0, 0, 0], radious: 1}\n")
    kind, diagnostics = preload.SceneLoader(path, None).result()
    assert kind == "scene"
    assert (2, 39) in [(d.line, d.column) for d in diagnostics]  # at the misspelt key
    assert any("radious" in str(d) for d in diagnostics)


def test_an_image_the_check_passes_but_that_cannot_be_decoded_is_a_value_error(tmp_path):
    from PIL import Image

    Image.new("RGB", (64, 64), (200, 10, 10)).save(tmp_path / "tex.png")
    data = (tmp_path / "tex.png").read_bytes()
    (tmp_path / "tex.png").write_bytes(data[: len(data) // 2])  # the header reads, the pixels do not
    path = tmp_path / "s.yaml"
    path.write_text("materials: {e: {type: lambertian, albedo: {type: image, file: tex.png}}}\n"
                    "shapes: [{type: sphere, center: [0, 0, -2], radius: 1, material: e}]\n")
    kind, message = preload.SceneLoader(path, None).result()
    assert kind == "value" and "tex.png" in message


def _die(*_):
    os.kill(os.getpid(), signal.SIGKILL)


def _fail(*_):
    raise RuntimeError("a bug in the loader")


@pytest.mark.parametrize("loader", [_die, _fail])
def test_a_child_that_dies_or_fails_otherwise_gives_no_answer(monkeypatch, loader):
    # The forked child runs the module as it is at the fork, patched function included.
    monkeypatch.setattr(preload, "load_tables", loader)
    assert preload.SceneLoader(ROOT / "scenes" / "cornell_box.yaml", None).result() is None


def test_the_answer_is_kept_when_the_child_was_reaped_already():
    # A parent that ignores SIGCHLD has its children reaped by the system: waitpid then fails.
    previous = signal.signal(signal.SIGCHLD, signal.SIG_IGN)
    try:
        outcome = preload.SceneLoader(ROOT / "scenes" / "cornell_box.yaml", None).result()
    finally:
        signal.signal(signal.SIGCHLD, previous)
    assert outcome is not None and outcome[0] == "tables"


def test_close_stops_a_child_still_working(monkeypatch):
    monkeypatch.setattr(preload, "load_tables", lambda *_: __import__("time").sleep(60))
    loader = preload.SceneLoader(ROOT / "scenes" / "cornell_box.yaml", None)
    pid = loader.pid
    loader.close()
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, 0)  # already reaped


PROBE = """
import sys
import rt.preload as p
result = p.SceneLoader.result
def noted(self):
    sys.stderr.write("scene read by a child process\\n")
    return result(self)
p.SceneLoader.result = noted
from rt.__main__ import run
sys.argv = ["rt", *sys.argv[1:]]
run()
"""


def run_program(*args, cwd):
    return subprocess.run([sys.executable, "-c", PROBE, *args], cwd=cwd, capture_output=True, text=True)


def test_a_real_render_reads_the_scene_in_a_child_and_gives_the_in_process_image(tmp_path):
    scene = str(ROOT / "scenes" / "cornell_smoke.yaml")
    out = run_program("render", scene, "-o", "child.png", "--hdr", "child.pfm", "--width", "24", "--spp", "3", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "scene read by a child process" in out.stderr
    # In this process Numba is already imported, so the scene is read here.
    import numba  # noqa: F401

    assert not preload.can_fork()
    result = CliRunner().invoke(app, ["render", scene, "-o", str(tmp_path / "here.png"), "--hdr", str(tmp_path / "here.pfm"),
                                      "--width", "24", "--spp", "3"])
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "child.pfm").read_bytes() == (tmp_path / "here.pfm").read_bytes()
    assert np.isfinite(np.frombuffer((tmp_path / "here.pfm").read_bytes()[-24 * 24 * 12:], np.float32)).all()


def test_a_real_render_of_an_invalid_scene_prints_the_diagnostics_the_in_process_one_does(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("materials: {glass: {type: dielectric, ior: -1}}\n"
                    "shapes:\n  - {type: sphere, center: [0, 0, 0], radious: 1, material: glass}\n")
    out = run_program("render", str(path), cwd=tmp_path)
    assert out.returncode == 1
    assert "scene read by a child process" in out.stderr
    here = CliRunner().invoke(app, ["render", str(path)])
    assert here.exit_code == 1
    child_lines = [line for line in out.stderr.splitlines() if line != "scene read by a child process"]
    assert child_lines == here.stderr.splitlines() and len(child_lines) >= 2
    assert not list(tmp_path.glob("*.png"))


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="limiting the probe to one core needs os.sched_setaffinity (Linux)")
def test_on_one_core_the_scene_is_read_in_process_and_an_invalid_one_is_reported_before_numba_loads(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("shapes:\n  - {type: sphere, center: [0, 0, 0], radious: 1}\n")
    probe = (
        "import os, sys\n"
        "os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})\n"
        "from rt.__main__ import run\n"
        "sys.argv = ['rt', 'render', sys.argv[1]]\n"
        "try:\n    run()\nexcept SystemExit as exc:\n    print('exit', exc.code, 'numba' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe, str(path)], capture_output=True, text=True)
    assert out.stdout.split() == ["exit", "1", "False"], out.stdout + out.stderr
    assert "bad.yaml:2:39" in out.stderr
