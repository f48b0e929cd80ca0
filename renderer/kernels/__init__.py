"""Numba kernels. They see only numpy arrays and scalars, never pydantic models."""
