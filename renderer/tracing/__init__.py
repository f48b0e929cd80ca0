"""The tracing layer, the roof of the kernels: closest hits through the trees (`traverse`), shadow
rays (`shadow`), the path tracer (`integrator`), a cluster's tiles (`tile`), the render passes'
albedo, normal and depth (`aux_passes`) and the rays that tests and tools probe with (`probe`). It calls the categories (shapes, materials, lights, media,
textures) through their interfaces; nothing below imports it."""
