"""Numba kernels. They see only numpy arrays and scalars, never pydantic models; every compiled
function is declared through renderer/target.py."""
