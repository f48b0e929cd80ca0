"""Building the guide's tables (guiding.py) from the records of a training render, in numpy.

A record is one vertex of a training path: where it was (a surface point), the direction the path
left in, and the luminance of the radiance that came back along it divided by the density of
that direction (an unbiased estimate of that radiance's integral over directions). The guide is
the SD-tree of Mueller, Gross and Novak (2017), built afresh from one set of records:

- the spatial tree: the box of the records (padded, and within the scene's lo..hi) cut in the
  middle of its longest side while a node holds more than `max_records` records, down to
  `max_depth` levels. Every node at one depth has the same shape (halving keeps it), so the
  axis of a cut depends on the depth alone;
- in each spatial leaf that holds at least `min_records` records and some energy, a quadtree over
  the square of directions (guiding.py's equal-area map): a cell is cut in four while it holds
  more than `threshold` of its leaf's energy (the sum of its weights), at least `cell_records`
  records with energy, and is shallower than `quad_depth`. A leaf with fewer records, or none
  with energy, gets no distribution: its vertices sample their BSDF alone (`guide_leaf` gives
  -1), since a handful of records would send half of those bounces after noise; such leaves lie
  where the training paths seldom went.

The count of records a cell needs is ours, not Mueller et al.'s. They cut a cell by the energy of
one iteration and fill the cells with the records of the next, so a cell cut around a few lucky
records is judged by fresh ones. Built from one set of records, a cell cut on energy alone
follows those few records down to the finest depth: a spike of almost no solid angle that takes
their share of the guide's samples and finds nothing beside them. benchmarks/guide_records.py
measures it on a light field with a known answer (a sphere of 1% of the directions lighting a
floor and a wall; four training iterations of doubling counts, 2 million records in the last;
the guided estimate's variance over uniform sampling's, 2 at worst): with max_records 8,000, cut
on energy alone gave 1.71; at least 4, 8, 16, 32 records a cell gave 0.20, 0.13, 0.12, 0.15
(light overhead); 0.23, 0.17, 0.15, 0.15 with the light along the map's pole, +z, where a small
light smears along a ring of cells; and where the light reaches only a disc of the floor
(`--spot 2`, as a caustic does), 1.36 on energy alone, 0.14, 0.14, 0.20 with 8, 16, 32. A new cell holds a quarter of its parent's
records, so with 16 it starts from about 4: coarse, and true to what was seen; as the iterations
send more samples where the light is, the cells there get finer.

`max_records` was settled on the same field (16 records a cell, 2 million records): 1,000,
2,000, 4,000, 8,000, 16,000 a leaf gave 0.31, 0.22, 0.17, 0.12, 0.11 (light overhead), 0.32,
0.25, 0.18, 0.15, 0.11 (along the pole), and -, 0.27, 0.21, 0.14, 0.15 (the disc). The smooth
field favours large leaves and the disc's edge small ones; 8,000 is best or within 12% of it
in all three.

Both trees are built a level at a time over all their nodes at once (the Python work is per
level, not per node), so 2 million records build in about a second on one core. Memory is
bounded whatever the records are (all at one point, all of weight zero, none): at most
`max_nodes` spatial nodes and `max_quads` quadtree cells; where a level would pass a cap, the
nodes holding the most records (cells holding the largest share of their leaf's energy) are cut
first. Records that are not finite, of negative weight, with a direction of length zero or
outside the scene's box are dropped. The same arrays and settings give the same tables, bit for
bit.
"""

from __future__ import annotations

import math

import numpy as np

from .guiding import (G_AXIS, G_CHILD, G_GUIDED, G_HI, G_LO, G_NODES, G_QCHILD, G_QUAD, G_QUADS, G_RECORDS, G_SHARE,
                      G_SPLIT, GUIDE_F_HEAD, GUIDE_I_HEAD)

# A spatial node with more records than this is cut (see `build_guide`).
MAX_RECORDS = 8000
# A spatial leaf with fewer records than this gets no distribution.
MIN_RECORDS = 64
# Levels of cuts of the spatial tree, at most: enough for a ground 2,000 units wide seen down to a
# few hundredths of a unit (three axes, 15 cuts each), and a cap on the leaf search's loop.
MAX_DEPTH = 48
# Rows of each kind of tree, at most (tables of 80 bytes a row: 5 MB and 21 MB).
MAX_NODES = 1 << 16
MAX_QUADS = 1 << 18
# Mueller et al.'s: a cell holding more than 1% of its leaf's energy is cut in four.
THRESHOLD = 0.01
# A cell is cut only where at least this many records with energy fell in it (see `build_guide`).
CELL_RECORDS = 16
# Levels of a quadtree: its finest cell spans 4 pi / 4^12, about 7.5e-7 sr (a sun 0.53 degrees
# across is 6.7e-5 sr).
QUAD_DEPTH = 12
# The spatial box is padded by this share of its longest side on every side.
PAD = 1e-3
# Records farther from the origin than this on an axis are dropped: scene coordinates stay below
# 1e60 (scenefmt.bounds.MAX_EXTENT, with room for transforms), and a box of any size within it
# halves finitely.
MAX_COORDINATE = 1e100


def build_guide(positions, directions, weights, lo, hi, *, max_records: int = MAX_RECORDS,
                min_records: int = MIN_RECORDS, max_depth: int = MAX_DEPTH, max_nodes: int = MAX_NODES,
                threshold: float = THRESHOLD, cell_records: int = CELL_RECORDS, quad_depth: int = QUAD_DEPTH,
                max_quads: int = MAX_QUADS) -> dict:
    """The tables {"guide_f", "guide_i"} (guiding.py) of the guide learned from records: positions
    (N, 3) of surface vertices, unit directions (N, 3) the paths left in, weights (N,) >= 0 (the
    radiance that came back along each, over the direction's density), the scene's bounds lo, hi
    (3,). Deterministic; settings as the module's docstring says (out-of-range ones are clamped)."""
    positions = np.asarray(positions, np.float64).reshape(-1, 3)
    directions = np.asarray(directions, np.float64).reshape(-1, 3)
    weights = np.asarray(weights, np.float64).reshape(-1)
    if not len(positions) == len(directions) == len(weights):
        raise ValueError(f"build_guide: {len(positions)} positions, {len(directions)} directions and "
                         f"{len(weights)} weights; one of each per record expected")
    max_records = max(1, int(max_records))
    min_records = max(1, int(min_records))
    max_depth = min(max(0, int(max_depth)), 100)
    max_nodes = max(1, int(max_nodes))
    threshold = float(threshold) if math.isfinite(threshold) else THRESHOLD
    threshold = min(max(threshold, 0.0), 1.0)
    cell_records = max(1, int(cell_records))
    quad_depth = min(max(1, int(quad_depth)), 24)
    max_quads = max(0, int(max_quads))

    positions, directions, weights = _kept(positions, directions, weights, lo, hi)
    box_lo, box_hi = _box(positions, lo, hi)
    child, axis, split, leaf_of = _spatial_tree(positions, box_lo, box_hi, max_records, max_depth, max_nodes)
    nodes = len(child)

    # The leaves that get a distribution: enough records, and some energy among them.
    count = np.bincount(leaf_of, minlength=nodes)
    energy = np.bincount(leaf_of, weights=weights, minlength=nodes)
    guided = (child < 0) & (count >= min_records) & (energy > 0.0)
    # At least one cell per guided leaf: the cap on quadtree rows bounds the leaves with one too.
    if guided.sum() > max_quads:
        guided[np.flatnonzero(guided)[np.argsort(-count[guided], kind="stable")[max_quads:]]] = False
    quad_root, share, quad_child = _quadtrees(directions, weights, leaf_of, guided, energy, threshold, cell_records,
                                              quad_depth, max_quads)
    quads = len(share)

    gf = np.zeros((1 + nodes + quads, GUIDE_F_HEAD.width), np.float64)
    gi = np.zeros((1 + nodes + quads, GUIDE_I_HEAD.width), np.int64)
    gf[0, G_LO:G_LO + 3] = box_lo
    gf[0, G_HI:G_HI + 3] = box_hi
    gi[0, [G_NODES, G_QUADS, G_RECORDS, G_GUIDED]] = nodes, quads, len(weights), int(guided.sum())
    node_rows = slice(1, 1 + nodes)
    gf[node_rows, G_SPLIT] = split
    gi[node_rows, G_CHILD] = np.where(child >= 0, 1 + child, -1)
    gi[node_rows, G_AXIS] = axis
    gi[node_rows, G_QUAD] = np.where(quad_root >= 0, 1 + nodes + quad_root, -1)
    quad_rows = slice(1 + nodes, 1 + nodes + quads)
    gf[quad_rows, G_SHARE:G_SHARE + 4] = share
    gi[quad_rows, G_QCHILD:G_QCHILD + 4] = np.where(quad_child >= 0, 1 + nodes + quad_child, -1)
    return {"guide_f": gf, "guide_i": gi}


def guide_summary(tables: dict) -> dict:
    """What a guide holds, from its header: spatial nodes, quadtree cells, the records it was
    built from and the leaves with a distribution (all 0 for an empty guide)."""
    gi = tables["guide_i"]
    if gi.shape[0] == 0:
        return {"nodes": 0, "quads": 0, "records": 0, "guided": 0}
    return {name: int(gi[0, at]) for name, at in
            (("nodes", G_NODES), ("quads", G_QUADS), ("records", G_RECORDS), ("guided", G_GUIDED))}


def _kept(positions, directions, weights, lo, hi):
    """The records worth learning from, directions made unit: finite (coordinates within
    MAX_COORDINATE), weight >= 0, a direction of some length, and inside the scene's box where
    that box is finite (padded); weights divided by the largest."""
    length = np.sqrt(np.einsum("ij,ij->i", directions, directions)) if len(directions) else np.zeros(0)
    with np.errstate(invalid="ignore"):
        keep = ((np.abs(positions) <= MAX_COORDINATE).all(axis=1) & np.isfinite(directions).all(axis=1)
                & np.isfinite(weights) & (weights >= 0.0) & (length > 0.0) & np.isfinite(length))
    scene_lo, scene_hi = np.asarray(lo, np.float64).reshape(3), np.asarray(hi, np.float64).reshape(3)
    if (np.abs(np.r_[scene_lo, scene_hi]) <= MAX_COORDINATE).all() and (scene_lo <= scene_hi).all():
        pad = _pad(scene_lo, scene_hi)
        with np.errstate(invalid="ignore"):
            keep &= ((positions >= scene_lo - pad) & (positions <= scene_hi + pad)).all(axis=1)
    if not keep.all():
        positions, directions, weights, length = positions[keep], directions[keep], weights[keep], length[keep]
    # Only shares of energy matter: weights over the largest sum without overflow (1e308 each).
    largest = float(weights.max()) if len(weights) else 0.0
    if largest > 0.0:
        weights = weights / largest
    return positions, directions / length[:, None], weights


def _box(positions, lo, hi):
    """The spatial tree's box: the records' bounds, padded on every side (also where they are
    flat or a single point, so that every cut has room); the scene's box if there are none."""
    if len(positions):
        box_lo, box_hi = positions.min(axis=0), positions.max(axis=0)
    else:
        box_lo, box_hi = np.asarray(lo, np.float64).reshape(3), np.asarray(hi, np.float64).reshape(3)
        if not ((np.abs(np.r_[box_lo, box_hi]) <= MAX_COORDINATE).all() and (box_lo <= box_hi).all()):
            box_lo, box_hi = np.zeros(3), np.zeros(3)
    pad = _pad(box_lo, box_hi)
    return box_lo - pad, box_hi + pad


def _pad(lo, hi) -> float:
    """How far a box is widened on every side: PAD of its longest side (of its distance from the
    origin where it is a point, 1 for the origin itself), and a few roundings of its coordinates,
    so that scenes of any size (scenefmt.bounds: 1e-60 to 1e60) get a box of their own scale."""
    largest = float((hi - lo).max())
    far = float(np.abs(np.r_[lo, hi]).max())
    scale = largest if largest > 0.0 else (far if far > 0.0 else 1.0)
    return PAD * scale + 4.0 * float(np.spacing(far))


def _cap(wanted: np.ndarray, priority: np.ndarray, room: int) -> np.ndarray:
    """`wanted` (bool) kept only for the `room` entries of highest priority (ties: the first)."""
    if wanted.sum() <= room:
        return wanted
    at = np.flatnonzero(wanted)
    keep = at[np.argsort(-priority[at], kind="stable")[:max(room, 0)]]
    out = np.zeros_like(wanted)
    out[keep] = True
    return out


def _spatial_tree(positions, box_lo, box_hi, max_records, max_depth, max_nodes):
    """The spatial tree, breadth first, node 0 the root: per node its first child (-1: a leaf; the
    second child is the next node), its axis and split, and each record's leaf."""
    n = len(positions)
    coords = [np.ascontiguousarray(positions[:, a]) for a in range(3)]  # of the active records
    child, axis, split = [np.full(1, -1, np.int64)], [np.zeros(1, np.int64)], [np.zeros(1)]
    leaf_of = np.zeros(n, np.int64)
    level_lo = box_lo[None, :].copy()  # corner of each node of the level; all share `extent`
    level_count = np.array([n])
    extent = box_hi - box_lo
    base, total = 0, 1  # the level's first node, and how many nodes there are
    active = np.arange(n)  # the records in the level's nodes, and their node within the level
    local = np.zeros(n, np.int64)
    for depth in range(max_depth):
        cut = _cap(level_count > max_records, level_count, (max_nodes - total) // 2)
        if not cut.any():
            break
        a = int(np.argmax(extent))  # the level's axis: its nodes' longest side (the first of equals)
        half = 0.5 * extent[a]
        at = np.flatnonzero(cut)
        first = total + 2 * np.arange(len(at))
        node_child = np.full(len(level_count), -1, np.int64)
        node_child[at] = first
        node_split = level_lo[:, a] + half
        child[-1][:] = node_child
        axis[-1][at] = a
        split[-1][at] = node_split[at]
        # Records in nodes not cut stay in their leaf; the others go below or above the cut.
        moving = cut[local]
        if not moving.all():
            leaf_of[active[~moving]] = base + local[~moving]
            active, local = active[moving], local[moving]
            coords = [c[moving] for c in coords]
        # Each record's node within the next level: the cut nodes' children, in order.
        renumber = np.zeros(len(cut), np.int64)
        renumber[at] = 2 * np.arange(len(at))
        local = renumber[local] + (coords[a] >= node_split[local])
        lo_next = np.repeat(level_lo[at], 2, axis=0)
        lo_next[1::2, a] = node_split[at]
        level_lo = lo_next
        level_count = np.bincount(local, minlength=2 * len(at))
        extent = extent.copy()
        extent[a] = half
        base, total = total, total + 2 * len(at)
        child.append(np.full(2 * len(at), -1, np.int64))
        axis.append(np.zeros(2 * len(at), np.int64))
        split.append(np.zeros(2 * len(at)))
    leaf_of[active] = base + local
    return np.concatenate(child), np.concatenate(axis), np.concatenate(split), leaf_of


def _square(directions):
    """(x, y) on the square [0, 1)^2 of unit directions: the equal-area map of guiding.py."""
    x = 0.5 * (np.clip(directions[:, 2], -1.0, 1.0) + 1.0)
    y = np.arctan2(directions[:, 1], directions[:, 0]) * (0.5 / math.pi)
    y = np.where(y < 0.0, y + 1.0, y)
    one = 1.0 - 2.0 ** -53
    return np.minimum(x, one), np.minimum(y, one)


def _quadtrees(directions, weights, leaf_of, guided, energy, threshold, cell_records, quad_depth, max_quads):
    """The quadtrees of the guided leaves: per spatial node the root cell of its tree (-1: none),
    and per cell its quarters' shares (n, 4) and the cells that split them (n, 4; -1: a leaf
    cell). Each leaf's cells are contiguous, breadth first."""
    nodes = len(guided)
    quad_root = np.full(nodes, -1, np.int64)
    leaves = np.flatnonzero(guided)
    if len(leaves) == 0:
        return quad_root, np.zeros((0, 4)), np.zeros((0, 4), np.int64)
    guided_index = np.full(nodes, -1, np.int64)
    guided_index[leaves] = np.arange(len(leaves))
    # Records of weight zero add nothing to any cell's energy.
    use = guided[leaf_of] & (weights > 0.0)
    x, y = _square(directions[use])
    w = weights[use]
    scale = float(1 << quad_depth)
    qx = np.minimum((x * scale).astype(np.int64), (1 << quad_depth) - 1)
    qy = np.minimum((y * scale).astype(np.int64), (1 << quad_depth) - 1)
    local = guided_index[leaf_of[use]]  # each record's cell within the level
    level_leaf = leaves.copy()  # each cell's spatial leaf
    shares, children, cell_leaf = [], [], []
    total = len(leaves)
    for depth in range(quad_depth):
        shift = quad_depth - 1 - depth
        quarter = ((qx >> shift) & 1) + 2 * ((qy >> shift) & 1)
        count = len(level_leaf)
        key = 4 * local + quarter
        mass = np.bincount(key, weights=w, minlength=4 * count).reshape(count, 4)
        seen = np.bincount(key, minlength=4 * count)
        cell_mass = mass.sum(axis=1)
        shares.append(mass / cell_mass[:, None])
        cell_leaf.append(level_leaf)
        of_leaf = (mass / energy[level_leaf][:, None]).ravel()
        cut = (of_leaf > threshold) & (seen >= cell_records) if depth + 1 < quad_depth else np.zeros(4 * count, bool)
        cut = _cap(cut, of_leaf, max_quads - total)
        first = np.full(4 * count, -1, np.int64)
        first[cut] = total + np.arange(int(cut.sum()))
        children.append(first.reshape(count, 4))
        total += int(cut.sum())
        moving = cut[key]
        qx, qy, w = qx[moving], qy[moving], w[moving]
        local = first[key[moving]] - (total - int(cut.sum()))
        level_leaf = np.repeat(level_leaf, 4)[cut]
        if not cut.any():
            break
    share = np.concatenate(shares)
    child = np.concatenate(children)
    leaf = np.concatenate(cell_leaf)
    # Each leaf's cells together (breadth first within it), for the cache on the hot path.
    order = np.argsort(leaf, kind="stable")
    new_index = np.empty_like(order)
    new_index[order] = np.arange(len(order))
    share, child = share[order], child[order]
    child = np.where(child >= 0, new_index[np.maximum(child, 0)], -1)
    quad_root[leaves] = new_index[np.arange(len(leaves))]
    return quad_root, share, child
