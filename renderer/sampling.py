"""How a render draws its samples: the sampler, and adaptive sampling's stopping rule (numpy only).

The kernels take a `Sampling` with every render pass and tile (tracing/integrator.py, tile.py).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# The samplers (`image.sampler` in a scene file, `--sampler` on the command line), as the kernels take them.
SAMPLER_INDEPENDENT = 0  # a fresh hashed number for every (seed, pixel, sample, dimension): the books'
SAMPLER_SOBOL = 1  # Owen-scrambled Sobol points, one independent scramble per batch (numerics/sobol.py)
SAMPLERS = {"independent": SAMPLER_INDEPENDENT, "sobol": SAMPLER_SOBOL}


# No per-pixel guard (Sampling.guard): an empty array of the type a guard has, so kernels compile once.
NO_GUARD = np.zeros((0, 0))


class Sampling(NamedTuple):
    """What the kernels need to know about drawing samples."""

    sampler: int  # a value of SAMPLERS
    # adaptive (adaptive.pixel_converged): a pixel of n samples stops once the standard error of its
    # mean is at most threshold * sqrt(n) (radiance), i.e. once n reaches its spread / threshold; 0: never stops
    threshold: float = 0.0
    floor: int = 0  # adaptive: samples a pixel takes before it may stop (a multiple of config.BATCHES)
    tail: float = 1.0  # adaptive: a pixel whose largest sample holds more than this share of its squares goes on
    # adaptive: per pixel of the film (or tile) the kernel renders into, the least variance of one
    # sample its stopping rule assumes, set from its neighbours' spread in the pilot (adaptive_plan.py);
    # empty (0, 0): none
    guard: np.ndarray = NO_GUARD


def uniform_sampling(sampler: str = "independent") -> Sampling:
    """Every pixel takes every sample: no adaptive stopping."""
    return Sampling(SAMPLERS[sampler])
