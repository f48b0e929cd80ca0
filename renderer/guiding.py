"""Path guiding: where light arrives from, learned per region of space, as a sampling density.

A path that leaves a matte surface in a direction drawn from its BSDF finds light that reaches it
only through glass or a mirror (a caustic) by luck. The guide is a distribution of incident
radiance over directions, one per cell of a spatial tree over the scene, learned from the paths
of a short training render (guide_training.py) and built in numpy (guide_build.py). At a vertex
with a density (materials.has_density) the integrator draws its next direction from the guide or
from the BSDF, one or the other at random, and weighs by the mixture of both densities, so the
estimate stays unbiased whatever the guide has learned (tracing/integrator.py).

The contract the integrator keeps with this module (tables `guide_f`, `guide_i` of the flat
scene; both empty when the scene is not guided):

- `guide_leaf(gf, gi, p)`: the spatial leaf whose directional distribution holds at point p, or
  -1 where there is none (an empty guide, p outside the tree's box, a leaf that learned nothing):
  the vertex then samples its BSDF alone.
- `sample_guide(gf, gi, leaf, u0, u1) -> (d, pdf)`: a unit direction d drawn from the leaf's
  distribution, and its density per unit solid angle (> 0).
- `pdf_guide(gf, gi, leaf, d)`: the density per unit solid angle with which `sample_guide` draws
  the unit direction d from that leaf (0 where it never does).

The tables (the SD-tree of Mueller, Gross and Novak 2017, "Practical path guiding"), one row
kind per part, all referring to each other by absolute row:

- row 0, the header: the box of the spatial tree (`GUIDE_F_HEAD`) and what the build counted
  (`GUIDE_I_HEAD`);
- rows 1 .. nodes, the spatial tree, binary, root at row 1 (`GUIDE_F_NODE`, `GUIDE_I_NODE`): an
  interior node cuts its box in two at `split` along `axis`, its children at rows child and
  child + 1 (below the cut, then above); a leaf (child -1) names the root row of its
  directional quadtree, or -1 where it has none;
- the rows after them, the directional quadtrees (`GUIDE_F_QUAD`, `GUIDE_I_QUAD`): a row is a
  cell of the square that was split in four; it holds its four quarters' shares of the cell's
  energy (summing to 1) and, for each quarter, the row that splits it further, or -1 where the
  quarter is a leaf cell whose density is uniform.

Directions live on the square [0, 1)^2 through the equal-area map x = (cos theta + 1) / 2,
y = phi / 2 pi (world axes: theta from +z, phi from +x toward +y), whose Jacobian is constant:
a density q on the square is q / 4 pi per unit solid angle. Quarter c of a cell is
c = ix + 2 iy, where ix (iy) says the upper half in x (y). The map's cells are squares on the
square but thin near its poles, +z and -z: light from a small source there spreads over a ring of
cells, which the guide resolves less well than one elsewhere (benchmarks/guide_records.py: a
variance 15 to 30% higher); in the books' scenes, +y is up.
"""

from __future__ import annotations

import math

import numpy as np

from . import target
from .columns import Column, Layout

GUIDE_F_HEAD = Layout("guide_f header", "float64", [
    Column("lo", 3, "row 0: corner of least coordinates of the spatial tree's box (world)"),
    Column("hi", 3, "row 0: corner of greatest coordinates; a point outside lo..hi has no guide"),
])
GUIDE_F_NODE = Layout("guide_f node", "float64", [
    Column("split", 1, "spatial node (rows 1 .. nodes): where an interior node cuts its box along its axis (the middle)"),
], GUIDE_F_HEAD.width)
GUIDE_F_QUAD = Layout("guide_f quad", "float64", [
    Column("share", 4, "quadtree cell (rows after the nodes): the share of the cell's energy in each quarter "
                       "ix + 2 iy (they sum to 1; 0: never drawn)"),
], GUIDE_F_HEAD.width)
GUIDE_I_HEAD = Layout("guide_i header", "int64", [
    Column("nodes", 1, "row 0: how many spatial node rows follow the header (rows 1 .. nodes); the quadtree rows come after"),
    Column("quads", 1, "row 0: how many quadtree rows there are"),
    Column("records", 1, "row 0: how many records the guide was built from (those kept: finite, weight >= 0, inside the box)"),
    Column("guided", 1, "row 0: how many spatial leaves have a distribution"),
])
GUIDE_I_NODE = Layout("guide_i node", "int64", [
    Column("child", 1, "spatial node: its first child's row (below the split; the second, above it, is the next row); -1 for a leaf"),
    Column("axis", 1, "interior spatial node: the axis it splits, 0 x, 1 y, 2 z"),
    Column("quad", 1, "spatial leaf: the root row of its directional quadtree; -1 where it has none (BSDF sampling alone)"),
], GUIDE_I_HEAD.width)
GUIDE_I_QUAD = Layout("guide_i quad", "int64", [
    Column("child", 4, "quadtree cell: for each quarter, the row that splits it further, or -1 for a leaf cell (uniform)"),
], GUIDE_I_HEAD.width)

G_LO, G_HI = GUIDE_F_HEAD.offsets("lo", "hi")
G_NODES, G_QUADS, G_RECORDS, G_GUIDED = GUIDE_I_HEAD.offsets("nodes", "quads", "records", "guided")
G_SPLIT = GUIDE_F_NODE.offset("split")
G_CHILD, G_AXIS, G_QUAD = GUIDE_I_NODE.offsets("child", "axis", "quad")
G_SHARE = GUIDE_F_QUAD.offset("share")
G_QCHILD = GUIDE_I_QUAD.offset("child")
ROOT = 1  # the spatial tree's root row

INV_4PI = 1.0 / (4.0 * math.pi)
# The largest double below 1: a rescaled random number stays in [0, 1).
ONE_MINUS_EPSILON = 1.0 - 2.0 ** -53


def empty_guide() -> dict:
    """The guide tables of a scene that is not guided: no leaves anywhere."""
    return {"guide_f": np.zeros((0, 1), np.float64), "guide_i": np.zeros((0, 1), np.int64)}


@target.device
def guide_leaf(gf, gi, p):
    """The leaf of the spatial tree holding p, or -1 where the guide has nothing to say: an empty
    guide, p outside the tree's box (or not finite), a leaf without a distribution."""
    if gi.shape[0] == 0:
        return -1
    x, y, z = p[0], p[1], p[2]
    # Written so that a NaN coordinate fails the test too.
    if not (gf[0, G_LO] <= x <= gf[0, G_HI] and gf[0, G_LO + 1] <= y <= gf[0, G_HI + 1]
            and gf[0, G_LO + 2] <= z <= gf[0, G_HI + 2]):
        return -1
    node = ROOT
    child = gi[node, G_CHILD]
    while child >= 0:
        axis = gi[node, G_AXIS]
        c = x if axis == 0 else (y if axis == 1 else z)
        node = child + 1 if c >= gf[node, G_SPLIT] else child
        child = gi[node, G_CHILD]
    if gi[node, G_QUAD] < 0:
        return -1
    return node


@target.device
def _clamp_unit(u):
    """u in [0, 1): rescaling may round up to 1, and a non-finite u becomes 0."""
    if u >= ONE_MINUS_EPSILON:
        return ONE_MINUS_EPSILON
    if u >= 0.0:
        return u
    return 0.0


@target.device
def _square_to_direction(x, y):
    """The unit direction at (x, y) of the square (the equal-area map)."""
    z = 2.0 * x - 1.0
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * y
    return (r * math.cos(phi), r * math.sin(phi), z)


@target.device
def sample_guide(gf, gi, leaf, u0, u1):
    """(unit direction, solid angle density) drawn from leaf `leaf`'s distribution.

    Each level chooses the column (ix) by u0 and the row (iy) within it by u1, rescaling each to
    its choice, so both numbers keep their precision down the tree; the final cell is drawn
    uniformly with what remains of them. The density is the product of 4 x the chosen quarters'
    shares, computed as `pdf_guide` computes it."""
    row = gi[leaf, G_QUAD]
    u0 = _clamp_unit(u0)
    u1 = _clamp_unit(u1)
    ox, oy, size = 0.0, 0.0, 1.0  # the current cell: its corner and side on the square
    density = 1.0
    while row >= 0:
        s0, s1 = gf[row, G_SHARE], gf[row, G_SHARE + 1]
        s2, s3 = gf[row, G_SHARE + 2], gf[row, G_SHARE + 3]
        left, right = s0 + s2, s1 + s3
        t = u0 * (left + right)
        if right <= 0.0 or t < left:
            ix = 0
            u0 = _clamp_unit(t / left)
            below, above = s0, s2
        else:
            ix = 1
            u0 = _clamp_unit((t - left) / right)
            below, above = s1, s3
        t = u1 * (below + above)
        if above <= 0.0 or t < below:
            iy = 0
            u1 = _clamp_unit(t / below)
            share = below
        else:
            iy = 1
            u1 = _clamp_unit((t - below) / above)
            share = above
        density *= 4.0 * share / (left + right)
        size *= 0.5
        ox += ix * size
        oy += iy * size
        row = gi[row, G_QCHILD + ix + 2 * iy]
    d = _square_to_direction(ox + u0 * size, oy + u1 * size)
    return d, density * INV_4PI


@target.device
def pdf_guide(gf, gi, leaf, d):
    """The solid angle density with which `sample_guide` draws unit direction d from `leaf`: the
    same descent, by the quarters d's point of the square lies in."""
    x = 0.5 * (d[2] + 1.0)
    y = math.atan2(d[1], d[0]) * (0.5 / math.pi)
    if y < 0.0:
        y += 1.0
    x = _clamp_unit(x)
    y = _clamp_unit(y)
    row = gi[leaf, G_QUAD]
    density = 1.0
    while row >= 0:
        ix = 1 if x >= 0.5 else 0
        iy = 1 if y >= 0.5 else 0
        share = gf[row, G_SHARE + ix + 2 * iy]
        if share <= 0.0:
            return 0.0
        s0, s1 = gf[row, G_SHARE], gf[row, G_SHARE + 1]
        s2, s3 = gf[row, G_SHARE + 2], gf[row, G_SHARE + 3]
        density *= 4.0 * share / ((s0 + s2) + (s1 + s3))
        # Exact in floating point: doubling, and subtracting 1 from a number in [1, 2).
        x = 2.0 * x - ix
        y = 2.0 * y - iy
        row = gi[row, G_QCHILD + ix + 2 * iy]
    return density * INV_4PI
