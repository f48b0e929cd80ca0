"""The Owen-scrambled Sobol sampler (renderer/numerics/sobol.py): nets, uniformity, independence.

The points come from one small compiled wrapper (a few seconds to compile once); every check is
exact (the nets) or a test at the suite's significance with fixed scramble keys.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from renderer.numerics import rng
from renderer.numerics.sobol import LIGHT_END, LIGHT_FIRST, owen_scramble32, pair_of, sobol_pair_coordinate, sobol_uniform
from tests.renderer.stats import ALPHA, chi2_test, z_limit

# Pairs of dimensions a path uses together, one from each part of rng.py's layout: the pixel,
# the lens, bounce 0's first and last pair, bounce 3's first, the point on bounce 0's and
# bounce 2's light, the light choice with Russian roulette, a lens retry.
PAIRS = [(0, 1), (2, 3), (8, 9), (16, 17), (38, 39),
         (2**60 + 1, 2**60 + 2), (2**60 + 9, 2**60 + 10), (2**60 + 4, 2**60 + 7), (2**61 + 2, 2**61 + 3)]


@numba.njit
def _points(scrambles, start, count, dims):
    """(len(scrambles), count, len(dims)): points start .. start + count - 1 of each batch key."""
    out = np.empty((scrambles.size, count, dims.size))
    for k in range(scrambles.size):
        for i in range(count):
            for j in range(dims.size):
                out[k, i, j] = sobol_uniform(scrambles[k], np.uint64(start + i), dims[j])
    return out


def points(scrambles, start, count, dims):
    return _points(np.asarray(scrambles, dtype=np.uint64), start, count, np.asarray(dims, dtype=np.uint64))


def keys(n, salt=0):
    """n scramble keys as rng.py makes them: hashes, not small integers."""
    with np.errstate(over="ignore"):
        return np.array([rng.mix64.py_func(np.uint64(i + 1000 * salt)) for i in range(n)], dtype=np.uint64)


def is_net(xy: np.ndarray, m: int) -> bool:
    """Whether the 2^m points `xy` put exactly one point in every elementary box of volume 2^-m
    (every split of m into 2^a columns by 2^(m-a) rows)."""
    for a in range(m + 1):
        col = np.floor(xy[:, 0] * 2**a).astype(np.int64)
        row = np.floor(xy[:, 1] * 2 ** (m - a)).astype(np.int64)
        if np.unique(col * 2 ** (m - a) + row).size != 2**m:
            return False
    return True


def test_every_aligned_block_of_a_batch_is_a_net_in_each_pair():
    scrambles = keys(3)
    dims = [d for pair in PAIRS for d in pair]
    for m in range(9):
        for block in (0, 1, 7, 1000):
            pts = points(scrambles, block * 2**m, 2**m, dims)
            for k in range(len(scrambles)):
                for p in range(len(PAIRS)):
                    assert is_net(pts[k, :, 2 * p: 2 * p + 2], m), (m, block, k, PAIRS[p])


def test_a_block_that_is_not_aligned_is_not_always_a_net():
    # The check above can fail: 4 points straddling two aligned blocks miss a box for some key.
    pts = points(keys(8), 2, 4, [0, 1])
    assert not all(is_net(pts[k], 2) for k in range(8))


def test_values_lie_in_the_unit_interval_on_the_32_bit_grid_and_repeat_exactly():
    pts = points(keys(64), 0, 256, [0, 1, 4, 9, 2**60 + 3, 2**62 + 12345])
    assert pts.min() >= 0.0 and pts.max() < 1.0
    assert np.array_equal(pts * 2.0**32, np.floor(pts * 2.0**32))
    assert np.array_equal(pts, points(keys(64), 0, 256, [0, 1, 4, 9, 2**60 + 3, 2**62 + 12345]))
    # The largest 32-bit fraction stays below 1.0 in float64.
    assert float(np.uint64(0xFFFFFFFF)) * (1.0 / 2.0**32) < 1.0


def test_indices_past_two_to_the_32_take_a_fresh_scramble():
    a = points(keys(4), 5, 64, [0, 1])
    b = points(keys(4), 5 + 2**32, 64, [0, 1])
    assert not np.array_equal(a, b)
    assert is_net(points(keys(1), 2**32, 64, [2, 3])[0], 6)


@pytest.mark.parametrize("index", [0, 1, 6, 255])
@pytest.mark.parametrize("dim", [0, 1, 4, 9, 2**60 + 2, 2**61 + 17, 2**62 + 987654321])
def test_each_coordinate_is_uniform_over_scramble_keys(index, dim):
    values = points(keys(8192), index, 1, [dim])[:, 0, 0]
    counts = np.bincount(np.floor(values * 64).astype(np.int64), minlength=64)
    p, _ = chi2_test(counts, np.full(64, 1 / 64))
    assert p > ALPHA / 28, (index, dim, p)


@pytest.mark.parametrize("dims", [(0, 2), (1, 8), (8, 10), (9, 2**60 + 1), (2**60 + 0, 2**60 + 1), (4, 2**61)])
def test_dimensions_of_different_pairs_are_independent(dims):
    # At one index over many keys: the joint histogram is uniform.
    across = points(keys(8192, salt=1), 3, 1, dims)[:, 0, :]
    # Within one batch: a pair walking the same shuffled sequence in step as another would put its
    # points of a block on a few diagonal boxes of the joint histogram (8 of 64 boxes).
    within = points(keys(4, salt=2), 0, 1024, dims)
    for xy in [across] + [within[k] for k in range(4)]:
        cells = np.floor(xy[:, 0] * 8).astype(np.int64) * 8 + np.floor(xy[:, 1] * 8).astype(np.int64)
        p, _ = chi2_test(np.bincount(cells, minlength=64), np.full(64, 1 / 64))
        assert p > ALPHA / 30, (dims, p)


def test_different_batches_and_pixels_give_different_uncorrelated_points():
    # Neighbouring keys (the batches of a pixel, or neighbouring pixels): the same points would
    # make the batch means one estimate, not eight.
    a = points(keys(16, salt=3), 0, 1024, [0, 1, 8])
    b = points(keys(16, salt=4), 0, 1024, [0, 1, 8])
    assert not (a == b).all(axis=2).any()
    limit = z_limit(16 * 3)
    for k in range(16):
        for j in range(3):
            r = np.corrcoef(a[k, :, j], b[k, :, j])[0, 1]
            assert abs(r) * math.sqrt(1024) < limit, (k, j, r)


def test_owen_scramble_keeps_aligned_blocks_and_permutes_within_them():
    scramble = owen_scramble32.py_func
    for seed in (np.uint64(1), np.uint64(0xDEADBEEF), np.uint64(0x12345678)):
        for m, base in ((4, 0), (6, 0xABCDE), (8, 0x123)):
            block = [int(scramble(np.uint64(base * 2**m + j), seed)) for j in range(2**m)]
            assert len({v >> m for v in block}) == 1
            assert sorted(v & (2**m - 1) for v in block) == list(range(2**m))


def test_pairs_follow_rngs_layout():
    assert LIGHT_FIRST == rng.DIM_LIGHT and LIGHT_END == rng.DIM_LENS_RETRY
    pair = pair_of.py_func
    used_together = [(rng.DIM_PIXEL_X, rng.DIM_PIXEL_Y), (rng.DIM_LENS_X, rng.DIM_LENS_Y)]
    used_together += [(rng.bounce_dim.py_func(b, 2 * i), rng.bounce_dim.py_func(b, 2 * i + 1))
                      for b in range(4) for i in range(5)]
    used_together += [(rng.light_dim.py_func(b, 1), rng.light_dim.py_func(b, 2)) for b in range(4)]
    used_together += [(rng.DIM_LENS_RETRY + np.uint64(2 * k), rng.DIM_LENS_RETRY + np.uint64(2 * k + 1))
                      for k in range(9)]
    seen = {}
    for x, y in used_together:
        (px, cx), (py, cy) = pair(np.uint64(x)), pair(np.uint64(y))
        assert px == py and (cx, cy) == (0, 1), (x, y)
        assert px not in seen, (x, y, seen.get(px))
        seen[px] = (x, y)
    # Every dimension of the layout has a (pair, component) of its own.
    dims = [np.uint64(d) for d in range(8 + 10 * 6)] + [rng.light_dim.py_func(b, k) for b in range(6) for k in range(4)]
    dims += [rng.DIM_LENS_RETRY + np.uint64(k) for k in range(18)]
    assert len({tuple(int(v) for v in pair(d)) for d in dims}) == len(dims)


def test_the_second_coordinate_has_the_direction_numbers_of_x_plus_1():
    # Sobol's construction written out: XOR of v_k over the set bits k of the index, v_0 = 2^31
    # (one half) and v_k = v_{k-1} ^ (v_{k-1} >> 1).
    def by_directions(index):
        x, v = 0, 1 << 31
        while index:
            if index & 1:
                x ^= v
            index >>= 1
            v ^= v >> 1
        return x

    rng_ = np.random.default_rng(5)
    for index in list(range(64)) + [int(i) for i in rng_.integers(0, 2**32, 200)] + [2**32 - 1]:
        assert int(sobol_pair_coordinate.py_func(np.uint64(index), np.uint64(1))) == by_directions(index), index
        assert int(sobol_pair_coordinate.py_func(np.uint64(index), np.uint64(0))) == int(f"{index:032b}"[::-1], 2)


def test_the_points_are_fixed():
    # A change of these numbers changes every Sobol image and every saved Sobol render's meaning.
    index = [0, 1, 2, 3, 77, 1000, 2**31 + 5, 2**32 + 9]
    dims = [0, 1, 9, 2**60 + 2, 2**61 + 17]
    expected = [[3614591629, 2639918254, 2146151285, 3089140498, 128230689],
                [1008401002, 1493396438, 3756979499, 349434477, 2792095516],
                [3068157275, 282340225, 126946958, 1998114546, 1403477672],
                [1810216725, 4282916988, 2687194903, 3626581828, 3860979194],
                [952661383, 894511777, 3300945331, 2581835483, 2003651680],
                [1486932320, 1301049199, 240451621, 475348427, 2150564828],
                [2415668268, 839483725, 2040345185, 2543106664, 3326727032],
                [561929022, 3903480943, 2845756444, 1859262789, 3709246924]]
    got = [[round(points([0x0123456789ABCDEF], i, 1, [d])[0, 0, 0] * 2**32) for d in dims] for i in index]
    assert got == expected
