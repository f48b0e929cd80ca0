"""The `rt` command line: validate, render and describe scene files."""

import os

# numpy's BLAS threads spin after a call; on a 2-core machine they would take a core from the
# renderer's own threads. The renderer does no heavy linear algebra, so one BLAS thread suffices.
# Set here, before any part of the program imports numpy.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
