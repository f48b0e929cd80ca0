"""Counter-based random numbers keyed by (seed, pixel, sample, dimension).

Every random number of a path is a pure function of where it is used, so an image does not
depend on thread scheduling or traversal order, and a render can be continued with more
samples exactly. The mixer is SplitMix64's finaliser (Steele, Lea and Flood 2014).

A path's key is a pair of uint64 `(hash, index)`. With the independent sampler `index` is
INDEPENDENT and every number is a hash of `hash` and the dimension. With the Sobol sampler
`hash` names the pixel's batch (`sample % BATCHES`: each batch is its own independently
scrambled sequence) and `index` is the point's place in it (`sample // BATCHES`).
"""

import numpy as np

from .. import target
from ..config import BATCHES
from ..sampling import SAMPLER_SOBOL
from ..target import uint64
from .sobol import sobol_uniform

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_INV53 = 1.0 / 9007199254740992.0  # 2^-53

# Dimensions: the camera uses 0..7; bounce b uses DIM_BOUNCE + b * DIMS_PER_BOUNCE + 0..9
# (a scattering direction takes up to 8, a dielectric's reflect-or-refract choice 1 more).
DIM_PIXEL_X = 0
DIM_PIXEL_Y = 1
DIM_LENS_X = 2
DIM_LENS_Y = 3
DIM_TIME = 4
# A lens sample is a point of the square kept when it falls in the disk: its later tries, and
# the rare fallback, draw from a stream of their own (dimensions 2^61 + k), so the camera's
# eight dimensions are enough.
DIM_LENS_RETRY = np.uint64(1) << np.uint64(61)
DIM_BOUNCE = 8
DIMS_PER_BOUNCE = 10
# Media draw their free-flight distance from a stream of their own, keyed by medium and bounce,
# so the value does not depend on the order the BVH visits them in.
DIM_MEDIUM = np.uint64(1) << np.uint64(62)
# Light sampling (the choice of light, a point on it) and Russian roulette draw from a stream of
# their own too, so the books' estimator keeps every number it had: bounce b uses
# DIM_LIGHT + b * DIMS_PER_LIGHT + 0..3.
DIM_LIGHT = np.uint64(1) << np.uint64(60)
DIMS_PER_LIGHT = 4
# A guided bounce (integrator guided, guiding.py) of bounce b draws from a stream of its own too, so
# `mis` renders bit for bit as before guiding existed: DIM_GUIDE + b * DIMS_PER_GUIDE + k, k = 0 the
# choice between the guide and the BSDF, k = 2 and 3 the guide's direction (one Sobol pair: rng's
# even-odd pairing; k = 1 unused).
DIM_GUIDE = np.uint64(1) << np.uint64(59)
DIMS_PER_GUIDE = 4


@target.device
def mix64(z):
    z = (z ^ (z >> uint64(30))) * _M1
    z = (z ^ (z >> uint64(27))) * _M2
    return z ^ (z >> uint64(31))


# The `index` of an independent sampler's key: no point of a sequence.
INDEPENDENT = np.uint64(0xFFFFFFFFFFFFFFFF)
# Mixed into a batch's hash so that a Sobol batch's scramble never equals an independent path's key.
_SOBOL_SALT = np.uint64(0x5851F42D4C957F2D)


@target.device_noinline
def path_hash(seed, pixel, sample):
    """A hash of the seed, the pixel index and the sample index."""
    k = mix64(uint64(seed) + _GOLDEN)
    k = mix64(k ^ (uint64(pixel) + _GOLDEN * uint64(2)))
    return mix64(k ^ (uint64(sample) + _GOLDEN * uint64(3)))


@target.device
def path_key(seed, pixel, sample):
    """The independent sampler's key of one path."""
    return (path_hash(seed, pixel, sample), INDEPENDENT)


@target.device
def independent_key(value):
    """An independent sampler's key from one number (probes and tests)."""
    return (uint64(value), INDEPENDENT)


@target.device
def sample_key(seed, pixel, sample, sampler):
    """The key of sample `sample` of pixel `pixel` for `sampler` (sampling.SAMPLERS)."""
    if sampler == SAMPLER_SOBOL:
        batch = uint64(sample) % uint64(BATCHES)
        return (mix64(path_hash(seed, pixel, batch) ^ _SOBOL_SALT), uint64(sample) // uint64(BATCHES))
    return path_key(seed, pixel, sample)


@target.device
def uniform(key, dim):
    """A number in [0, 1) for dimension `dim` of the path with `key`."""
    if key[1] == INDEPENDENT:
        return float(mix64(key[0] + uint64(dim) * _GOLDEN) >> uint64(11)) * _INV53
    return sobol_uniform(key[0], key[1], uint64(dim))


@target.device
def bounce_dim(bounce, k):
    return DIM_BOUNCE + bounce * DIMS_PER_BOUNCE + k


@target.device
def light_dim(bounce, k):
    """Dimension k of bounce `bounce`'s light-sampling stream (unsigned all through: mixed with a
    signed integer Numba would round it to a float, and 2^60 + k to 2^60)."""
    return DIM_LIGHT + uint64(bounce) * uint64(DIMS_PER_LIGHT) + uint64(k)


@target.device
def guide_dim(bounce, k):
    """Dimension k of bounce `bounce`'s guiding stream (unsigned all through, as light_dim)."""
    return DIM_GUIDE + uint64(bounce) * uint64(DIMS_PER_GUIDE) + uint64(k)
