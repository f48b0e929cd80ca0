"""Numba kernels. They see only numpy arrays and scalars, never pydantic models."""

# Chooses Numba's cache folder before any kernel module (of this package or of a specialised
# copy, see variants.py) makes its compiled functions.
from .. import jit_cache  # noqa: F401
