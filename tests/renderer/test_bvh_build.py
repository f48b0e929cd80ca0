"""The tree build grows subtrees on every thread: the tree must be the one a single thread grows."""

import numba
import numpy as np
import pytest

from renderer import bvh
from scenefmt import meshgen

# Compiles the tree build's Numba kernels (tests/conftest.py).
pytestmark = pytest.mark.slow


def boxes_of(kind: str, n: int):
    rng = np.random.default_rng(n)
    if kind == "spheres":
        c = rng.uniform(-1, 1, (n, 3))
        r = rng.uniform(1e-3, 0.1, (n, 1))
        return c - r, c + r
    if kind == "coincident":  # no plane separates them: halved by index
        return np.full((n, 3), -1.0), np.full((n, 3), 1.0)
    v, f = meshgen.icosphere(int(np.sqrt(n / 20)) + 1)
    p = v[f]
    return p.min(1), p.max(1)


def tree(lo, hi, cost, tasks):
    return bvh._build(lo, hi, bvh.BVH_BINS, bvh.BVH_MAX_LEAF, cost, tasks)


@pytest.mark.parametrize("kind,n", [("spheres", 1), ("spheres", 3), ("spheres", 50), ("spheres", 20000),
                                    ("coincident", 700), ("mesh", 30000)])
def test_the_tree_grown_on_many_threads_is_the_tree_one_thread_grows(kind, n):
    lo, hi = boxes_of(kind, n)
    n = len(lo)
    threads = numba.get_num_threads()
    try:
        for cost in (bvh.TRAVERSAL_COST, bvh.MESH_TRAVERSAL_COST):
            numba.set_num_threads(1)
            one = tree(lo, hi, cost, 1 << 62)  # no range is small enough to be a task: all grown in order
            numba.set_num_threads(threads)
            for tasks in (1, 2, bvh.BUILD_TASKS, 1000):
                many = tree(lo, hi, cost, tasks)
                for a, b in zip(one, many):
                    assert a.dtype == b.dtype and np.array_equal(a, b)
    finally:
        numba.set_num_threads(threads)
    # A sound tree: every slot in exactly one leaf, each box inside its leaf's box.
    node_lo, node_hi, a, count, _, order = one
    leaves = np.flatnonzero(count > 0)
    slots = np.concatenate([np.arange(a[i], a[i] + count[i]) for i in leaves])
    assert np.array_equal(np.sort(slots), np.arange(n))
    assert np.array_equal(np.sort(order), np.arange(n))
    for i in leaves[:200]:
        inside = order[a[i]:a[i] + count[i]]
        assert (lo[inside] >= node_lo[i]).all() and (hi[inside] <= node_hi[i]).all()
