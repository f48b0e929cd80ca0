"""The files a scene names (meshes, images), read once per load however they are named.

A scene may name one file many times: eight shapes of one mesh, or one texture as `a.png`,
`./a.png`, `sub/../a.png`, an absolute path and a symbolic link. `AssetCache` keys what was read
by the file's identity (device, inode, size and modification time, from `os.stat`), not by the
spelling, so each file is read and decoded once per load; a failure is kept too, so a broken
file is read once and reported at every place that names it. Which files a scene depends on
(`rt watch`, a cluster's package) is recorded where each name is looked up
(`named_files.locate_named_file`), so a file read once is still recorded for every name.
"""

from __future__ import annotations

import os
import re
from typing import Callable, Optional


def file_identity(path) -> Optional[tuple]:
    """(st_dev, st_ino, st_size, st_mtime_ns) of the file `path` names (through links), or None."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    return info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns


class AssetCache:
    """What was made from each file (by kind: "mesh", "image", ...), keyed by the file's identity."""

    def __init__(self):
        self._made: dict = {}
        self.reads = 0  # how many times `make` ran: what a test counts

    def get(self, kind: str, path, make: Callable[[], object]):
        """`make()`, or what it returned (or raised) for the same file before."""
        identity = file_identity(path)
        if identity is None:  # gone or unreadable: let `make` say why
            self.reads += 1
            return make()
        key = (kind, identity)
        if key not in self._made:
            self.reads += 1
            try:
                self._made[key] = (True, make())
            except MemoryError:
                raise  # not the file's fault: another try may succeed
            except Exception as exc:  # noqa: BLE001 - kept and raised again for every name of the file
                self._made[key] = (False, exc)
        ok, value = self._made[key]
        if not ok:
            raise value
        return value


_NUMPY_SIZE = re.compile(r"Unable to allocate ([0-9.]+ ?[KMGTP]?i?B)")


def memory_message(exc: MemoryError, what: str, needed: Optional[int] = None) -> str:
    """'not enough memory to <what> (about 3.5 GiB needed)', from our estimate when there is one,
    else from numpy's message (the size of the one array that failed)."""
    from .bounds import gib

    if needed:
        return f"not enough memory to {what} (about {gib(needed) if needed >= 1 << 20 else f'{needed:,} bytes'} needed)"
    m = _NUMPY_SIZE.search(str(exc))
    if m:
        return f"not enough memory to {what} ({m.group(1)} more needed for one array)"
    return f"not enough memory to {what}"
