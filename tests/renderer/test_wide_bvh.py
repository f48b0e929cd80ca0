"""The four-wide BVH: widening keeps the binary tree's leaves and boxes, and the vector slab test
answers exactly as the scalar one does, box by box."""

import math

import numpy as np
import pytest
from renderer import target

from renderer.bvh import SLOT_EMPTY, SLOT_INTERIOR, WIDTH, build_bvh, single_leaf, widen
from renderer.config import BVH_STACK, BVH_WIDE_STACK
from renderer.numerics.simd import slab4
from renderer.tracing.traverse import inverse_direction, slab

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow


def random_boxes(rng, n, spread=50.0):
    lo = rng.uniform(-spread, spread, (n, 3))
    return lo, lo + rng.uniform(0.0, 3.0, (n, 3))


def binary_leaves(tree):
    return {(int(tree.a[k]), int(tree.n[k])) for k in range(len(tree.n)) if tree.n[k] > 0}


def wide_walk(wide):
    """Leaves, interior slots, and depth of a wide tree, found from the root."""
    leaves, interior, depth = set(), 0, 0
    todo = [(0, 1)]
    seen = set()
    while todo:
        node, level = todo.pop()
        assert node not in seen, "a wide node reached twice"
        seen.add(node)
        depth = max(depth, level)
        for c in range(WIDTH):
            code, count = int(wide.child[node, c]), int(wide.child[node, WIDTH + c])
            if count > 0:
                leaves.add((code, count))
            elif count == SLOT_INTERIOR:
                interior += 1
                todo.append((code, level + 1))
            else:
                assert count == SLOT_EMPTY and np.isnan(wide.box[node, c::WIDTH]).all()
    assert seen == set(range(len(wide.child))), "every wide node is reachable exactly once"
    return leaves, interior, depth


def binary_depth(tree, node=0):
    if tree.n[node] > 0:
        return 1
    return 1 + max(binary_depth(tree, node + 1), binary_depth(tree, int(tree.a[node])))


@pytest.mark.parametrize("n", [1, 2, 3, 5, 17, 400, 3000])
def test_widening_keeps_the_leaves_and_their_boxes(n):
    rng = np.random.default_rng(n)
    lo, hi = random_boxes(rng, n)
    tree = build_bvh(lo, hi)
    wide = widen(tree)
    leaves, interior, depth = wide_walk(wide)
    assert leaves == binary_leaves(tree)
    assert interior == len(wide.child) - 1
    # Half as many levels, or close: what the wide traversal saves. No deeper in any case, so
    # the traversal stack (three entries a level) stays within its bound.
    assert depth <= binary_depth(tree)
    if n >= 400:
        assert depth <= 0.6 * binary_depth(tree) + 1
    assert 3 * depth + 1 <= BVH_WIDE_STACK and binary_depth(tree) <= BVH_STACK
    # Each child's box is the binary node's box it stands for: the union of its primitives'.
    order = tree.order
    for node in range(len(wide.child)):
        for c in range(WIDTH):
            code, count = int(wide.child[node, c]), int(wide.child[node, WIDTH + c])
            if count > 0:
                prims = order[code:code + count]
                box = wide.box[node, c::WIDTH]
                assert np.all(box[:3] <= lo[prims].min(axis=0)) and np.all(box[3:] >= hi[prims].max(axis=0))


def test_a_single_leaf_and_an_empty_tree_widen_to_one_node():
    lo, hi = random_boxes(np.random.default_rng(2), 50)
    wide = widen(single_leaf(lo, hi))
    assert wide.child.shape == (1, 2 * WIDTH)
    assert wide.child[0, 0] == 0 and wide.child[0, WIDTH] == 50
    assert list(wide.child[0, WIDTH + 1:]) == [SLOT_EMPTY] * 3
    empty = widen(build_bvh(np.zeros((0, 3)), np.zeros((0, 3))))
    assert list(empty.child[0, WIDTH:]) == [SLOT_EMPTY] * 4 and np.isnan(empty.box).all()


@target.kernel
def _both(box_rows, o_all, d_all, tmin, tmax):
    """For each ray and each wide node: the vector answer and the scalar answer for its four boxes."""
    n_rays, n_nodes = o_all.shape[0], box_rows.shape[0]
    vec = np.empty((n_rays, n_nodes, 4))
    sca = np.empty((n_rays, n_nodes, 4))
    lohi = np.empty((4, 6))
    for r in range(n_rays):
        o = (o_all[r, 0], o_all[r, 1], o_all[r, 2])
        inv = inverse_direction((d_all[r, 0], d_all[r, 1], d_all[r, 2]))
        for k in range(n_nodes):
            t0, t1, t2, t3 = slab4(box_rows, k, o, inv, tmin[r], tmax[r])
            vec[r, k, 0], vec[r, k, 1], vec[r, k, 2], vec[r, k, 3] = t0, t1, t2, t3
            for c in range(4):
                for q in range(6):
                    lohi[c, q] = box_rows[k, q * 4 + c]
            for c in range(4):
                sca[r, k, c] = slab(lohi, c, o, inv, tmin[r], tmax[r])
    return vec, sca


def test_the_vector_slab_test_equals_the_scalar_one_bit_for_bit():
    rng = np.random.default_rng(7)
    lo, hi = random_boxes(rng, 300, spread=5.0)
    # Flat boxes and boxes sharing faces: the edge cases of the slab test.
    hi[:40, 0] = lo[:40, 0]
    lo[40:80, 1] = 1.0
    wide = widen(build_bvh(lo, hi))
    box = np.ascontiguousarray(wide.box)
    n = 600
    o = rng.uniform(-8.0, 8.0, (n, 3))
    d = rng.normal(size=(n, 3))
    # Axis-parallel directions, signed zeros, and origins on box planes.
    d[:100, rng.integers(0, 3, 100)] = 0.0
    d[100:150, 1] = -0.0
    o[150:200, 1] = 1.0
    tmin = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.0, 3.0, n))
    tmax = np.where(rng.random(n) < 0.5, math.inf, rng.uniform(3.0, 9.0, n))
    vec, sca = _both(box, o, d, tmin, tmax)
    assert np.array_equal(vec.view(np.int64), sca.view(np.int64)), "same bits, signed zeros included"
    hits = np.isfinite(vec)
    # Thousands of boxes are met (most are not: they are small), and empty (nan) slots never.
    assert 1000 < hits.sum() < 0.5 * hits.size
    empty = np.isnan(box[:, :WIDTH])
    assert not hits[:, empty].any()
