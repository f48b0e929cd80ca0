"""Where Numba caches the renderer's compiled code.

Numba keys each cached function by its own source file only, so a kernel that inlines code
from another file would keep stale machine code after that file changes. The cache therefore
lives in a folder named after a hash of every source with compiled code (and the Numba
version): any change gives a fresh cache, and an installation in a read-only place still
caches. Set NUMBA_CACHE_DIR to choose the place yourself.

Numba reads its cache folder when a compiled function is declared: renderer/target.py, through
which every kernel is declared, sets it to `folder_for` its flags at that moment.

Within that folder Numba keeps each source file's code under the file's full path, and checks
the file's modification time and size: the same sources at another path (an editable install
after a regular one, a second virtual environment) or copied anew (a reinstall) compile again.
`installation_key` names exactly that, so the markers that say "compiled" (renderer/variants.py)
are this installation's, and a render says it is compiling whenever it is.
"""

from __future__ import annotations

import functools
import hashlib
import os
import tempfile
import threading
from pathlib import Path
from typing import Optional

import numba



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


@functools.lru_cache(maxsize=None)
def installation_key() -> str:
    """A name for this installation's compiled code as Numba's disk cache finds it: the sources'
    hash (`source_version`), the package's resolved folder, each source file's modification time
    and size, and the processor Numba compiles for. It changes whenever Numba would compile again
    rather than load from the cache, and not otherwise."""
    import llvmlite.binding

    here = Path(__file__).resolve().parent
    digest = hashlib.sha256(source_version().encode())
    digest.update(os.fsencode(here))
    for path in sorted(here.rglob("*.py")):
        info = path.stat()
        digest.update(f"\0{path.relative_to(here)}\0{info.st_mtime_ns}\0{info.st_size}".encode())
    cpu = numba.config.CPU_NAME or llvmlite.binding.get_host_cpu_name()
    features = numba.config.CPU_FEATURES or llvmlite.binding.get_host_cpu_features().flatten()
    digest.update(f"\0{cpu}\0{features}".encode())
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


@functools.lru_cache(maxsize=None)
def base_folder() -> Optional[str]:
    """The general kernel's cache folder (chosen once per process): NUMBA_CACHE_DIR if set, else
    the folder named by `source_version` in the user's cache; None where that is read-only (then
    Numba's own choice, beside the sources, is kept)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    folder = _cache_dir()
    return str(folder) if _writable(folder) else None


def folder_for(tag: str) -> Optional[str]:
    """The cache folder of the kernel whose flags are named `tag` (variants.KernelFeatures.tag):
    the base folder for the general kernel ('all'), a subfolder `variants/<tag>` for a
    specialised one. Numba keys cached code by source file and signature, not by the flags a
    module holds, so kernels of different flags must never share a folder: where the base folder
    is Numba's own choice (beside the sources, shared by all), the specialised kernels go to a
    private temporary folder instead."""
    base = base_folder()
    if tag == "all":
        return base
    if not base:
        user = os.getuid() if hasattr(os, "getuid") else "user"
        base = os.path.join(tempfile.gettempdir(), f"rt-numba-{user}")
    return os.path.join(base, "variants", tag)


# Held while a compiled function is declared (renderer/target.py sets Numba's cache folder for
# that moment), by the general package's target module and by every specialised copy's.
DECLARE_LOCK = threading.RLock()


def general_folder() -> str:
    """The folder the general kernel's compiled code is cached in (Numba's own choice where
    `base_folder` is None); nothing is changed: renderer/target.py applies it per declaration."""
    return base_folder() or numba.config.CACHE_DIR
