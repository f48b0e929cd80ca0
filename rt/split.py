"""The `rt render` program in two processes: one reads the scene while the other loads the renderer.

A render starts with two jobs that do not depend on each other, both Python bytecode, so two
threads would only take turns on the interpreter lock:

- the front half (render_job.prepare): parsing the command line (typer, which imports pydantic
  for it), then reading, checking and flattening the scene (PyYAML, pydantic; numpy only for
  image textures and for --resume or --save-state): about 0.33 s for bouncing spheres on a
  2-core machine, 0.6 s for the final scene;
- loading the renderer (render_job.load_renderer): importing Numba and loading the tree
  builder from the disk cache, about 0.33 s.

So the program forks at its start. The child runs the command line as usual; when `rt render`
has prepared the scene, the child hands the options and the scene's tables to the parent
through a pipe (`FrontEnd.hand_over`) and ends. Meanwhile the parent loads the renderer; it
then renders what it received (render_job.render_prepared). Whatever the child prints (help,
usage errors, the scene's errors, `--explain`) it prints itself, before it hands over, and the
parent ends with the child's exit status when there is nothing to render.

The split changes nothing but the time. If the child fails in any other way (killed, an
unexpected exception, an answer that does not unpickle), the parent runs the whole command
line itself, so every error surfaces as it does in one process. Ctrl-C reaches both processes
(a terminal signals the whole process group): the child ignores it and the parent, which
stops, kills it; a parent ended otherwise (SIGTERM, SIGKILL) takes the child with it on Linux.
If loading the renderer fails, the child's own output and status come first, as in one
process, which reads the scene before it loads Numba. No child is started where it cannot
gain: on one core, or in a process that already imported Numba (`rt.cli.app` called from
Python runs both halves in its own process).
"""

from __future__ import annotations

import os
import pickle
import select
import signal
import sys
import threading
from typing import TYPE_CHECKING, Any, Optional

if TYPE_CHECKING:
    from .render_job import PreparedScene, RenderOptions

# Set in the front-end child only: `rt render` hands its prepared scene to it.
front_end: Optional[FrontEnd] = None


def can_split(argv: list[str]) -> bool:
    """Whether `rt` with these arguments runs in two processes to any gain: `rt render`, in a
    fresh process (Numba not yet imported, so there is start-up to overlap) with one thread (a
    fork copies only the calling thread), and a second core for the child to run on."""
    if argv[1:2] != ["render"] or not hasattr(os, "fork"):
        return False
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return cores > 1 and "numba" not in sys.modules and threading.active_count() == 1


def run() -> int:
    """Run the `rt` command line split in two processes; the exit status.

    Only the child imports typer and the command line (and pydantic, which typer's parsing
    imports): the parent needs neither unless the child fails.
    """
    _flush()  # a fork copies unwritten output buffers
    parent = os.getpid()
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read_end)
        _front_end(write_end, parent)  # never returns
    os.close(write_end)
    return _back_end(_Child(read_end, pid))


def _run_command_line() -> None:
    from .cli import app

    app(prog_name="rt")  # ends in SystemExit


class FrontEnd:
    """The child's end of the pipe: one message, ("render", (options, scene, started)) or ("exit", status)."""

    def __init__(self, fd: int):
        self.fd = fd
        self.sent = False

    def hand_over(self, opts: RenderOptions, scene: PreparedScene, started: float) -> None:
        """Give the prepared render to the parent; `started` is time.perf_counter() when the
        command started (the same clock in both processes)."""
        self._send(("render", (opts, scene, started)))

    def _send(self, message: tuple[str, Any]) -> None:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        _flush()  # what this process printed comes before anything the parent prints
        with os.fdopen(self.fd, "wb") as pipe:
            pipe.write(data)
        self.sent = True


def _front_end(fd: int, parent: int) -> None:
    global front_end
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _end_with(parent)
    front_end = FrontEnd(fd)
    status: Optional[int] = None
    try:
        _run_command_line()
    except SystemExit as exc:
        status = _exit_status(exc.code)
    except BaseException:  # noqa: BLE001 - the parent runs the command itself and shows the error
        pass
    try:
        if status is not None and not front_end.sent:
            front_end._send(("exit", status))
    finally:
        _flush()
        # No interpreter shutdown: it would run the parent's exit handlers.
        os._exit(0)


class _Child:
    """The parent's end: the front-end child's pid and the pipe from it."""

    def __init__(self, fd: int, pid: int):
        self.fd: int = fd
        self.pid: Optional[int] = pid
        self.ending = False  # the child closed the pipe: it ends by itself

    def done(self) -> bool:
        """Whether the child has written its message or ended (a read would not wait long)."""
        # poll, not select: select cannot watch a descriptor numbered 1024 or more.
        poller = select.poll()
        poller.register(self.fd, select.POLLIN)
        return bool(poller.poll(0))

    def message(self) -> Optional[tuple[str, Any]]:
        """The child's message once it has closed the pipe, or None if it gave none (it failed).

        The child is reaped later, by `close`: the system takes a few milliseconds to release its
        memory, and the render need not wait for that.
        """
        with os.fdopen(self.fd, "rb") as pipe:
            self.fd = -1
            data = pipe.read()
        self.ending = True
        # The child writes only whole messages; one cut short (the child killed while writing)
        # does not unpickle.
        try:
            message = pickle.loads(data) if data else None
        except Exception:
            return None
        if isinstance(message, tuple) and len(message) == 2 and message[0] in ("render", "exit"):
            return message
        return None

    def close(self) -> None:
        """Stop the child if it is still there (this process is leaving early), and reap it."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
        if self.pid is None:
            return
        pid, self.pid = self.pid, None
        try:
            if os.waitpid(pid, os.WNOHANG)[0] == pid:
                return  # it had ended
        except ChildProcessError:
            return  # reaped by the system already (a parent that ignores SIGCHLD): its pid may be reused
        if not self.ending:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        try:
            os.waitpid(pid, 0)
        except ChildProcessError:
            pass


_PENDING = ("pending", None)


def _back_end(child: _Child) -> int:
    message: Optional[tuple[str, Any]] = _PENDING
    try:
        try:
            import numba  # noqa: F401 - the larger part of loading the renderer

            from .render_job import load_renderer

            # Help, a usage error or an invalid scene has usually ended the child by now: then
            # there is nothing to render, and no need to load more.
            if child.done():
                message = child.message()
            if message is _PENDING or (message is not None and message[0] == "render"):
                load_renderer()
            if message is _PENDING:
                message = child.message()
        except KeyboardInterrupt:
            return 130  # as typer does for the command line
        except Exception:
            # Loading the renderer failed. What the child had to say (help, the scene's errors)
            # comes first, with its status, as in one process, which reads the scene first.
            if message is _PENDING:
                message = child.message()
            if message is not None and message[0] == "exit":
                return message[1]
            raise
        if message is None:  # the child failed: the whole command line here
            _run_command_line()
            return 0
        kind, payload = message
        if kind == "exit":
            return payload
        from .render_job import render_prepared

        opts, scene, started = payload
        return _as_program(render_prepared, opts, scene, started)
    finally:
        child.close()


def _as_program(function, *args) -> int:
    """Call `function` the way typer runs a command of the program: its exit status."""
    import errno

    from .render_job import Stop

    try:
        function(*args)
    except Stop as stop:
        return stop.status
    except KeyboardInterrupt:
        return 130
    except OSError as exc:
        if exc.errno != errno.EPIPE:
            raise
        # The reader went away (`rt render ... | head`): end quietly, as typer does.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    return 0


def _end_with(parent: int) -> None:
    """Have the system kill this child when the parent ends (Linux), so a parent killed on its own
    (SIGTERM, SIGKILL) leaves no child reading the scene and printing after it."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # the parent ended before the request took effect
        os._exit(1)


def _exit_status(code: object) -> int:
    """The process status of SystemExit(code), as the interpreter would set it."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    sys.stderr.write(f"{code}\n")
    return 1


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
