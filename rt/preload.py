"""Reading a scene in a second process while this one starts the renderer.

`rt render` begins with two jobs that do not depend on each other: reading, checking and
flattening the scene (PyYAML, pydantic and numpy: about 0.2 s for bouncing spheres, 0.5 s for
the final scene) and importing Numba and loading the compiled code (about 0.4 s). Both are
Python bytecode, so two threads would only take turns on the interpreter lock. A forked child
does the first on another core while this process does the second, and sends the flattened
tables back through a pipe.

The child changes nothing but the time: it runs `read_scene`, the function this process would
otherwise run itself. The scene's own errors come back as diagnostics; if the child fails in any
other way (killed, out of memory, an unexpected exception, an answer that does not unpickle),
`result` returns None and the caller loads the scene itself, so every error surfaces exactly as
it does without the child.
"""

from __future__ import annotations

import os
import pickle
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Optional, Union

if TYPE_CHECKING:
    from renderer.flat import Frame
    from renderer.tables import SceneTables
    from scenefmt.diagnostics import Diagnostic
    from scenefmt.validation import LoadedScene

# What the child sends: ("tables", (tables, frame)), ("scene", diagnostics) or ("value", message).
Outcome = tuple[str, Union["tuple[SceneTables, Frame]", "list[Diagnostic]", str]]


def load_tables(scene: Path, width: Optional[int]) -> tuple[SceneTables, Frame, LoadedScene]:
    """The scene's tables (all but its trees), image settings at `width` if given, and models.

    Raises SceneError for an invalid scene and ValueError for input the format cannot check
    (an unreadable image file). Imports neither Numba nor any module with compiled code.
    """
    from renderer.compile import scene_tables, with_width
    from renderer.flat import Frame
    from scenefmt.validation import load

    loaded = load(scene)
    graph = loaded.graph if width is None else with_width(loaded.graph, width)
    return scene_tables(graph), Frame.of(graph), loaded


def read_scene(scene: Path, width: Optional[int]) -> tuple[Outcome, Optional[LoadedScene]]:
    """`load_tables` as an outcome (what the child sends), and the scene's models if it is valid."""
    from scenefmt.diagnostics import SceneError

    try:
        tables, frame, loaded = load_tables(scene, width)
    except SceneError as exc:
        return ("scene", list(exc.diagnostics)), None
    except ValueError as exc:
        return ("value", str(exc)), None
    return ("tables", (tables, frame)), loaded


def can_fork() -> bool:
    """Whether a child can load the scene to any gain: a fresh process (Numba not yet imported, so
    there is start-up to overlap) with one thread (a fork copies only the calling thread), and a
    second core for the child to run on."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return hasattr(os, "fork") and cores > 1 and "numba" not in sys.modules and threading.active_count() == 1


class SceneLoader:
    """A child process running `read_scene(scene, width)`; `result()` collects its outcome."""

    def __init__(self, scene: Path, width: Optional[int]):
        read_end, write_end = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child
            os.close(read_end)
            _child(write_end, scene, width)  # never returns
        os.close(write_end)
        self.pid: Optional[int] = pid
        self._read_end = read_end

    def result(self) -> Optional[Outcome]:
        """The child's outcome once it has finished, or None if it gave none (load the scene here)."""
        with os.fdopen(self._read_end, "rb") as pipe:
            self._read_end = -1
            data = pipe.read()
        try:
            os.waitpid(self.pid, 0)
        except ChildProcessError:  # reaped already (a parent that ignores SIGCHLD)
            pass
        self.pid = None
        # The child writes only a whole answer; one cut short (the child killed while writing)
        # does not unpickle.
        try:
            outcome = pickle.loads(data) if data else None
        except Exception:
            return None
        return outcome if isinstance(outcome, tuple) and len(outcome) == 2 else None

    def close(self) -> None:
        """Stop and reap the child if it is still there (this process is leaving early)."""
        if self._read_end >= 0:
            os.close(self._read_end)
            self._read_end = -1
        if self.pid is not None:
            try:
                os.kill(self.pid, signal.SIGKILL)
                os.waitpid(self.pid, 0)
            except (ProcessLookupError, ChildProcessError):
                pass
            self.pid = None


def _child(fd: int, scene: Path, width: Optional[int]) -> None:
    # Ctrl-C reaches the whole process group: the parent stops and kills this child.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    code = 1
    try:
        # The scene's models stay here: the command needs only the tables.
        outcome, _ = read_scene(scene, width)
        data = pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
        with os.fdopen(fd, "wb") as pipe:
            pipe.write(data)
        code = 0
    except BaseException:  # noqa: BLE001 - the parent loads the scene itself and reports the error
        pass
    finally:
        # No interpreter shutdown: it would run the parent's exit handlers and flush copies of
        # its output buffers.
        os._exit(code)
