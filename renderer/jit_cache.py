"""Where Numba caches the renderer's compiled code.

Numba keys each cached function by its own source file only, so a kernel that inlines code
from another file would keep stale machine code after that file changes. The cache therefore
lives in a folder named after a hash of every source with compiled code (and the Numba
version): any change gives a fresh cache, and an installation in a read-only place still
caches. Set NUMBA_CACHE_DIR to choose the place yourself.

Numba reads its cache folder when a compiled function is defined, so `configure` must run
before any module with compiled code is imported: each such module calls it at its top.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

_configured = False


def source_version() -> str:
    """A name for the renderer's compiled code: a hash of Numba's version and of every source
    file of the renderer package (code, or constants compiled into it). It names the cache folder,
    and a cluster's workers compare it with the client's."""
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256(numba.__version__.encode())
    for path in sorted(here.rglob("*.py")):
        digest.update(str(path.relative_to(here)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rt" / "numba"
    return base / source_version()


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-test"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


def configure() -> str:
    """Choose Numba's cache folder for the renderer (once per process) and return it.

    NUMBA_CACHE_DIR wins; where the home folder is read-only, Numba's own choice is kept.
    """
    global _configured
    if not _configured and not os.environ.get("NUMBA_CACHE_DIR"):
        folder = _cache_dir()
        if _writable(folder):
            numba.config.CACHE_DIR = str(folder)
    _configured = True
    return numba.config.CACHE_DIR
