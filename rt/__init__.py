"""rt: render declarative YAML/JSON scene files with a physically based path tracer.

From Python (see the README): `img = rt.render("scene.yaml", spp=64)`, then `img.array`,
`img.noise`, `img.save("out.exr")`; `rt.load` and `rt.validate` give the models and the
diagnostics. The command line is `rt` (`rt.cli`). Importing rt loads neither Numba nor the
renderer: they load with the first render.
"""

import os

# numpy's BLAS threads spin after a call; on a 2-core machine they would take a core from the
# renderer's own threads. The renderer does no heavy linear algebra, so one BLAS thread suffices.
# Set here, before any part of the program imports numpy.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from scenefmt.diagnostics import Diagnostic, SceneError  # noqa: E402  (after the environment)

from .api import Image, Validation, load, render, validate  # noqa: E402

__all__ = ["render", "load", "validate", "Image", "Validation", "SceneError", "Diagnostic"]
