"""The path tracer: flattens a scene graph into arrays and renders it with Numba kernels.

Importing the package imports nothing heavy: `renderer.compile` (a scene graph into tables)
runs without Numba, so `rt render` can flatten a scene in a child process while this one
imports Numba (see rt/split.py). Every module with compiled code imports
`renderer.jit_cache` first, which chooses Numba's disk-cache folder.
"""
