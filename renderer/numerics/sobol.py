"""Owen-scrambled Sobol points, in pairs of dimensions, keyed like the rest of the random numbers.

`sobol_uniform(scramble, index, dim)` is the `index`-th point of one batch of one pixel (whose
`scramble` key numerics/rng.py derives from the seed, the pixel and the batch), coordinate `dim`.
It follows Burley, "Practical Hash-based Owen Scrambling" (JCGT 2020), written here for 32-bit
integers held in uint64 and masked:

- Dimensions go in PAIRS (`pair_of`): the two coordinates of a pair are the first two
  dimensions of a Sobol sequence (van der Corput and the one of the polynomial x + 1), which
  together form a (0, 2)-sequence: every aligned block of 2^m consecutive points is a
  (0, m, 2)-net, one point in each of the 2^m elementary boxes of any shape. Higher Sobol
  dimensions are worse nets, so a path's dimensions are not one long Sobol point; each pair
  draws from its own (0, 2)-sequence instead ("padding").
- Each pair shuffles the point index with a nested uniform (Owen) scramble of its own seed.
  Owen scrambling the index as a binary fraction permutes the points so that an aligned block of
  2^m indices maps onto an aligned block of 2^m indices: the nets survive, while the pairs of a
  path no longer walk the same sequence in step (which would correlate them).
- Each coordinate is Owen scrambled with a seed of its own: randomised quasi-Monte Carlo. Every
  point is uniform on [0, 1)^2 and the nets keep their one point per box, so estimates are
  unbiased and each batch (its own scramble key) is an independent estimate of the pixel.

The nested uniform scramble of a 32-bit value is a permutation in which output bit j depends on
input bits j and above only. Burley builds it from a Laine-Karras style hash (whose bit j depends
on bits j and below: additions, odd multiplications and x ^= x * even carry information upward
only) applied between two bit reversals. The hash here is Nathan Vegdahl's strengthened variant
(2021) of Burley's, which mixes the seed into more bits.
"""

import numpy as np

from .. import target
from ..target import uint64

_MASK32 = np.uint64(0xFFFFFFFF)
_INV32 = 1.0 / 4294967296.0  # 2^-32: a 32-bit integer scaled into [0, 1), strictly below 1

# Where rng.py's light stream begins and the lens retries begin (its DIM_LIGHT and
# DIM_LENS_RETRY: copied, not imported, because rng.py calls into this module; a test checks
# that they agree).
LIGHT_FIRST = np.uint64(1) << np.uint64(60)
LIGHT_END = np.uint64(1) << np.uint64(61)

# MurmurHash3's 64-bit finaliser (Appleby): the seeds of a pair are hashed with a mixer other
# than rng.py's SplitMix64, so they share no structure with the scramble keys they start from.
_F1 = np.uint64(0xFF51AFD7ED558CCD)
_F2 = np.uint64(0xC4CEB9FE1A85EC53)
_PAIR_SALT = np.uint64(0x9E3779B97F4A7C15)
_ODD = np.uint64(0xD1B54A32D192ED03)

# The constants of Vegdahl's hash: the three x ^= x * c multipliers are even, so each step is a
# bijection of 32-bit integers.
_LK1 = np.uint64(0x3D20ADEA)
_LK2 = np.uint64(0x05526C56)
_LK3 = np.uint64(0x53A22864)

_M1 = np.uint64(0x55555555)
_M2 = np.uint64(0x33333333)
_M4 = np.uint64(0x0F0F0F0F)
_M8 = np.uint64(0x00FF00FF)
_M16 = np.uint64(0x0000FFFF)


@target.device
def fmix64(z):
    z = (z ^ (z >> uint64(33))) * _F1
    z = (z ^ (z >> uint64(33))) * _F2
    return z ^ (z >> uint64(33))


@target.device
def reverse_bits32(x):
    """The 32 low bits of x in reverse order (bit 0 to bit 31)."""
    x = ((x >> uint64(1)) & _M1) | ((x & _M1) << uint64(1))
    x = ((x >> uint64(2)) & _M2) | ((x & _M2) << uint64(2))
    x = ((x >> uint64(4)) & _M4) | ((x & _M4) << uint64(4))
    x = ((x >> uint64(8)) & _M8) | ((x & _M8) << uint64(8))
    return ((x >> uint64(16)) & _M16) | ((x & _M16) << uint64(16))


@target.device
def upward_hash32(x, seed):
    """A seeded bijection of 32-bit integers whose output bit j depends on input bits 0..j only
    (Vegdahl's Laine-Karras style hash): the Owen scramble of x's bits read from the lowest up."""
    x = (x ^ (x * _LK1)) & _MASK32
    x = (x + seed) & _MASK32
    x = (x * ((seed >> uint64(16)) | uint64(1))) & _MASK32
    x = (x ^ (x * _LK2)) & _MASK32
    return (x ^ (x * _LK3)) & _MASK32


@target.device
def owen_scramble32(x, seed):
    """Nested uniform scramble of x read as a 32-bit binary fraction: bit j of the result
    depends on bits j..31 of x, so values in an aligned block of 2^m stay in one aligned block."""
    return reverse_bits32(upward_hash32(reverse_bits32(x), seed))


@target.device
def superset_parity32(y):
    """Bit j of the result is the parity of the bits k of y whose positions k contain j's
    binary digits (k AND j == j): y multiplied by Pascal's matrix mod 2, since C(k, j) is odd
    exactly then (Lucas). One sweep per digit of the 5-bit positions, instead of a loop over
    the bits of y (whose branches, on a shuffled index, cost more than the rest of a point)."""
    y ^= (y >> uint64(1)) & _M1
    y ^= (y >> uint64(2)) & _M2
    y ^= (y >> uint64(4)) & _M4
    y ^= (y >> uint64(8)) & _M8
    return y ^ ((y >> uint64(16)) & _M16)


@target.device
def sobol_pair_coordinate(index, component):
    """Coordinate `component` (0 or 1) of point `index` of Sobol's first two dimensions, as a
    32-bit fraction: 0 is van der Corput's radical inverse; 1 has the direction numbers of the
    polynomial x + 1, v_k = sum over j of (C(k, j) mod 2) 2^-(j+1) (Pascal's triangle mod 2:
    v_0 = 1/2, v_k = v_{k-1} xor v_{k-1} / 2), so its digit j is `superset_parity32`'s bit j."""
    if component == 0:
        return reverse_bits32(index)
    return reverse_bits32(superset_parity32(index))


@target.device
def pair_of(dim):
    """(pair, component) of random dimension `dim`: the two dimensions a sampling routine uses
    together share a pair, whose points are a (0, 2)-sequence of their own.

    With rng.py's layout, consecutive even-odd dimensions are used together: the pixel's x and
    y (0, 1), the lens's (2, 3), the shutter time (4, with 5 unused), a bounce's (8 + 10b + 2i,
    8 + 10b + 2i + 1) (a sphere direction's two coordinates; a microfacet family's u0, u1 and
    u2 take dims 0..2, so its direction (u1, u2) straddles two pairs: stratified in each
    coordinate only), the lens retries' (2^61 + 2k, 2^61 + 2k + 1). The light stream of bounce b,
    2^60 + 4b + k, uses k = 1 and 2 together (the point on the light) and pairs the light choice
    (k = 0) with Russian roulette (k = 3). The pair's number is the dimension it starts from
    (for the light's point, that plus one), so no two pairs share a number; media dimensions are
    hashes, and whatever pair one falls in is as good as any.
    """
    d = uint64(dim)
    if LIGHT_FIRST <= d < LIGHT_END:
        k = d & uint64(3)
        base = d - k
        if k == uint64(1) or k == uint64(2):
            return base + uint64(1), k - uint64(1)
        return base, k >> uint64(1)
    return d & ~uint64(1), d & uint64(1)


@target.device_noinline
def sobol_uniform(scramble, index, dim):
    """A number in [0, 1) (never 1.0): coordinate `dim` of point `index` of the batch whose
    scramble key is `scramble`.

    For each pair of dimensions the index is shuffled and the coordinate scrambled with seeds
    hashed from (scramble, pair); an index past 2^32 starts a fresh scramble (its high bits join
    the hash), so points never repeat.
    """
    pair, component = pair_of(dim)
    i = uint64(index)
    h = fmix64(uint64(scramble) ^ fmix64(pair * _PAIR_SALT + (i >> uint64(32)) * _ODD))
    shuffled = owen_scramble32(i & _MASK32, h & _MASK32)
    coordinate_seed = fmix64(h + uint64(1) + component) & _MASK32
    # owen_scramble32(sobol_pair_coordinate(shuffled, component), coordinate_seed), without the
    # two bit reversals that cancel: the coordinate's digits, lowest first, are the shuffled
    # index itself (van der Corput) or its superset parities.
    digits = shuffled if component == uint64(0) else superset_parity32(shuffled)
    return float(reverse_bits32(upward_hash32(digits, coordinate_seed))) * _INV32
