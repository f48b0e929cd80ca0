"""rt: render declarative YAML/JSON scene files with a physically based path tracer.

From Python (see the README): `img = rt.render("scene.yaml", spp=64)`, then `img.array`,
`img.noise`, `img.save("out.exr")`; `rt.load` and `rt.validate` give the models and the
diagnostics. The command line is `rt` (`rt.cli`). Importing rt loads neither Numba nor the
renderer: they load with the first render.

Importing rt changes nothing in the process (no environment variable, no thread setting): the
command line and `rt.render` ask for one BLAS thread when they start (rendering.limit_blas_threads).
"""

from scenefmt.diagnostics import Diagnostic, SceneError

from .api import Image, Validation, load, render, validate

__all__ = ["render", "load", "validate", "Image", "Validation", "SceneError", "Diagnostic"]
