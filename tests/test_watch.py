"""`rt watch`: its page, its events and its refusals, through HTTP and a server-sent events client.

tests/test_watch_browser.py drives the same page in a real browser where one is installed.
"""

import http.client
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rt.watch import Watch, WatchOptions

SCENE = """camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 64, aspect_ratio: 2, samples_per_pixel: 8, max_depth: 5}
include: [lib.yaml]
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: ground}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: ball}
"""
LIB = "materials:\n  ground: {type: lambertian, albedo: [0.5, 0.5, 0.5]}\n  ball: {type: lambertian, albedo: [0.8, 0.2, 0.2]}\n"


class Events:
    """A client of the page's event stream (what the page's EventSource receives)."""

    def __init__(self, port: int, timeout: float = 120.0):
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
        self.conn.request("GET", "/events")
        self.response = self.conn.getresponse()
        assert self.response.status == 200
        assert self.response.getheader("Content-Type") == "text/event-stream"

    def next(self):
        name = data = None
        while True:
            line = self.response.fp.readline().decode()
            assert line, "the event stream ended"
            line = line.rstrip("\n")
            if line.startswith("event: "):
                name = line[len("event: "):]
            elif line.startswith("data: "):
                data = json.loads(line[len("data: "):])
            elif line == "" and name:
                return name, data

    def until(self, want, timeout: float = 120.0):
        """The first event for which want(name, data) holds; every event before it."""
        deadline = time.monotonic() + timeout
        seen = []
        while time.monotonic() < deadline:
            name, data = self.next()
            seen.append((name, data))
            if want(name, data):
                return data, seen
        raise AssertionError(f"no such event in {timeout} s: {seen}")

    def close(self):
        self.conn.close()


def get(port, path, host=None, method="GET"):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    headers = {"Host": host} if host else {}
    conn.request(method, path, headers=headers)
    response = conn.getresponse()
    body = response.read()
    conn.close()
    return response.status, response.getheader("Content-Type"), body


def save(path: Path, text: str) -> None:
    """Write as an editor does, and make sure the modification time moves on coarse clocks."""
    before = path.stat().st_mtime_ns if path.exists() else 0
    path.write_text(text)
    if path.stat().st_mtime_ns == before:
        os.utime(path, ns=(before + 1_000_000, before + 1_000_000))


@pytest.fixture
def watched(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    (tmp_path / "lib.yaml").write_text(LIB)
    said = []
    watch = Watch(WatchOptions(tmp_path / "scene.yaml"), port=0, say=said.append).start()
    yield watch, tmp_path, said
    watch.close()


def test_the_server_serves_its_page_and_nothing_from_the_file_system(tmp_path):
    (tmp_path / "scene.yaml").write_text("shapes: [{type: sphere, radious: 1}]\n")
    watch = Watch(WatchOptions(tmp_path / "scene.yaml"), port=0, say=lambda m: None)
    try:
        assert watch.server.server_address[0] == "127.0.0.1"
        watch.start()
        port = watch.port
        status, kind, page = get(port, "/")
        assert status == 200 and kind.startswith("text/html") and b'<script src="/app.js">' in page
        assert get(port, "/app.js")[0] == 200
        for path in ("/scene.yaml", "/../scene.yaml", "/%2e%2e/etc/passwd", "/etc/passwd", "//etc/passwd", "/image.png/../scene.yaml",
                     "/app.js/", "/index.html"):
            status, _, body = get(port, path)
            assert status == 404 and b"radious" not in body, path
        assert get(port, "/", host="evil.example:80")[0] == 403  # DNS rebinding
        assert get(port, "/", host=f"localhost:{port}")[0] == 200
        assert get(port, "/", method="POST")[0] == 501
        assert get(port, "/", method="PUT")[0] == 501
        events = Events(port)
        problems, _ = events.until(lambda n, d: n == "problems" and d["errors"])
        events.close()
        (first,) = [e for e in problems["errors"] if e["path"] == "shapes[0].radious"]
        assert (first["line"], first["column"]) == (1, 25)
        assert first["source"] == "shapes: [{type: sphere, radious: 1}]"
        assert first["text"].endswith("scene.yaml:1:25: error: shapes[0].radious: unknown key 'radious'; did you mean 'radius'?")
        assert get(port, "/image.png")[0] == 404  # nothing good rendered yet
    finally:
        watch.close()


@pytest.mark.slow
def test_saves_render_again_errors_keep_the_last_image_and_mending_renders(watched):
    from io import BytesIO

    from PIL import Image

    watch, folder, said = watched
    events = Events(watch.port)
    try:
        # A small fast pass first, then the full image refining to the file's 8 samples. The board's
        # own history is read for the preview: a client that connects after it is posted is sent
        # only the latest image, which on a busy machine can already be the full one.
        final, seen = events.until(lambda n, d: n == "image" and d["samples"] == 8)
        preview = next(json.loads(text) for _, name, text in list(watch.board.events) if name == "image")
        assert preview["stage"] == "preview" and preview["width"] == 16 and preview["display_width"] == 64
        assert final["width"] == 64 and final["height"] == 32 and 0 < final["noise"] < 1
        status, kind, png = get(watch.port, "/image.png")
        assert status == 200 and kind == "image/png"
        first = Image.open(BytesIO(png))
        assert first.size == (64, 32)

        # Saving the scene renders it again.
        save(folder / "scene.yaml", SCENE.replace("radius: 0.5", "radius: 0.7"))
        changed, _ = events.until(lambda n, d: n == "image" and d["generation"] > final["generation"])
        generation = changed["generation"]
        assert changed["save_to_image"] is not None and changed["save_to_image"] < 10
        events.until(lambda n, d: n == "image" and d["samples"] == 8)
        second = get(watch.port, "/image.png")[2]
        assert second != png

        # So does saving a file it includes.
        save(folder / "lib.yaml", LIB.replace("[0.8, 0.2, 0.2]", "[0.2, 0.2, 0.8]"))
        recoloured, _ = events.until(lambda n, d: n == "image" and d["generation"] > generation and d["samples"] == 8)
        third = get(watch.port, "/image.png")[2]
        assert third != second
        r, g, b = Image.open(BytesIO(third)).convert("RGB").getpixel((32, 16))
        assert b > r  # the ball is blue now

        # A broken save shows the error, where it is and the line, and keeps the last good image.
        save(folder / "lib.yaml", LIB.replace("[0.5, 0.5, 0.5]", "[0.5, -0.5, 0.5]"))
        problems, _ = events.until(lambda n, d: n == "problems" and d["errors"])
        (error,) = problems["errors"]
        assert error["file"].endswith("lib.yaml") and (error["line"], error["column"]) == (2, 44)
        assert error["source"] == "  ground: {type: lambertian, albedo: [0.5, -0.5, 0.5]}"
        assert "materials.ground.albedo[1]: expected a number >= 0, found -0.5" in error["text"]
        assert any("lib.yaml:2:44" in line for line in said)
        assert get(watch.port, "/image.png")[2] == third

        # Mending it renders again and clears the errors.
        save(folder / "lib.yaml", LIB)
        cleared, _ = events.until(lambda n, d: n == "problems" and not d["errors"])
        events.until(lambda n, d: n == "image" and d["generation"] == cleared["generation"])
    finally:
        events.close()


@pytest.mark.slow
def test_ctrl_c_stops_rt_watch_cleanly(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    (tmp_path / "lib.yaml").write_text(LIB)
    process = subprocess.Popen([sys.executable, "-m", "rt", "watch", "scene.yaml", "--port", "0", "--spp", "100000"],
                               cwd=tmp_path, stderr=subprocess.PIPE, text=True)
    try:
        banner = process.stderr.readline()
        assert banner.startswith("rt watch: http://127.0.0.1:"), banner
        port = int(banner.split("http://127.0.0.1:")[1].split("/")[0])
        events = Events(port)
        events.until(lambda n, d: n == "image" and d["stage"] == "render")  # mid-render
        process.send_signal(signal.SIGINT)
        out = process.communicate(timeout=30)[1]
        events.close()
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, out
    assert out.rstrip().endswith("stopped") and "Traceback" not in out


def test_rt_watch_refuses_standard_input_and_a_port_in_use(tmp_path):
    import socket

    from typer.testing import CliRunner

    from rt.cli import app
    from rt.watch import serve

    result = CliRunner().invoke(app, ["watch", "-"])
    assert result.exit_code == 2 and "needs a scene file to watch" in result.stderr
    (tmp_path / "scene.yaml").write_text(SCENE)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        said = []
        assert serve(WatchOptions(tmp_path / "scene.yaml"), "127.0.0.1", taken.getsockname()[1], said.append) == 1
    assert said[0].startswith("error: cannot listen on 127.0.0.1:") and "choose another port with --port" in said[0]


def test_the_preview_reuses_the_full_scene_with_its_camera_at_the_preview_width():
    # Only the camera row depends on the image's size: the preview's tables are the full scene's
    # with that row replaced, equal to flattening the scene again at the preview width.
    import numpy as np

    import rt
    from renderer.session import flatten_loaded as flatten
    from rt.watch import preview_scene

    scenes = Path(__file__).resolve().parents[1] / "scenes"
    for name, width, integrator in (("cornell_box.yaml", None, None), ("earth.yaml", 300, "path"),
                                    ("sky_spheres.yaml", 97, None), ("quads.json", None, "mis")):
        loaded = rt.load(scenes / name)
        _, flat = flatten(loaded, width, integrator)
        small_graph, small_flat = preview_scene(loaded, flat, 37, integrator)
        graph, again = flatten(loaded, 37, integrator)
        assert small_graph.image == graph.image, name
        for table, a, b in zip(flat._fields, small_flat, again):
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), (name, table)
