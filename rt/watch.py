"""`rt watch`: a page that shows a scene refining, and renders it again each time a file it uses is saved.

One process keeps the kernels loaded, so a save costs a reload of the scene and the first pass,
not a new program. Three threads:

- the previewer loads the scene (recording every file it reads: the scene, its includes, its
  textures and meshes), renders a small fast pass, then the full image in passes of more samples,
  and posts each image (at most one every `FRAME_SECONDS`) or the scene's errors to the board;
- the poller compares those files' sizes and modification times every `POLL_SECONDS` and stops
  the render in progress at the end of its pass when one changes;
- the HTTP server (the standard library's, one thread per connection) serves the page, its
  script, the latest image and the board's events as server-sent events.

Why no dependencies: the standard library's server and server-sent events are enough for one
local page, and polling a scene's few files costs microseconds every 50 ms, works on every file
system (network mounts, editors that save by renaming a new file into place) and adds at most
50 ms to the time from a save to the first new image; a file-events library (watchfiles) would
save that 50 ms at the price of a compiled dependency.

The server answers only GET and HEAD of its own four paths and reads nothing from the file
system; it listens on 127.0.0.1 unless told otherwise, and then refuses requests whose Host
header is not the loopback address (a web page elsewhere cannot reach it through DNS rebinding).
The page's script sets text only (never HTML), so nothing in a scene file can run in it.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
import traceback
from collections import deque
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Callable, Optional
from urllib.parse import urlsplit

from scenefmt.assets import file_identity  # what a save changes: polled for every file the scene read

POLL_SECONDS = 0.05
FRAME_SECONDS = 0.5  # at most one full-size image this often, and always the last
PREVIEW_WIDTH = 160  # the first pass: a quarter of the width, at most this many pixels, 1 sample
SOURCE_LINE_CHARS = 400
LOOPBACK = ("127.0.0.1", "localhost", "::1")


@dataclass(frozen=True)
class WatchOptions:
    scene: Path
    spp: Optional[int] = None
    width: Optional[int] = None
    integrator: Optional[str] = None
    overrides: tuple[str, ...] = ()
    allow_paths: tuple = ()  # --allow-path: folders besides the scene's that its files may be in
    display: Optional[str] = None  # --display: the page's display transform; None: the scene's image.display


def source_line(file: str, line: int) -> str:
    """Line `line` of the file `file` (1-based), control characters escaped, at most
    SOURCE_LINE_CHARS; '' when it cannot be read (standard input, a --set argument)."""
    from scenefmt.diagnostics import escape_control
    from scenefmt.files import FileProblem, read_regular_file
    from scenefmt.loading import MAX_FILE_BYTES

    try:
        raw = read_regular_file(file, MAX_FILE_BYTES)
    except (FileProblem, OSError, ValueError):
        return ""
    lines = raw.decode("utf-8", "replace").splitlines()
    if not 1 <= line <= len(lines):
        return ""
    return escape_control(lines[line - 1].rstrip())[:SOURCE_LINE_CHARS]


def describe(diag) -> dict:
    """A diagnostic for the page: where, what, and the line it is about."""
    from scenefmt.diagnostics import escape_control

    out = diag.to_json()
    out["message"] = escape_control(out["message"])
    out["path"] = escape_control(out["path"])
    out["file"] = escape_control(out["file"])
    out["text"] = str(diag)
    # The line is shown only from a file known to be a scene: never a line of a file the scene
    # merely named (scenefmt.includes.not_a_scene), which may be anyone's secrets.
    out["source"] = source_line(diag.file, diag.line) if diag.quote_source else ""
    return out


def placeless_error(text: str, file: str = "", message: Optional[str] = None) -> dict:
    """An error for the page in `describe`'s shape, for a problem with no line to point at."""
    return {"text": text, "file": file, "line": 0, "column": 0, "path": "", "message": text if message is None else message,
            "severity": "error", "source": ""}


class Board:
    """What the page shows: a stream of events (status, image, problems) and the latest image's PNG."""

    def __init__(self, keep: int = 64):
        self.cond = threading.Condition()
        self.seq = 0
        self.events: deque = deque(maxlen=keep)  # (seq, name, json text)
        self.latest: dict[str, tuple] = {}  # name -> its latest event
        self.png: Optional[bytes] = None
        self.closed = False

    def post(self, name: str, data: dict, png: Optional[bytes] = None) -> None:
        with self.cond:
            self.seq += 1
            if png is not None:
                self.png = png
            event = (self.seq, name, json.dumps(data))
            self.events.append(event)
            self.latest[name] = event
            self.cond.notify_all()

    def wait(self, after: int, timeout: float) -> list:
        """The events after `after` (the latest of each kind if the client fell behind), waiting up
        to `timeout` seconds for one; [] on timeout or once closed."""
        with self.cond:
            self.cond.wait_for(lambda: self.seq > after or self.closed, timeout)
            if self.closed or self.seq <= after:
                return []
            if after < 0 or not self.events or self.events[0][0] > after + 1:
                return sorted(self.latest.values())
            return [e for e in self.events if e[0] > after]

    def close(self) -> None:
        with self.cond:
            self.closed = True
            self.cond.notify_all()


def preview_scene(loaded, flat, width: int, integrator: Optional[str] = None):
    """(graph, flat tables) of the scene at another `width`, from its tables `flat` at the full one.

    The image's size reaches the kernels only through the camera row (the pixel grid: see
    renderer/camera.py), so the full scene's tables serve with that row replaced: a save costs
    one flattening, not two.
    """
    import numpy as np

    from renderer.compile import camera_values
    from renderer.session import scene_graph_with

    graph = scene_graph_with(loaded, width, integrator)
    return graph, flat._replace(camera=np.array(camera_values(graph), np.float64))


class Previewer:
    """Renders the scene again whenever a file it read changes; posts what it has to the board."""

    def __init__(self, opts: WatchOptions, board: Board, say: Callable[[str], None]):
        self.opts = opts
        self.board = board
        self.say = say
        self.stopping = threading.Event()
        self.changed = threading.Event()
        self.lock = threading.Lock()
        scene = os.path.abspath(opts.scene)
        self.watched: dict[str, object] = {scene: file_identity(scene)}
        self.generation = 0
        self.version = 0
        self.display = opts.display or "gamma2"  # set again from the scene each time it is read (_render_once)
        self.saved_at: Optional[float] = None  # when the poller saw the change being rendered
        self.version_first = False  # the next image is the first since the change
        self.posted_noise: tuple = (None, 0, float("inf"))  # (film, its samples, relative_noise) of the last image posted
        self.threads = [
            threading.Thread(target=self._render_loop, name="rt-watch-render", daemon=True),
            threading.Thread(target=self._poll_loop, name="rt-watch-poll", daemon=True),
        ]

    def start(self) -> None:
        for thread in self.threads:
            thread.start()

    def stop(self, timeout: float = 30.0) -> None:
        self.stopping.set()
        self.changed.set()
        for thread in self.threads:
            thread.join(timeout)

    # -- watching files

    def _poll_loop(self) -> None:
        while not self.stopping.wait(POLL_SECONDS):
            with self.lock:
                watched = dict(self.watched)
            if any(file_identity(path) != seen for path, seen in watched.items()):
                with self.lock:
                    if self.watched == watched:  # not replaced by a reload meanwhile
                        self.watched = {path: file_identity(path) for path in watched}
                        self.saved_at = time.perf_counter()
                        self.changed.set()

    def _watch(self, paths: list[str], before: dict) -> None:
        """Watch `paths` from now on; those known before the load keep the signature they had then,
        so a save during the load still counts as a change."""
        paths = [os.path.abspath(self.opts.scene)] + paths
        with self.lock:
            self.watched = {p: before[p] if p in before else file_identity(p) for p in dict.fromkeys(paths)}
            if any(file_identity(p) != s for p, s in self.watched.items()):
                self.changed.set()

    # -- rendering

    def _should_stop(self) -> bool:
        return self.changed.is_set() or self.stopping.is_set()

    def _render_loop(self) -> None:
        while not self.stopping.is_set():
            self.changed.clear()
            self.generation += 1
            try:
                self._render_once()
            except Exception as exc:  # a bug: keep serving, and say what happened
                self.say("".join(traceback.format_exception(exc)).rstrip())
                error = placeless_error(f"internal error: {type(exc).__name__}: {exc}", message=str(exc))
                self.board.post("problems", {"generation": self.generation, "errors": [error]})
            while not self.changed.wait(0.5):
                pass

    def _post_image(self, film, target: int, display_width: int, stage: str, started: float) -> None:
        from renderer.film import png_bytes, relative_noise

        self.version += 1
        noise = relative_noise(film)
        self.posted_noise = (film, film.samples, noise)
        png = png_bytes(film.mean(), self.display)
        latency = time.perf_counter() - self.saved_at if self.saved_at is not None and self.version_first else None
        self.version_first = False
        data = {
            "version": self.version, "generation": self.generation, "stage": stage, "samples": film.samples,
            "target": target, "width": film.width, "height": film.height, "display_width": display_width,
            "noise": noise if noise != float("inf") else None,
            "seconds": round(time.perf_counter() - started, 3),
            "save_to_image": round(latency, 3) if latency is not None else None,
        }
        self.board.post("image", data, png)

    def _render_once(self) -> None:
        from renderer.film import Film
        from renderer.flat import Frame
        from renderer.render import render_flat
        from renderer.session import flatten_loaded
        from renderer.variants import compile_wait, features_of, first_kernel, is_compiled
        from scenefmt.diagnostics import SceneError
        from scenefmt.files import recording_reads
        from scenefmt.validation import load

        started = time.perf_counter()
        self.version_first = True
        generation = self.generation
        with self.lock:
            before = dict(self.watched)
        self.board.post("status", {"generation": generation, "text": "loading the scene"})
        with recording_reads() as reads:
            try:
                loaded = load(self.opts.scene, self.opts.overrides, allow_paths=self.opts.allow_paths)
                graph, flat = flatten_loaded(loaded, self.opts.width, self.opts.integrator)
            except SceneError as exc:
                errors = [describe(d) for d in exc.diagnostics]
            except ValueError as exc:  # an image that does not decode
                from scenefmt.diagnostics import escape_control

                errors = [placeless_error(escape_control(f"{self.opts.scene}: {exc}"), str(self.opts.scene))]
            else:
                errors = []
        self._watch(reads, before)
        if errors:
            for error in errors:
                self.say(error["text"])
            self.say(f"{self.opts.scene}: invalid; showing the last good image (save again to retry)")
            self.board.post("problems", {"generation": generation, "errors": errors})
            self.board.post("status", {"generation": generation, "text": "the scene has errors: fix them and save"})
            return
        self.board.post("problems", {"generation": generation, "errors": []})
        needed = features_of(graph)
        kernel = first_kernel(needed)  # never switch kernels mid-render: a save would wait for a compile
        if not is_compiled(kernel):
            text = f"compiling the renderer's kernel: {compile_wait(kernel)}, once per installation"
            self.say(text)
            self.board.post("status", {"generation": generation, "text": text})
        frame = Frame.of(graph)
        self.display = self.opts.display if self.opts.display is not None else graph.image.display
        target = self.opts.spp if self.opts.spp is not None else frame.samples
        self.board.post("status", {"generation": generation, "text": "rendering"})
        # A small, fast first pass: a quarter of the width, one sample.
        small = min(PREVIEW_WIDTH, frame.width // 4)
        if small >= 8:
            small_graph, small_flat = preview_scene(loaded, flat, small, self.opts.integrator)
            small_frame = Frame.of(small_graph)
            film = Film.empty(small_frame.width, small_frame.height)
            render_flat(small_flat, small_frame, samples=1, film=film, should_stop=self._should_stop, needed=needed,
                        features=kernel)
            if film.samples and not self._should_stop():
                self._post_image(film, target, frame.width, "preview", started)
        film = Film.empty(frame.width, frame.height)
        last = {"posted": 0.0, "samples": 0}

        def progress(_stats) -> None:
            now = time.perf_counter()
            if (now - last["posted"] >= FRAME_SECONDS or film.samples >= target) and not self._should_stop():
                self._post_image(film, target, frame.width, "render", started)
                last.update(posted=now, samples=film.samples)

        render_flat(flat, frame, samples=target, film=film, progress=progress, should_stop=self._should_stop, needed=needed,
                    features=kernel)
        if film.samples and film.samples != last["samples"] and not self._should_stop():
            self._post_image(film, target, frame.width, "render", started)
        if film.samples >= target:
            self._post_image_done(film, started)

    def _post_image_done(self, film, started: float) -> None:
        from renderer.film import relative_noise

        posted, samples, noise = self.posted_noise
        if posted is not film or samples != film.samples:  # the last pass was not posted (a save stopped it)
            noise = relative_noise(film)
        noise_text = f", noise {100 * noise:.2f}%" if noise != float("inf") else ""
        self.say(f"rendered {film.width}x{film.height}, {film.samples} spp{noise_text} in {time.perf_counter() - started:.1f} s")
        self.board.post("status", {"generation": self.generation, "text": "done"})


PAGE = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>rt watch: {title}</title>
<style>
  body {{ font: 14px system-ui, sans-serif; margin: 1em; background: #222; color: #ddd; }}
  #status {{ margin-bottom: 0.6em; font-variant-numeric: tabular-nums; }}
  #image {{ max-width: 100%; height: auto; background: #000; display: block; }}
  #problems {{ background: #4a1c1c; color: #fdd; padding: 0.6em 1em; margin: 0.6em 0; border-radius: 4px; }}
  #problems pre {{ margin: 0.2em 0 0.8em 1em; color: #fff; white-space: pre; overflow-x: auto; }}
  #problems .where {{ font-family: ui-monospace, monospace; }}
</style>
</head>
<body>
<div id="status">connecting</div>
<div id="problems" hidden><strong>The scene has errors; the image is the last good one.</strong><div id="list"></div></div>
<img id="image" alt="the render" hidden>
<script src="/app.js"></script>
</body>
</html>
"""

SCRIPT = """"use strict";
const status = document.getElementById("status");
const image = document.getElementById("image");
const problems = document.getElementById("problems");
const list = document.getElementById("list");
let summary = "";
let note = "";
function show() { status.textContent = summary + (note ? "  \\u00b7  " + note : ""); }
const events = new EventSource("/events");
events.addEventListener("image", (e) => {
  const d = JSON.parse(e.data);
  const next = new Image();
  next.onload = () => {
    image.src = next.src;
    image.width = d.display_width;
    image.hidden = false;
    image.dataset.version = d.version;
    image.dataset.generation = d.generation;
    image.dataset.samples = d.samples;
    const noise = d.noise === null ? "noise not estimated yet" : "noise " + (100 * d.noise).toFixed(2) + "%";
    summary = (d.stage === "preview" ? "preview " : "") + d.width + "\\u00d7" + d.height + ", " + d.samples + " of " +
      d.target + " spp, " + noise + ", " + d.seconds.toFixed(1) + " s";
    show();
  };
  next.src = "/image.png?v=" + d.version;
});
events.addEventListener("problems", (e) => {
  const d = JSON.parse(e.data);
  list.replaceChildren();
  for (const p of d.errors) {
    const where = document.createElement("div");
    where.className = "where";
    where.textContent = p.text;
    list.append(where);
    if (p.source) {
      const pre = document.createElement("pre");
      pre.textContent = p.source + "\\n" + " ".repeat(Math.max(0, p.column - 1)) + "^";
      list.append(pre);
    }
  }
  problems.hidden = d.errors.length === 0;
  document.body.dataset.problems = d.errors.length;
});
events.addEventListener("status", (e) => { note = JSON.parse(e.data).text; show(); });
events.onerror = () => { note = "disconnected (is rt watch still running?)"; show(); };
"""


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True
    board: Board
    page: bytes
    allowed_hosts: Optional[set]
    say: Callable[[str], None] = staticmethod(lambda message: None)

    def handle_error(self, request, client_address) -> None:
        """A request that failed. A browser that closes a tab, reloads or gives up on a request
        resets its connection at any point: that is no error, so it is passed over in silence.
        Anything else is one line in the terminal (the server goes on), never a traceback."""
        exc = sys.exc_info()[1]
        if isinstance(exc, (ConnectionError, TimeoutError)):
            return
        from scenefmt.diagnostics import escape_control

        self.say(escape_control(f"rt watch: a request from {client_address[0]} failed: {type(exc).__name__}: {exc}"))


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    server_version = "rt-watch"
    sys_version = ""
    protocol_version = "HTTP/1.0"

    def log_message(self, format, *args) -> None:  # quiet: the terminal shows renders and errors
        pass

    def do_GET(self) -> None:
        self._route(body=True)

    def do_HEAD(self) -> None:
        self._route(body=False)

    def _send(self, status: int, kind: str, data: bytes, body: bool) -> None:
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(data)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Content-Security-Policy",
                         "default-src 'none'; script-src 'self'; img-src 'self'; connect-src 'self'; style-src 'unsafe-inline'")
        self.end_headers()
        if body:
            self.wfile.write(data)

    def _route(self, body: bool) -> None:
        allowed = self.server.allowed_hosts
        if allowed is not None and (self.headers.get("Host") or "").lower() not in allowed:
            return self._send(403, "text/plain; charset=utf-8", b"forbidden: this server answers only to its loopback address\n", body)
        path = urlsplit(self.path).path
        if path == "/":
            return self._send(200, "text/html; charset=utf-8", self.server.page, body)
        if path == "/app.js":
            return self._send(200, "text/javascript; charset=utf-8", SCRIPT.encode(), body)
        if path == "/image.png":
            png = self.server.board.png
            if png is None:
                return self._send(404, "text/plain; charset=utf-8", b"no image yet\n", body)
            return self._send(200, "image/png", png, body)
        if path == "/events":
            return self._events(body)
        return self._send(404, "text/plain; charset=utf-8", b"not found: this server serves only its own page\n", body)

    def _events(self, body: bool) -> None:
        self.send_response(200)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        if not body:
            return
        board = self.server.board
        seen = -1
        try:
            self.wfile.write(b"retry: 1000\n\n")
            self.wfile.flush()
            while not board.closed:
                events = board.wait(seen, timeout=15.0)
                if not events:
                    self.wfile.write(b": keep-alive\n\n")
                for seq, name, data in events:
                    self.wfile.write(f"id: {seq}\nevent: {name}\ndata: {data}\n\n".encode())
                    seen = max(seen, seq)
                self.wfile.flush()
        except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError):
            pass


class Watch:
    """The running `rt watch`: `start()` binds and starts rendering, `url`, `close()`."""

    def __init__(self, opts: WatchOptions, host: str = "127.0.0.1", port: int = 8000, say: Callable[[str], None] = print):
        self.opts = opts
        self.board = Board()
        self.previewer = Previewer(opts, self.board, say)
        self.server = _Server((host, port), _Handler, bind_and_activate=True)
        self.server.board = self.board
        self.server.say = say
        from html import escape

        self.server.page = PAGE.format(title=escape(str(opts.scene))).encode()
        self.host = host
        self.port = self.server.server_address[1]
        self.server.allowed_hosts = (
            {f"{h}:{self.port}" for h in ("127.0.0.1", "localhost", "[::1]")} if host in LOOPBACK else None
        )
        self._thread = threading.Thread(target=self.server.serve_forever, kwargs={"poll_interval": 0.1}, name="rt-watch-http",
                                        daemon=True)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def start(self) -> "Watch":
        self._thread.start()
        self.previewer.start()
        return self

    def close(self) -> None:
        self.previewer.stopping.set()
        self.board.close()
        self.server.shutdown()
        self.server.server_close()
        self.previewer.stop()
        self._thread.join(5)


def serve(opts: WatchOptions, host: str, port: int, say: Callable[[str], None]) -> int:
    """The command: serve until Ctrl-C; the exit status."""
    from scenefmt.diagnostics import escape_control

    try:
        watch = Watch(opts, host, port, say)
    except OSError as exc:
        say(escape_control(f"error: cannot listen on {host}:{port}: {exc.strerror or exc}; choose another port with --port"))
        return 1
    if host not in LOOPBACK:
        say(f"warning: listening on {host}: anyone who can reach this machine can see the render")
    watch.start()
    say(f"rt watch: {watch.url} shows {escape_control(str(opts.scene))}; it renders again on each save (Ctrl-C to stop)")
    try:
        while True:
            time.sleep(0.2)
    except KeyboardInterrupt:
        say("stopping: finishing the current pass")
    finally:
        watch.close()
    say("stopped")
    return 0


def main_say(message: str) -> None:
    sys.stderr.write(message + "\n")
    sys.stderr.flush()
