"""Where Numba caches the compiled code: imported by every module with compiled code, before it.

Compiled kernels are cached on disk. Numba keys each cached function by its own source file
only, so a kernel that inlines code from another file would keep stale machine code after
that file changes. The cache therefore lives in a folder named after a hash of every source
with compiled code (and the Numba version): any change gives a fresh cache, and an installation in a
read-only place still caches. Set NUMBA_CACHE_DIR to choose the place yourself.

Importing this also has cached code load without the compiler's set-up (cache_load.py).
"""


import hashlib
import os
from pathlib import Path

import numba

from . import cache_load


def _cache_dir() -> Path:
    here = Path(__file__).resolve().parent
    # Every file with compiled code, or constants compiled into it.
    sources = sorted((here / "kernels").glob("*.py")) + [here / name for name in ("bvh.py", "layout.py", "config.py")]
    digest = hashlib.sha256(numba.__version__.encode())
    for path in sources:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rt" / "numba"
    return base / digest.hexdigest()[:16]


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-test"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


if not os.environ.get("NUMBA_CACHE_DIR"):
    _dir = _cache_dir()
    # Where the home folder is read-only, Numba's own choice of cache folder is kept.
    if _writable(_dir):
        numba.config.CACHE_DIR = str(_dir)

# Cached functions load without the compiler's set-up, for the Numba versions that was checked on.
cache_load.install()
