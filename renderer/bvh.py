"""Bounding volume hierarchy: binned SAH build, flattened depth-first.

The tree is built over primitive bounds and stored as arrays: node i's first child is node
i + 1, its second child is `node_a[i]`; a leaf has `node_n[i] > 0` primitives starting at
`node_a[i]` in the permutation `order`. The build runs in Numba: the top of the tree on one
thread, the subtrees below it on every thread, each split decided as one thread decides it, so
the tree does not depend on the number of threads.

The bottom-level trees are then widened to four children per node (`widen`): a traversal
step tests four boxes with one vector computation and the tree has about half as many levels,
which made whole renders 1.3 times as fast (docs/speed.md).
"""

from typing import NamedTuple

import numpy as np

from . import target
from .config import BVH_BINS, BVH_MAX_LEAF

# A flat box is padded to this thickness (relative to the scene's scale) so slab tests stay robust.
PAD_RELATIVE = 1e-9
# SAH cost of visiting a node, in units of one primitive test. The wide traversal tests a node's
# four boxes in one vector step, so a box costs far less than a primitive: splitting down to
# smaller leaves made the Cornell box (18 large quads) 1.28 times as fast, other scenes the same.
TRAVERSAL_COST = 0.3
# For mesh triangles, leaves of a few triangles: a triangle test is cheap next to a wide node
# (256 bytes), and at 0.3 a 10^6-triangle tree took 120 bytes a triangle; at 1.0 it takes about
# 60, within the 150 bytes a triangle with the triangle tables.
MESH_TRAVERSAL_COST = 1.0
# Below this depth splits halve the range by index, so no tree is deeper than about
# SAH_DEPTH_LIMIT + log2(n) and the traversal stack (config.BVH_STACK) cannot overflow.
SAH_DEPTH_LIMIT = 32
# Subtrees the build grows in parallel: enough that threads finish together although SAH splits
# are uneven, few enough that the part grown on one thread above them stays small.
BUILD_TASKS = 32


class Bvh(NamedTuple):
    lo: np.ndarray  # (m, 3) float64
    hi: np.ndarray  # (m, 3) float64
    a: np.ndarray  # (m,) int32: leaf -> first primitive slot; interior -> second child
    n: np.ndarray  # (m,) int32: leaf -> primitive count; interior -> 0
    axis: np.ndarray  # (m,) int32: split axis of an interior node
    order: np.ndarray  # (k,) int32: primitive index of each leaf slot


@target.kernel
def _sah_split(lo, hi, cen, start, end, bins):
    """(axis, position, cost) of the best binned-SAH split of the boxes in rows start:end; axis
    -1 if none. `cen` holds the boxes' centres, 0.5 (lo + hi). The rows are the build's copies,
    kept in slot order, so every pass reads memory in sequence."""
    cmin = np.full(3, np.inf)
    cmax = np.full(3, -np.inf)
    for j in range(start, end):
        for ax in range(3):
            c = cen[j, ax]
            cmin[ax] = min(cmin[ax], c)
            cmax[ax] = max(cmax[ax], c)
    best_axis, best_pos, best_cost = -1, 0.0, np.inf
    count = np.zeros(bins, np.int64)
    blo = np.empty((bins, 3))
    bhi = np.empty((bins, 3))
    for ax in range(3):
        extent = cmax[ax] - cmin[ax]
        if not extent > 0.0:
            continue
        count[:] = 0
        blo[:, :] = np.inf
        bhi[:, :] = -np.inf
        inv = bins / extent
        for j in range(start, end):
            c = cen[j, ax]
            b = min(bins - 1, int((c - cmin[ax]) * inv))
            count[b] += 1
            for q in range(3):
                blo[b, q] = min(blo[b, q], lo[j, q])
                bhi[b, q] = max(bhi[b, q], hi[j, q])
        # Sweep from the right to get each suffix's area and count, then from the left.
        right_area = np.zeros(bins)
        right_count = np.zeros(bins, np.int64)
        rlo = np.full(3, np.inf)
        rhi = np.full(3, -np.inf)
        rc = 0
        for b in range(bins - 1, 0, -1):
            rc += count[b]
            for q in range(3):
                rlo[q] = min(rlo[q], blo[b, q])
                rhi[q] = max(rhi[q], bhi[b, q])
            right_count[b] = rc
            right_area[b] = _area(rlo, rhi) if rc > 0 else 0.0
        llo = np.full(3, np.inf)
        lhi = np.full(3, -np.inf)
        lc = 0
        for b in range(0, bins - 1):
            lc += count[b]
            for q in range(3):
                llo[q] = min(llo[q], blo[b, q])
                lhi[q] = max(lhi[q], bhi[b, q])
            if lc == 0 or right_count[b + 1] == 0:
                continue
            cost = lc * _area(llo, lhi) + right_count[b + 1] * right_area[b + 1]
            if cost < best_cost:
                best_axis, best_pos, best_cost = ax, cmin[ax] + (b + 1) / inv, cost
    return best_axis, best_pos, best_cost


@target.device
def _area(lo, hi):
    dx, dy, dz = hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]
    return dx * dy + dy * dz + dz * dx


@target.kernel
def _grow(lo, hi, cen, idx, start, end, depth, bins, max_leaf, traversal_cost, cutoff,
          node_lo, node_hi, node_a, node_n, node_axis, base, tasks):
    """Build the tree over slots start:end (at `depth`) into the node arrays from row `base`, in
    preorder: a node's first child is the next row, its second child's row is `node_a`. The
    slots' boxes, centres and `idx` are permuted in place. A range of at most `cutoff` boxes below
    the root is not built but left as a task: its node gets count -1 - k and row k of `tasks`
    (start, end, depth). Returns the number of nodes written and of tasks left."""
    # Work stack: (start, end, parent whose second child this is or -1, depth).
    stack = np.empty((128, 4), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2], stack[0, 3] = start, end, -1, depth
    sp = 1
    count = 0
    n_tasks = 0
    while sp > 0:
        sp -= 1
        start, end, parent, depth = stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3]
        node = base + count
        count += 1
        if parent >= 0:
            node_a[parent] = node
        size = end - start
        if count > 1 and size <= cutoff:
            tasks[n_tasks, 0], tasks[n_tasks, 1], tasks[n_tasks, 2] = start, end, depth
            node_n[node] = -1 - n_tasks
            n_tasks += 1
            continue
        for q in range(3):
            node_lo[node, q] = np.inf
            node_hi[node, q] = -np.inf
        for j in range(start, end):
            for q in range(3):
                node_lo[node, q] = min(node_lo[node, q], lo[j, q])
                node_hi[node, q] = max(node_hi[node, q], hi[j, q])
        axis, pos, cost = -1, 0.0, np.inf
        if size > 1 and depth < SAH_DEPTH_LIMIT:
            axis, pos, cost = _sah_split(lo, hi, cen, start, end, bins)
        # SAH in units of one primitive test (see TRAVERSAL_COST).
        node_area = _area(node_lo[node], node_hi[node])
        leaf_cost = size * node_area
        if size <= max_leaf and not cost + traversal_cost * node_area < leaf_cost:
            axis = -1
        mid = start
        if axis >= 0:
            # Partition by centroid against the chosen plane.
            i, j = start, end - 1
            while i <= j:
                c = cen[i, axis]
                if c < pos:
                    i += 1
                else:
                    idx[i], idx[j] = idx[j], idx[i]
                    for q in range(3):
                        lo[i, q], lo[j, q] = lo[j, q], lo[i, q]
                        hi[i, q], hi[j, q] = hi[j, q], hi[i, q]
                        cen[i, q], cen[j, q] = cen[j, q], cen[i, q]
                    j -= 1
            mid = i
            if mid == start or mid == end:
                axis = -1
        if axis < 0 and size > max_leaf:
            # No useful plane (coincident centroids): split the range in half by index.
            axis = 0
            mid = start + size // 2
        if axis < 0:
            node_a[node] = start
            node_n[node] = size
            continue
        node_axis[node] = axis
        node_n[node] = 0
        if sp + 2 > stack.shape[0]:
            bigger = np.empty((stack.shape[0] * 2, 4), np.int64)
            bigger[:sp] = stack[:sp]
            stack = bigger
        # Right first so the left child is popped next and lands at node + 1.
        stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3] = mid, end, node, depth + 1
        sp += 1
        stack[sp, 0], stack[sp, 1], stack[sp, 2], stack[sp, 3] = start, mid, -1, depth + 1
        sp += 1
    return count, n_tasks


@target.parallel_kernel
def _build(lo, hi, bins, max_leaf, traversal_cost, tasks_wanted):
    """The tree over boxes lo, hi, in preorder, and the permutation of the boxes in its leaves.

    The top of the tree is grown on one thread until about `tasks_wanted` ranges are left; those
    subtrees grow on every thread, each into its own rows, and are then stitched in where their
    placeholders are. Every split is decided as when one thread grows it all, so the tree is the
    same, row for row, whatever the number of threads."""
    n = lo.shape[0]
    # Copies of the boxes and their centres, permuted with idx: row k is the box in slot k.
    lo = lo.copy()
    hi = hi.copy()
    cen = 0.5 * (lo + hi)
    idx = np.arange(n).astype(np.int32)
    cutoff = n // tasks_wanted
    # Room for a whole tree (a range of k boxes makes at most 2k - 1 nodes): the pages of rows
    # never written are never touched.
    top_cap = max(1, 2 * n)
    top_lo = np.empty((top_cap, 3))
    top_hi = np.empty((top_cap, 3))
    top_a = np.zeros(top_cap, np.int32)
    top_n = np.zeros(top_cap, np.int32)
    top_axis = np.zeros(top_cap, np.int32)
    tasks = np.empty((top_cap, 3), np.int64)
    top_count, n_tasks = _grow(lo, hi, cen, idx, 0, n, 0, bins, max_leaf, traversal_cost, cutoff,
                               top_lo, top_hi, top_a, top_n, top_axis, 0, tasks)
    # Each task's rows: a range of k boxes makes at most 2k - 1 nodes.
    first = np.zeros(n_tasks + 1, np.int64)
    for t in range(n_tasks):
        first[t + 1] = first[t] + 2 * (tasks[t, 1] - tasks[t, 0])
    cap = max(1, first[n_tasks])
    sub_lo = np.empty((cap, 3))
    sub_hi = np.empty((cap, 3))
    sub_a = np.zeros(cap, np.int32)
    sub_n = np.zeros(cap, np.int32)
    sub_axis = np.zeros(cap, np.int32)
    made = np.zeros(n_tasks, np.int64)
    # The subtrees leave no tasks (their cutoff is 0), so they share one unused task row.
    none = np.empty((1, 3), np.int64)
    for t in target.prange(n_tasks):
        made[t] = _grow(lo, hi, cen, idx, tasks[t, 0], tasks[t, 1], tasks[t, 2], bins, max_leaf, traversal_cost, 0,
                        sub_lo, sub_hi, sub_a, sub_n, sub_axis, first[t], none)[0]
    # Stitch in preorder: a top node's row moves up by the rows of the subtrees before it.
    total = top_count + made.sum() - n_tasks
    row_of = np.empty(top_count, np.int64)
    row = 0
    for i in range(top_count):
        row_of[i] = row
        row += made[-1 - top_n[i]] if top_n[i] < 0 else 1
    node_lo = np.empty((total, 3))
    node_hi = np.empty((total, 3))
    node_a = np.empty(total, np.int32)
    node_n = np.empty(total, np.int32)
    node_axis = np.empty(total, np.int32)
    for i in range(top_count):
        r = row_of[i]
        if top_n[i] < 0:
            t = -1 - top_n[i]
            shift = r - first[t]
            for k in range(first[t], first[t] + made[t]):
                node_lo[k + shift] = sub_lo[k]
                node_hi[k + shift] = sub_hi[k]
                node_a[k + shift] = sub_a[k] + shift if sub_n[k] == 0 else sub_a[k]
                node_n[k + shift] = sub_n[k]
                node_axis[k + shift] = sub_axis[k]
            continue
        node_lo[r] = top_lo[i]
        node_hi[r] = top_hi[i]
        node_a[r] = row_of[top_a[i]] if top_n[i] == 0 else top_a[i]
        node_n[r] = top_n[i]
        node_axis[r] = top_axis[i]
    return node_lo, node_hi, node_a, node_n, node_axis, idx


def single_leaf(lo: np.ndarray, hi: np.ndarray) -> Bvh:
    """A "tree" of one leaf holding every box: traversing it tests every primitive (brute force)."""
    n = lo.shape[0]
    box_lo = lo.min(axis=0, keepdims=True) if n else np.full((1, 3), np.inf)
    box_hi = hi.max(axis=0, keepdims=True) if n else np.full((1, 3), -np.inf)
    pad = np.maximum(PAD_RELATIVE * (np.abs(box_lo).max() + np.abs(box_hi).max()), 1e-300) if n else 0.0
    return Bvh(box_lo - pad, box_hi + pad, np.zeros(1, np.int32), np.array([n], np.int32), np.zeros(1, np.int32),
               np.arange(n, dtype=np.int32))


def build_bvh(lo: np.ndarray, hi: np.ndarray, traversal_cost: float = TRAVERSAL_COST) -> Bvh:
    """A BVH over boxes [lo[i], hi[i]]; an empty input gives one empty leaf. `traversal_cost` is
    a node visit's SAH cost in primitive tests (MESH_TRAVERSAL_COST for triangles)."""
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    hi = np.ascontiguousarray(hi, dtype=np.float64)
    if lo.shape[0] == 0:
        empty = np.full((1, 3), np.inf)
        return Bvh(empty, -empty, np.zeros(1, np.int32), np.zeros(1, np.int32), np.zeros(1, np.int32), np.zeros(0, np.int32))
    # Pad flat boxes (axis-aligned quads) so a ray in their plane still meets them.
    scale = np.maximum(np.abs(lo), np.abs(hi)).max(axis=1, keepdims=True) + (hi - lo).max(axis=1, keepdims=True)
    pad = np.maximum(PAD_RELATIVE * scale, 1e-300)
    lo = lo - pad
    hi = hi + pad
    node_lo, node_hi, a, n, axis, order = _build(lo, hi, BVH_BINS, BVH_MAX_LEAF, float(traversal_cost), BUILD_TASKS)
    return Bvh(node_lo, node_hi, a, n, axis, order)


def join(first: Bvh, second: Bvh) -> Bvh:
    """One tree with `first` and `second` as the two children of its root: the leaves of each
    stay apart (a group's surfaces and its mesh triangles live in different tables). The
    second tree's items are numbered after the first's in `order`."""
    k = len(first.lo)
    root_lo = np.minimum(first.lo[0], second.lo[0])[None, :]
    root_hi = np.maximum(first.hi[0], second.hi[0])[None, :]
    a1 = np.where(first.n > 0, first.a, first.a + 1)
    a2 = np.where(second.n > 0, second.a + len(first.order), second.a + 1 + k)
    return Bvh(
        np.concatenate([root_lo, first.lo, second.lo]), np.concatenate([root_hi, first.hi, second.hi]),
        np.concatenate([[1 + k], a1, a2]).astype(np.int32), np.concatenate([[0], first.n, second.n]).astype(np.int32),
        np.concatenate([[0], first.axis, second.axis]).astype(np.int32),
        np.concatenate([first.order, second.order + len(first.order)]).astype(np.int32),
    )


# --- four-wide trees --------------------------------------------------------------------------

WIDTH = 4
# Child slot kinds in a wide node's count column.
SLOT_INTERIOR = 0
SLOT_EMPTY = -1


class WideBvh(NamedTuple):
    """The same tree with up to four children per node, for a traversal that tests four boxes at once.

    Node k's children's boxes are `box[k]`, laid out by coordinate so that each row of four
    is one vector: lo x of children 0..3, lo y, lo z, hi x, hi y, hi z (24 values). An empty
    slot's box is nan, which no ray meets. `child[k, c]` is the wide node of child c, or its
    first primitive slot if `child[k, 4 + c]` (its primitive count) is above 0; a count of
    SLOT_EMPTY marks an empty slot. Node 0 is the root.
    """

    box: np.ndarray  # (w, 24) float64
    child: np.ndarray  # (w, 8) int64


@target.kernel
def _widen(lo, hi, a, n):
    m = lo.shape[0]
    box = np.full((max(1, m), 6 * WIDTH), np.nan)
    child = np.zeros((max(1, m), 2 * WIDTH), np.int64)
    child[:, WIDTH:] = SLOT_EMPTY
    # Work stack of (binary node, wide node it becomes).
    work = np.empty((max(1, m), 2), np.int64)
    work[0, 0], work[0, 1] = 0, 0
    top = 1
    count = 1
    kids = np.empty(WIDTH, np.int64)
    # A tree of one node is a leaf, possibly empty (n = 0); in a larger tree n = 0 marks interior nodes.
    lone_leaf = m == 1
    while top > 0:
        top -= 1
        b, w = work[top, 0], work[top, 1]
        # Start from b's children (or b itself, a lone leaf at the root) and open the interior
        # child of largest surface area until there are four: large boxes are the ones rays meet.
        if lone_leaf:
            if n[b] == 0:
                break  # an empty tree: every slot stays empty
            kids[0] = b
            k = 1
        else:
            kids[0], kids[1] = b + 1, a[b]
            k = 2
        while k < WIDTH:
            best, best_area = -1, -1.0
            for s in range(k):
                j = kids[s]
                if n[j] == 0:
                    area = _area(lo[j], hi[j])
                    if area > best_area:
                        best, best_area = s, area
            if best < 0:
                break
            j = kids[best]
            kids[best] = j + 1
            kids[k] = a[j]
            k += 1
        for s in range(k):
            j = kids[s]
            for q in range(3):
                box[w, q * WIDTH + s] = lo[j, q]
                box[w, (3 + q) * WIDTH + s] = hi[j, q]
            if n[j] > 0:
                child[w, s] = a[j]
                child[w, WIDTH + s] = n[j]
            else:
                child[w, s] = count
                child[w, WIDTH + s] = SLOT_INTERIOR
                work[top, 0], work[top, 1] = j, count
                top += 1
                count += 1
    return box[:count].copy(), child[:count].copy()


def widen(tree: Bvh) -> WideBvh:
    """The four-wide form of a binary tree (same leaves, same primitive order)."""
    box, child = _widen(tree.lo, tree.hi, tree.a.astype(np.int64), tree.n.astype(np.int64))
    return WideBvh(box, child)
