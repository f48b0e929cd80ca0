"""Loading the renderer's machine code from Numba's disk cache without the compiler's set-up.

Before Numba loads a function from its disk cache, it refreshes the target context: the
set-up a compilation needs, which imports and registers the typing and lowering of every
Python and numpy function Numba supports. That took about 0.1 s of every `rt render` on a
2-core machine, a fourteenth of a bouncing-spheres render, though code that is already compiled
needs none of it. It needs only Numba's runtime (NRT), whose functions the machine code calls:
loading without it crashes.

So for the renderer's own functions on the CPU, `load_overload` starts the runtime alone and
loads. Where nothing usable is cached, Numba compiles, and its compiler does the whole set-up
itself first (`CompilerBase.__init__` refreshes both contexts). Any other function, or another
target, goes through Numba's own method untouched.

This replaces a method of an internal Numba class, so it is done only for the Numba versions it
was tested with (`TESTED`: the parts involved are the same in every release from 0.59 to 0.68,
and the tests pass on 0.59.1 and 0.68.1); any other keeps Numba's behaviour and pays the set-up.
Machine code refers to symbols from three places: Numba's helpers (registered when the context
is made), the runtime (started here) and modules its environment imports when it is rebuilt
(the parallel thread pool, and `numba.cpython.hashing`'s hash secrets for code that hashes; a
review loaded such a function this way without trouble). `tests/renderer/test_cache_load.py`
renders with the general kernel loaded this way and compares with Numba's own loading.
"""

from __future__ import annotations

import numba

# (major, minor) versions of Numba whose cache loading this was checked against: the same
# `Cache.load_overload` (refresh, then `_load_overload` under `_guard_against_spurious_io_errors`),
# and a CPU context whose refresh starts the runtime with `rtsys.initialize`.
TESTED = ((0, 59), (0, 68))
# Modules whose compiled functions load this way: the renderer and its specialised kernel copies.
_OURS = ("renderer.",)


def _version() -> tuple[int, int]:
    major, minor = numba.__version__.split(".")[:2]
    return int(major), int(minor)


def supported() -> bool:
    """Whether this Numba's cache loading is one `install` was tested with."""
    try:
        version = _version()
    except ValueError:
        return False
    return TESTED[0] <= version <= TESTED[-1]


def _is_ours(cache) -> bool:
    module = getattr(getattr(cache, "_py_func", None), "__module__", None) or ""
    return module.startswith(_OURS)


def install() -> bool:
    """Make the renderer's cached functions load without the compiler's set-up (see the module
    docstring); whether it was done. Safe to call more than once."""
    if not supported():
        return False
    from numba.core import caching
    from numba.core.cpu import CPUContext
    from numba.core.runtime import rtsys

    numba_load = caching.Cache.load_overload
    if getattr(numba_load, "_rt_light", False):
        return True

    def load_overload(self, sig, target_context):
        if not (isinstance(target_context, CPUContext) and _is_ours(self)):
            return numba_load(self, sig, target_context)
        # The one part of target_context.refresh() that loaded machine code relies on.
        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)
        return None  # the guard swallowed an I/O error: nothing loaded, as in Numba's own method

    load_overload._rt_light = True
    load_overload.__doc__ = numba_load.__doc__
    caching.Cache.load_overload = load_overload
    return True
