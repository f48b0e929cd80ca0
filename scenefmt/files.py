"""Reading a file named by a user or a scene: regular files only, never more than a limit.

A path can name something that is not a file at all: `/dev/zero` (directly or through a
symlink) never ends, a FIFO blocks until a writer comes, a directory cannot be read. A name
can be unusable: a NUL byte, longer than the system allows, a loop of symlinks. Each of these
becomes a `FileProblem` with a sentence to show, never a traceback or a hang: the file is
opened without blocking, checked to be a regular file on the open descriptor (so a swap
between check and read changes nothing), and read to at most the limit plus one byte.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import stat
from typing import Optional
from pathlib import Path

# The files opened through this module while `recording_reads` is active (in this thread).
_reads: contextvars.ContextVar = contextvars.ContextVar("scenefmt_reads", default=None)
# The folders files may be read from while `reading_within` is active (real paths); None: anywhere.
_roots: contextvars.ContextVar = contextvars.ContextVar("scenefmt_roots", default=None)

ALLOW_HINT = "to read it, allow its folder with --allow-path DIR (allow_paths=[...] in Python)"


class FileProblem(Exception):
    """A file cannot be used; the message says why, in words."""


class LineProblem(Exception):
    """A file's content cannot be used; `line` is the 1-based line where one is known (a text
    format's readers: OBJ meshes, material libraries)."""

    def __init__(self, message: str, line: Optional[int] = None):
        super().__init__(message)
        self.message = message
        self.line = line

    def __str__(self) -> str:
        return f"line {self.line}: {self.message}" if self.line is not None else self.message


_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


def describe_os_error(exc: OSError) -> str:
    """An OSError in words, without the file name (the caller names the file)."""
    if exc.errno == errno.ENAMETOOLONG:
        return "the file name is longer than the system allows"
    if exc.errno == errno.ELOOP:
        return "the path runs through a loop of symbolic links (or too many of them)"
    return exc.strerror or str(exc)


def path_problem(path) -> str | None:
    """Why `path` cannot even be looked up (a NUL byte, an empty name), or None."""
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = text.decode("utf-8", "surrogateescape")
    if "\x00" in text:
        return "the file name contains a NUL byte"
    if text == "":
        return "the file name is empty"
    return None


def kind_of(mode: int) -> str | None:
    """'a directory', 'a FIFO (named pipe)', ... for anything but a regular file; None for one."""
    if stat.S_ISREG(mode):
        return None
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


@contextlib.contextmanager
def recording_reads():
    """Collect the absolute path of every file opened here while inside (a scene file, the files
    it includes, its textures and meshes; also those that could not be opened), and of every name
    a scene's files were looked up by (named_files.locate_named_file, found or not): what `rt
    watch` polls for changes and a cluster client sends its workers. Yields the list, filled as
    files are looked up and opened."""
    seen: list[str] = []
    token = _reads.set(seen)
    try:
        yield seen
    finally:
        _reads.reset(token)


def record_read(path) -> None:
    """Add `path` to the files `recording_reads` collects, if it is active: every file opened
    here is, and so is every name `named_files.locate_named_file` looks up, found or not (a
    missing one too: `rt watch` reloads when it is created)."""
    log = _reads.get()
    if log is not None:
        log.append(os.path.abspath(os.fsdecode(path)))


def real_folder(path) -> str:
    """The folder `path` names, symbolic links resolved: what `reading_within` compares against."""
    return os.path.realpath(os.fsdecode(path))


@contextlib.contextmanager
def reading_within(folders):
    """Refuse, while inside, to open any file that does not resolve (after symbolic links) inside
    one of `folders`: a scene downloaded from elsewhere may name `../../.ssh/id_rsa` or a link to
    it, and what it names must not be read, let alone quoted. Nested uses replace the folders."""
    roots = tuple(dict.fromkeys(real_folder(f) for f in folders))
    token = _roots.set(roots)
    try:
        yield roots
    finally:
        _roots.reset(token)


def outside_problem(path) -> str | None:
    """Why `path` may not be read under `reading_within` (it resolves outside every allowed
    folder), or None. Checked before a file is looked for, so nothing outside is even probed."""
    roots = _roots.get()
    if roots is None or path_problem(path):
        return None
    try:
        real = os.path.realpath(os.fsdecode(path))
    except (OSError, ValueError):
        return None  # the open that follows says what is wrong with the name
    for root in roots:
        if real == root or real.startswith(root.rstrip(os.sep) + os.sep):
            return None
    shown = " or ".join(roots) if len(roots) <= 3 else f"{roots[0]} or {len(roots) - 1} other allowed folders"
    through = f", through a symbolic link to {real}" if real != os.path.abspath(os.fsdecode(path)) else ""
    return f"outside the folders this scene may read files from ({shown}){through}; {ALLOW_HINT}"


def open_regular_file(path):
    """The regular file at `path` opened for binary reading (a file object); FileProblem otherwise."""
    fd = _open_regular(path)
    return os.fdopen(fd, "rb")


def _open_regular(path) -> int:
    problem = path_problem(path) or outside_problem(path)
    if problem:
        raise FileProblem(problem)
    record_read(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(Path(path), flags)
    except OSError as exc:
        raise FileProblem(f"cannot read the file: {describe_os_error(exc)}") from None
    try:
        kind = kind_of(os.fstat(fd).st_mode)
    except OSError as exc:
        os.close(fd)
        raise FileProblem(f"cannot read the file: {describe_os_error(exc)}") from None
    if kind is not None:
        os.close(fd)
        raise FileProblem(f"is {kind}, not a regular file")
    return fd


def read_regular_file(path, limit: int) -> bytes:
    """The bytes of the regular file at `path`, at most `limit` of them; FileProblem otherwise."""
    fd = _open_regular(path)
    try:
        info = os.fstat(fd)
        if info.st_size > limit:
            raise FileProblem(f"the file is larger than the {limit:,} bytes allowed ({info.st_size:,} bytes)")
        chunks = []
        size = 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:  # it grew while being read
            raise FileProblem(f"the file is larger than the {limit:,} bytes allowed")
        return b"".join(chunks)
    except OSError as exc:
        raise FileProblem(f"cannot read the file: {describe_os_error(exc)}") from None
    finally:
        os.close(fd)


def read_stream(stream, limit: int) -> bytes:
    """At most `limit` bytes from a binary stream (standard input); FileProblem if it holds more.

    A stream has no size to check first: it is read in chunks and refused as soon as it passes
    the limit, so `/dev/zero` or an endless pipe costs at most `limit` bytes of memory."""
    chunks = []
    size = 0
    try:
        while size <= limit:
            chunk = stream.read(min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise FileProblem(f"cannot read: {describe_os_error(exc)}") from None
    except ValueError:  # Python's "read of closed file": a caller closed the stream (sys.stdin.close())
        raise FileProblem("cannot read: the stream is closed") from None
    if size > limit:
        raise FileProblem(f"the input is larger than the {limit:,} bytes allowed")
    return b"".join(chunks)
