"""The path tracer: flattens a scene graph into arrays and renders it with Numba kernels.

Importing the package imports nothing heavy. Every module with compiled code calls
`renderer.jit_cache.configure` before defining it, which chooses Numba's disk-cache folder.
"""
