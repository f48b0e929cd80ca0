"""The path tracer: flattens a scene graph into arrays and renders it with Numba kernels.

Importing the package imports nothing heavy. Every compiled function is declared through
`renderer.target`, which also chooses Numba's disk-cache folder for it (`renderer.jit_cache`).
"""
