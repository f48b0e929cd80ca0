"""The path tracer: flattens a scene graph into arrays and renders it with Numba kernels."""
