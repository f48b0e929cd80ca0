"""The compile target of the renderer's kernels: every compiled function is declared here.

Kernel code never names its compiler. It declares its functions with the decorators below and
runs its parallel loops with `prange`; the render calls a kernel through `launch`. This module
is the CPU target, through Numba:

- `device`: a function called from kernels only, inlined into its caller (vectors, shape
  tests, materials: small, and on the hot path, where a call would cost more than the work);
- `device_noinline`: a device function compiled once and called, for a larger body used in a
  few places (a sphere's (u, v), the key of a path);
- `kernel`: a serial kernel, callable from Python; it releases the GIL, so that several can run
  at once on threads of one process (the tiles of a cluster's worker);
- `parallel_kernel`: a kernel whose `prange` loop runs on `thread_count()` threads; per-thread
  scratch is allocated before the loop and picked by `thread_index()` inside it, so the loop
  body allocates nothing;
- `launch(kernel, *args)`: runs a kernel: here a plain call.

The options every declaration shares are set here once: Numba's disk cache on (in this
target's folder, `CACHE_FOLDER`), numpy's error model (a division by zero gives inf or nan, as
the kernels' robust geometry expects, instead of raising), LLVM inlining and no reference
counting for device functions (see `device` below).

A CUDA target would be a module with the same names: `device` as `numba.cuda.jit(device=True,
inline=True)`, `kernel` and `parallel_kernel` as `numba.cuda.jit` kernels whose `prange` loop
becomes one thread per iteration (`cuda.grid(1)` and a bounds check), `thread_index` that grid
index, and `launch` computing the grid from the loop's length (`kernel[blocks, threads](*args)`)
and moving the flat scene's arrays to the device once per scene. The kernels' code is the same
for both; a second target is added by swapping this module, not by editing the kernels.

Specialised kernels (variants.py) import the renderer package again with other flags: each such
copy holds its own copy of this module, whose `CACHE_FOLDER` is the one of its flags. Numba
offers no public per-function cache folder: it reads `numba.config.CACHE_DIR` when a function is
declared. So each declaration sets it for that moment (`declaring`), under one lock for the
process, and puts it back: the only place the renderer changes Numba's configuration.
"""

from __future__ import annotations

from contextlib import contextmanager

import numba

# Absolute, not relative: the specialised copies of the package share this module (one lock,
# one choice of the base folder per process).
from renderer import jit_cache

from . import kernel_flags

# Where this target's compiled code is cached: the general kernel's folder, or the subfolder of
# the flags of the specialised copy this module belongs to (None: Numba's own choice).
CACHE_FOLDER = jit_cache.folder_for(kernel_flags.TAG)

_DECLARE_LOCK = jit_cache.DECLARE_LOCK
_SHARED = {"cache": True, "error_model": "numpy"}


@contextmanager
def declaring():
    """Numba's cache folder set to this target's while functions are declared (see the module's
    docstring); a declaration on another thread waits."""
    with _DECLARE_LOCK:
        if CACHE_FOLDER is None:
            yield
            return
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = CACHE_FOLDER
        try:
            yield
        finally:
            numba.config.CACHE_DIR = saved


def _declarer(**options):
    def declare(function):
        with declaring():
            return numba.njit(**_SHARED, **options)(function)

    return declare


# Device functions are compiled without reference counting (`_nrt=False`): they never allocate,
# and with it on Numba wraps every array argument of every device call in a call to its atomic
# incref/decref, which its refcount pruner cannot remove here (the general kernel's machine code
# went from about 400 calls to 2,700). Measured on 2 cores (issue 30): without `_nrt=False` the
# Cornell box renders at 0.17x (general kernel) and 0.32x (specialised) of the speed with it,
# the final scene at 0.26x (general), and one thread is as slow (0.17x). The public settings do
# not help: the pruner already runs with every pattern on by default (NUMBA_LLVM_REFPRUNE_FLAGS
# "all"), NUMBA_OPT=max still gives 0.15x, and Numba-IR inlining (`inline="always"`) instead of
# LLVM's ran past 3.5 minutes and 12 GB compiling the general kernel (57 s before) and was stopped.
# So this is the one private Numba option the renderer uses, written here only.
device = _declarer(forceinline=True, _nrt=False)
device_noinline = _declarer(_nrt=False)
kernel = _declarer(nogil=True)
parallel_kernel = _declarer(parallel=True)

prange = numba.prange
# The unsigned integer type of the counter-based random numbers (numerics/rng.py).
uint64 = numba.uint64


# Threads a parallel kernel runs on: callable from Python and inside a kernel, before its loop.
thread_count = numba.get_num_threads
set_thread_count = numba.set_num_threads


def max_thread_count() -> int:
    """The most threads a parallel kernel can run on in this process (NUMBA_NUM_THREADS)."""
    return numba.config.NUMBA_NUM_THREADS
# Inside a parallel loop: the running thread's number, 0 .. thread_count() - 1.
thread_index = numba.get_thread_id


def launch(kernel_function, *args):
    """Run a kernel declared with `kernel` or `parallel_kernel`: on the CPU, a call."""
    return kernel_function(*args)


