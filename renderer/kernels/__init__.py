"""Numba kernels. They see only numpy arrays and scalars, never pydantic models."""

# Absolute, not relative: a specialised copy of the renderer (variants.py) shares the one
# configuration of the cache folder rather than making its own.
from renderer import jit_cache

# Numba reads its cache folder when a compiled function is defined: choose it before any
# kernel module (of this package or of a specialised copy, see variants.py) is imported.
jit_cache.configure()
