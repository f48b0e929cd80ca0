"""The paths a newcomer takes (issue 29): what `rt` says on them, run as a user runs it.

- the help of every command shows its text in square brackets (".[cluster]");
- `--resume` with a state of another scene or image size says which, not that the file is large;
  a state cut short or damaged is one clear line;
- `rt watch` says nothing when a browser resets its connection;
- `rt.render` of an unchanged scene a second time in one process does not load it again;
- a copy of the renderer at another path says it is compiling when it is.
"""

from __future__ import annotations

import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.test_cli import run_rt, write
from tests.test_render_job import SMALL

ROOT = Path(__file__).resolve().parents[1]

# -- help texts


def _help(*command: str) -> str:
    out = run_rt(*command, "--help", cwd=ROOT, env_extra={"COLUMNS": "200"})
    assert out.returncode == 0, out.stderr
    return " ".join(out.stdout.split())


@pytest.mark.slow
def test_render_help_shows_the_cluster_extra():
    assert "pip install '.[cluster]'" in _help("render")


@pytest.mark.slow
def test_no_help_text_loses_words_in_square_brackets():
    import re

    import typer

    from rt.cli import app

    group = typer.main.get_command(app)
    for name, command in [("", group), *group.commands.items()]:
        texts = [command.help or "", command.epilog or ""] + [getattr(p, "help", None) or "" for p in command.params]
        bracketed = [b for text in texts for b in re.findall(r"\[[^\]]*\]", " ".join(text.split()))]
        shown = _help(*([name] if name else []))
        for words in bracketed:
            assert words in shown, f"rt {name} --help lost {words!r}"


# -- resuming a state of another render

# test_render_job's small scene at 200x100 and 1 sample
SCENE_A = SMALL.replace("width: 16,", "width: 200,").replace("samples_per_pixel: 4,", "samples_per_pixel: 1,")
SCENE_B = SCENE_A.replace("[0.6, 0.3, 0.2]", "[0.2, 0.3, 0.6]")


@pytest.fixture(scope="module")
def saved_state(tmp_path_factory):
    """A folder with scenes a.yaml and b.yaml and a.npz: a state of a.yaml at 200x100, 1 sample."""
    folder = tmp_path_factory.mktemp("states")
    write(folder, "a.yaml", SCENE_A)
    write(folder, "b.yaml", SCENE_B)
    out = run_rt("render", "a.yaml", "--save-state", "a.npz", cwd=folder)
    assert out.returncode == 0, out.stderr
    return folder


def _refused(out, *words):
    assert out.returncode == 1, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    for word in words:
        assert word in lines[0], lines[0]
    assert "larger than" not in lines[0]
    return lines[0]


@pytest.mark.slow
def test_resuming_a_state_of_another_scene_and_size_says_so(saved_state):
    # The state (about 960 KB) is far larger than a 16-pixel-wide state can be: the refusal
    # used to say only that, not whose state it is.
    out = run_rt("render", "b.yaml", "--width", "16", "--spp", "2", "--resume", "a.npz", cwd=saved_state)
    line = _refused(out, "a.npz: this state does not match this render: it is of another scene (or of this one before a "
                         "change to it) and of a 200x100 image (this render is 16x8)")
    assert "seed" not in line and "max depth" not in line and "integrator" not in line
    assert not (saved_state / "b.png").exists()


@pytest.mark.slow
def test_resuming_at_another_size_seed_depth_or_integrator_names_each(saved_state):
    out = run_rt("render", "a.yaml", "--width", "16", "--spp", "2", "--resume", "a.npz", cwd=saved_state)
    line = _refused(out, "this state does not match this render: it is of a 200x100 image (this render is 16x8)")
    assert "another scene" not in line
    out = run_rt("render", "a.yaml", "--spp", "2", "--seed", "9", "--max-depth", "6", "--integrator", "path",
                 "--resume", "a.npz", cwd=saved_state)
    _refused(out, "max depth 4 (now 6); seed 5 (now 9); integrator mis (now path)")


@pytest.mark.slow
def test_a_state_cut_short_or_damaged_is_refused_in_one_line(saved_state):
    data = (saved_state / "a.npz").read_bytes()
    cut = data[: len(data) // 2]
    (saved_state / "cut.npz").write_bytes(cut)
    out = run_rt("render", "a.yaml", "--spp", "2", "--resume", "cut.npz", "-o", "cut.png", cwd=saved_state)
    _refused(out, "cut.npz: not a saved render state, or one cut short")
    # Inside the data of the sums of samples (nonzero after a render; other arrays hold zeros that zeros would not
    # damage): the member's checksum fails.
    import io
    import zipfile

    member = zipfile.ZipFile(io.BytesIO(data)).getinfo("total.npy")
    middle = member.header_offset + 30 + len(member.filename) + member.file_size // 2
    bad = data[:middle] + bytes([0xA5]) * 64 + data[middle + 64:]
    (saved_state / "bad.npz").write_bytes(bad)
    out = run_rt("render", "a.yaml", "--spp", "2", "--resume", "bad.npz", "-o", "bad.png", cwd=saved_state)
    _refused(out, "bad.npz: the member 'total.npy' cannot be read")
    # Refused before rendering: no image written, and the states are as they were.
    assert not (saved_state / "cut.png").exists() and not (saved_state / "bad.png").exists()
    assert (saved_state / "cut.npz").read_bytes() == cut and (saved_state / "bad.npz").read_bytes() == bad


def test_a_state_of_a_larger_image_is_refused_by_its_key_after_reading_little(tmp_path):
    import tracemalloc

    from renderer.film import Film
    from renderer.state import RenderKey, StateError, load_state, save_state

    saved = RenderKey("ab" * 32, 600, 600, 50, 7)
    save_state(tmp_path / "run.npz", Film(np.zeros((600, 600, 3)), np.zeros((600, 600, 3)), 1), saved)
    tracemalloc.start()
    try:
        with pytest.raises(StateError) as excinfo:
            load_state(tmp_path / "run.npz", RenderKey("ab" * 32, 64, 64, 8, 7, "path"))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(excinfo.value) == (f"{tmp_path / 'run.npz'}: this state does not match this render: it is of a 600x600 "
                                  "image (this render is 64x64); max depth 50 (now 8); integrator mis (now path)")
    assert peak < 1_000_000  # the 8.6 MB file is not read: only its directory and key


# -- rt watch and connections reset by the browser

BROKEN = "shapes:\n  - {type: sphere, radious: 1}\n"  # no render, so no kernel to load: the server alone


def _reset(sock: socket.socket) -> None:
    """Close `sock` with a reset (RST), as a browser that gives up on a request may."""
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    sock.close()


@pytest.mark.slow
def test_rt_watch_passes_over_connections_reset_by_the_client(tmp_path):
    write(tmp_path, "scene.yaml", BROKEN)
    process = subprocess.Popen([sys.executable, "-m", "rt", "watch", "scene.yaml", "--port", "0"], cwd=tmp_path,
                               stderr=subprocess.PIPE, text=True)
    try:
        banner = process.stderr.readline()
        assert banner.startswith("rt watch: http://127.0.0.1:"), banner
        port = int(banner.split("http://127.0.0.1:")[1].split("/")[0])
        for _ in range(3):  # reset in the middle of a request line
            sock = socket.create_connection(("127.0.0.1", port), timeout=10)
            sock.sendall(b"GET / HT")
            time.sleep(0.1)
            _reset(sock)
        for path in ("/", "/app.js", "/events"):  # reset before the answer is written
            sock = socket.create_connection(("127.0.0.1", port), timeout=10)
            sock.sendall(f"GET {path} HTTP/1.0\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
            _reset(sock)
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        err = process.communicate(timeout=30)[1]
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert "Traceback" not in err and "Exception occurred" not in err, err
    assert err.rstrip().endswith("stopped")


def test_rt_watch_reports_another_server_error_in_one_line(tmp_path):
    from rt.watch import Watch, WatchOptions

    said = []
    watch = Watch(WatchOptions(tmp_path / "scene.yaml"), port=0, say=said.append)
    try:
        try:
            raise ValueError("a bug\nin two lines")
        except ValueError:
            watch.server.handle_error(None, ("127.0.0.1", 5000))
        try:
            raise ConnectionResetError(104, "Connection reset by peer")
        except ConnectionResetError:
            watch.server.handle_error(None, ("127.0.0.1", 5001))
    finally:
        watch.server.server_close()
    assert len(said) == 1 and "\n" not in said[0], said
    assert said[0].startswith("rt watch: a request from 127.0.0.1 failed: ValueError: a bug")


# -- rt.render keeps the scene it prepared

BALL = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 24, aspect_ratio: 2, samples_per_pixel: 2, max_depth: 4, seed: 3}
include: [lib.yaml]
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: ground}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: ball}
"""
BALL_LIB = "materials:\n  ground: {type: lambertian, albedo: [0.5, 0.5, 0.5]}\n  ball: {type: lambertian, albedo: [0.8, 0.2, 0.2]}\n"


@pytest.fixture
def counted(monkeypatch):
    """rt.api with its loads and flattenings counted: {"load": n, "flatten": n}."""
    import renderer.session
    import rt.api

    rt.api.forget_prepared_scenes()
    calls = {"load": 0, "flatten": 0}
    load, flatten = rt.api.load, renderer.session.flatten_loaded

    def counting_load(*args, **kw):
        calls["load"] += 1
        return load(*args, **kw)

    def counting_flatten(*args, **kw):
        calls["flatten"] += 1
        return flatten(*args, **kw)

    monkeypatch.setattr(rt.api, "load", counting_load)
    monkeypatch.setattr(renderer.session, "flatten_loaded", counting_flatten)
    yield calls
    rt.api.forget_prepared_scenes()


def _bump(path: Path) -> None:
    """Give `path` a later modification time than it has, whatever the clock's resolution."""
    info = path.stat()
    os.utime(path, ns=(info.st_atime_ns, info.st_mtime_ns + 2_000_000_000))


@pytest.mark.slow
def test_rendering_an_unchanged_scene_file_again_skips_loading_it(tmp_path, counted):
    import rt
    import rt.api

    scene = write(tmp_path, "ball.yaml", BALL)
    lib = write(tmp_path, "lib.yaml", BALL_LIB)
    first = rt.render(scene)
    second = rt.render(str(scene))
    assert counted == {"load": 1, "flatten": 1}
    assert np.array_equal(first.array, second.array)
    # Other options of the render itself (samples, seed) keep the prepared scene.
    rt.render(scene, spp=1, seed=4)
    assert counted == {"load": 1, "flatten": 1}
    # The same scene prepared from scratch renders the very same image.
    rt.api.forget_prepared_scenes()
    assert np.array_equal(rt.render(scene).array, first.array)
    assert counted == {"load": 2, "flatten": 2}

    # A saved include is read again: the ball turns blue.
    lib.write_text(BALL_LIB.replace("[0.8, 0.2, 0.2]", "[0.2, 0.2, 0.8]"))
    _bump(lib)
    blue = rt.render(scene)
    assert counted == {"load": 3, "flatten": 3}
    r, _, b = blue.array[6, 12]
    assert b > r and not np.array_equal(blue.array, first.array)
    # A new modification time alone is enough, and another width or integrator is another entry.
    _bump(scene)
    rt.render(scene)
    assert counted["load"] == 4
    rt.render(scene, width=16)
    rt.render(scene, integrator="path")
    assert counted["load"] == 6
    rt.render(scene, width=16)  # the two latest are kept
    assert counted["load"] == 6


@pytest.mark.slow
def test_a_dict_or_model_is_kept_by_its_content(tmp_path, counted, monkeypatch):
    import yaml

    import rt

    monkeypatch.chdir(tmp_path)
    data = yaml.safe_load(BALL)
    data.pop("include")
    data["materials"] = yaml.safe_load(BALL_LIB)["materials"]
    first = rt.render(data)
    assert np.array_equal(rt.render(dict(data)).array, first.array)
    assert counted["flatten"] == 1
    data["materials"]["ball"]["albedo"] = [0.2, 0.2, 0.8]  # changed in place: another scene
    assert not np.array_equal(rt.render(data).array, first.array)
    assert counted["flatten"] == 2
    scene = rt.load(data).scene
    rt.render(scene)
    rt.render(scene)
    assert counted["flatten"] == 3


# -- a copy of the renderer at another path says it is compiling

TINY = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0]}
image: {width: 8, aspect_ratio: 1, samples_per_pixel: 1, max_depth: 2}
materials: {m: {type: lambertian, albedo: [0.5, 0.5, 0.5]}}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: m}
"""
COMPILING = "compiling the renderer's"


def _install_copy(folder: Path) -> Path:
    """The packages' sources copied to `folder`, as a second installation of the same version."""
    import shutil

    for package in ("renderer", "rt", "scenefmt", "schemas"):
        shutil.copytree(ROOT / package, folder / package, ignore=shutil.ignore_patterns("__pycache__"))
    write(folder, "tiny.yaml", TINY)
    return folder


@pytest.mark.slow
def test_the_same_sources_at_another_path_say_they_compile(tmp_path):
    # The checkout and a copy of it share the user's cache, as an installation and an editable
    # install of one version do. The checkout's kernel is compiled by then (by the render below if
    # no earlier test did), so only the copy's first render has anything to compile.
    second = _install_copy(tmp_path / "two")
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONPATH", None)
    where = subprocess.run([sys.executable, "-c", "import renderer; print(renderer.__file__)"], cwd=second, env=env,
                           capture_output=True, text=True, check=True)
    assert where.stdout.strip() == str(second / "renderer" / "__init__.py")  # `python -m rt` here runs the copy

    def render(folder: Path) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "rt", "render", str(second / "tiny.yaml"), "-o", str(tmp_path / "t.png")],
                              cwd=folder, env=env, capture_output=True, text=True, timeout=900)

    out = render(ROOT)
    assert out.returncode == 0, out.stderr
    out = render(ROOT)  # the control: compiled, so it says nothing
    assert out.returncode == 0 and COMPILING not in out.stderr, out.stderr
    # The same sources at another path: Numba's cache misses them, so it compiles and must say so.
    # The message comes before the compile: stop the process once it has said it.
    process = subprocess.Popen([sys.executable, "-m", "rt", "render", "tiny.yaml"], cwd=second, env=env,
                               stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        said = ""
        for line in process.stderr:
            said += line
            if COMPILING in line:
                break
    finally:
        process.kill()
        process.wait()
    assert COMPILING in said, said
