"""Owen-scrambled Sobol points for the Sobol sampler (rng.sample_key): a placeholder until written."""

import numpy as np

from .. import target
from ..target import uint64

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


@target.device
def _mix(z):
    z = (z ^ (z >> uint64(30))) * _M1
    z = (z ^ (z >> uint64(27))) * _M2
    return z ^ (z >> uint64(31))


@target.device_noinline
def sobol_uniform(scramble, index, dim):
    """A number in [0, 1) for dimension `dim` of point `index` of the sequence scrambled by `scramble`."""
    return float(_mix(scramble ^ _mix(index + dim * _GOLDEN)) >> uint64(11)) * (1.0 / 9007199254740992.0)
