"""The light tree: choosing among many lights by what each may send to the shading point.

With thousands of lights, choosing one by power alone (lights.py's cdf) spends most shadow rays
on lights that are far away or turned away. The tree groups the lights that have a place (area
lights, points, spots) into a binary hierarchy; each node bounds its lights by

- a sphere (centre and radius) holding them all,
- a cone of their normals (unit axis, half-angle theta_o) and the angle theta_e past its normal
  beyond which no light of the node sends anything (pi/2 for a diffuse emitter; a spot's ramp
  from its beam to its cut-off); a node with a light that emits from both sides of its normal is
  `two_sided` (its cosines at the light are taken absolute),
- its total power (the lights' LIGHT_POWER).

A node's *importance* at shading point p with normal n is a cheap over-estimate of what its
lights can send there: power x (the largest cosine at the light that the cone and the sphere
allow toward p) x (the largest |cosine| at p that the sphere allows) / (squared distance to the
centre, at least a quarter of the squared radius). The cosines subtract the angle the sphere subtends at p
from the angle between the cone and p; it is zero only where no light of the node can reach p
(the cone and theta_e turn away from p, or the sphere lies below p's horizon on both sides: the
bound takes |cos| at p, so light through a transmissive surface counts). This is the bound of
Conty Estevez and Kulla (2018), as pbrt-v4 evaluates it, written over the bounding sphere only.

A light is chosen by walking from the root: at each node a child is taken with probability
proportional to its importance (both zero: each with 1/2, so the walk is always defined and a
light is always found), and u is rescaled to the chosen child's share of [0, 1), so one uniform
number does the whole walk. The pmf of a light is the product of the choices on its way; the
density `pdf_li` needs walks up from its leaf (`parent`) and multiplies the same factors.

The tree is built in numpy when flattening (`build_light_tree`): a split in the middle of the
centroids' spread is not enough for lights, whose orientation and power matter as much as their
place; so each split is the best of 12 buckets along each axis by the cost of Conty Estevez and
Kulla (power x the solid angle measure of the orientation cone x the box's surface area, for both
children), computed for every node of a level of the tree at once (levels, not recursion, so the
Python overhead is per level, not per node).

Which rows go into the tree, and how the tree shares the choice with the lights outside it, is
the light category's (lights.py: `light_tables` and `select_light`); the tables here are
`ltree_f` and `ltree_i` of the flat scene.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import target
from .columns import Column, Layout

LTREE_F = Layout("ltree_f", "float64", [
    Column("center", 3, "centre of the sphere that holds the node's lights (world)"),
    Column("radius", 1, "that sphere's radius: half the diagonal of the lights' box"),
    Column("axis", 3, "unit axis of the cone of the lights' normals"),
    Column("cos_o", 1, "cosine of the cone's half-angle theta_o: every light's normal is within theta_o of the axis (-1: any direction)"),
    Column("cos_e", 1, "cosine of theta_e: no light of the node sends anything further than theta_e from its normal"),
    Column("power", 1, "the power of the node's lights, their LIGHT_POWER summed"),
    Column("share", 1, "the root: the probability that the choice among the lights after the map goes to the tree "
                       "(exactly 1 where no light outside it has power); 0 for other nodes"),
])
LTREE_I = Layout("ltree_i", "int32", [
    Column("child", 1, "interior node: its first child (the second is the next row); -1 for a leaf"),
    Column("light", 1, "leaf: its light row (light_i, light_f); -1 for an interior node"),
    Column("parent", 1, "the node's parent; -1 for the root"),
    Column("two_sided", 1, "1 where a light of the node emits from both sides of its normal (cosines at the light taken absolute)"),
])
LT_CENTER, LT_RADIUS, LT_AXIS, LT_COS_O, LT_COS_E, LT_POWER, LT_SHARE = LTREE_F.offsets(
    "center", "radius", "axis", "cos_o", "cos_e", "power", "share")
LT_CHILD, LT_LIGHT, LT_PARENT, LT_TWO_SIDED = LTREE_I.offsets("child", "light", "parent", "two_sided")

# The largest double below 1: u rescaled to a child's share stays in [0, 1).
ONE_MINUS_EPSILON = 1.0 - 2.0 ** -53
# The least squared distance the importance divides by: a shading point on a point light gives a
# large finite importance, not inf (powers are below 1e150: scenefmt.bounds' extents and radiances).
MIN_DISTANCE2 = 1e-100
# Buckets per axis a split is chosen among (as pbrt-v4 and Conty Estevez and Kulla).
BUCKETS = 12
# Cones are widened by this many radians when joined, so rounding never leaves a light's own
# normal outside its node's cone.
CONE_SLACK = 1e-7


class LightBounds(NamedTuple):
    """What the tree knows of each light it holds (one entry per light, world space)."""

    lo: np.ndarray  # (m, 3) corner of least coordinates of a box holding the light
    hi: np.ndarray  # (m, 3) corner of greatest coordinates
    axis: np.ndarray  # (m, 3) unit axis of the cone of its normals
    theta_o: np.ndarray  # (m,) that cone's half-angle, radians (pi: any direction)
    theta_e: np.ndarray  # (m,) how far past its normal it sends light, radians
    two_sided: np.ndarray  # (m,) bool: it emits along the negated normal too
    power: np.ndarray  # (m,) its LIGHT_POWER, > 0

    @staticmethod
    def join(parts: list["LightBounds"]) -> "LightBounds":
        return LightBounds(*(np.concatenate([getattr(p, f) for p in parts]) for f in LightBounds._fields))


def full_sphere(count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(axis, theta_o, theta_e) of lights that may send light in every direction."""
    axis = np.zeros((count, 3))
    axis[:, 2] = 1.0
    return axis, np.full(count, math.pi), np.full(count, 0.5 * math.pi)


# --- the build (numpy) --------------------------------------------------------------------------


def _normalized(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit vectors along the rows of v, and whether the row had a direction at all)."""
    norm = np.linalg.norm(v, axis=-1)
    ok = norm > 1e-12
    out = np.zeros_like(v)
    out[..., 2] = 1.0
    out[ok] = v[ok] / norm[ok][..., None]
    return out, ok


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip(np.einsum("...k,...k->...", a, b), -1.0, 1.0))


def orientation_measure(theta_o: np.ndarray, theta_e: np.ndarray, two_sided: np.ndarray) -> np.ndarray:
    """The solid angle measure of an orientation cone (Conty Estevez and Kulla's M_Omega): the
    integral over directions of the cosine-weighted emission the cone allows; a two-sided cone
    counts twice (at most the whole sphere's 4 pi)."""
    theta_w = np.minimum(theta_o + theta_e, math.pi)
    sin_o, cos_o = np.sin(theta_o), np.cos(theta_o)
    m = 2.0 * math.pi * (1.0 - cos_o) + 0.5 * math.pi * (
        2.0 * theta_w * sin_o - np.cos(theta_o - 2.0 * theta_w) - 2.0 * theta_o * sin_o + cos_o)
    return np.minimum(np.where(two_sided, 2.0 * m, m), 4.0 * math.pi)


def _box_area(lo: np.ndarray, hi: np.ndarray, pad: np.ndarray) -> np.ndarray:
    """Surface area of boxes, each side at least `pad` long (points and flat sets still compare)."""
    e = np.maximum(hi - lo, pad[..., None])
    return 2.0 * (e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0])


def join_cones(a: np.ndarray, theta_a: np.ndarray, b: np.ndarray, theta_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smallest cone holding both cones (a, theta_a) and (b, theta_b), row by row: one of
    them if it holds the other, else the cone whose edge touches both, rotated from a toward b;
    the whole sphere (theta pi) where that is all that holds them."""
    theta_d = _angle(a, b)
    axis = a.copy()
    theta = np.maximum(theta_a, theta_b)
    a_holds = np.minimum(theta_d + theta_b, math.pi) <= theta_a
    b_holds = ~a_holds & (np.minimum(theta_d + theta_a, math.pi) <= theta_b)
    axis[b_holds] = b[b_holds]
    theta[a_holds] = theta_a[a_holds]
    theta[b_holds] = theta_b[b_holds]
    rest = ~(a_holds | b_holds)
    spread = 0.5 * (theta_a + theta_d + theta_b)
    k, turns = _normalized(np.cross(a, b))
    rotate = rest & (spread < math.pi) & turns
    phi = (spread - theta_a)[rotate]
    ar, kr = a[rotate], k[rotate]
    # Rodrigues' rotation of a about k (perpendicular to a) by phi.
    axis[rotate] = ar * np.cos(phi)[:, None] + np.cross(kr, ar) * np.sin(phi)[:, None]
    theta[rotate] = spread[rotate]
    theta[rest & ~rotate] = math.pi
    return axis, np.minimum(theta + CONE_SLACK * rest, math.pi)


def _segment_reduce(op, values: np.ndarray, keys: np.ndarray, count: int, fill: float) -> np.ndarray:
    """op (np.minimum or np.maximum) of `values` by integer key in [0, count), `fill` for keys with none."""
    out = np.full((count,) + values.shape[1:], fill)
    if len(keys) == 0:
        return out
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    out[sorted_keys[starts]] = op.reduceat(values[order], starts, axis=0)
    return out


def _split_costs(key, segments, b: LightBounds, members, pad) -> np.ndarray:
    """(segments, BUCKETS - 1): the cost of cutting each segment after each bucket, given each
    member's key segment x BUCKETS + bucket: both sides' power x orientation measure x surface
    area (inf where a side is empty)."""
    count = segments * BUCKETS
    n = np.bincount(key, minlength=count).reshape(segments, BUCKETS)
    power = np.bincount(key, weights=b.power[members], minlength=count).reshape(segments, BUCKETS)
    lo = _segment_reduce(np.minimum, b.lo[members], key, count, math.inf).reshape(segments, BUCKETS, 3)
    hi = _segment_reduce(np.maximum, b.hi[members], key, count, -math.inf).reshape(segments, BUCKETS, 3)
    axis_sum = np.stack([np.bincount(key, weights=b.axis[members, j], minlength=count) for j in range(3)], axis=1)
    axis, has_axis = _normalized(axis_sum)
    # Each bucket's cone: its members' axes summed, and the widest of their cones about it.
    spread = _angle(axis[key], b.axis[members]) + b.theta_o[members]
    theta = np.where(has_axis, _segment_reduce(np.maximum, spread, key, count, 0.0), math.pi).reshape(segments, BUCKETS)
    theta_e = _segment_reduce(np.maximum, b.theta_e[members], key, count, 0.0).reshape(segments, BUCKETS)
    two = np.bincount(key, weights=b.two_sided[members].astype(float), minlength=count).reshape(segments, BUCKETS) > 0
    axis = axis.reshape(segments, BUCKETS, 3)
    axis_sum = axis_sum.reshape(segments, BUCKETS, 3)
    filled = n > 0

    def side(reverse: bool):
        """Everything of the buckets left of each cut (reverse: right of it), for each cut."""
        def acc(op, x):
            if reverse:
                return op.accumulate(x[:, ::-1], axis=1)[:, ::-1][:, 1:]
            return op.accumulate(x, axis=1)[:, :-1]
        s_n, s_power = acc(np.add, n), acc(np.add, power)
        s_lo, s_hi = acc(np.minimum, lo), acc(np.maximum, hi)
        s_theta_e, s_two = acc(np.maximum, theta_e), acc(np.logical_or, two)
        s_axis, s_has = _normalized(acc(np.add, axis_sum))
        # The side's cone about its summed axis: the widest bucket cone about it, over its buckets.
        s_theta = np.zeros((segments, BUCKETS - 1))
        cut = np.arange(BUCKETS - 1)
        for j in range(BUCKETS):
            inside = (j > cut) if reverse else (j <= cut)
            reach = _angle(s_axis, axis[:, j][:, None, :]) + theta[:, j][:, None]
            s_theta = np.where(inside[None, :] & filled[:, j][:, None], np.maximum(s_theta, reach), s_theta)
        s_theta = np.where(s_has, np.minimum(s_theta, math.pi), math.pi)
        cost = s_power * orientation_measure(s_theta, s_theta_e, s_two) * _box_area(s_lo, s_hi, pad[:, None])
        return np.where(s_n > 0, cost, math.inf)

    return side(False) + side(True)


def _topology(b: LightBounds):
    """The tree's shape, level by level: (child, parent, first, count, depth) per node, breadth
    first (siblings next to each other), and `order`, the lights in leaf order: node k holds
    lights order[first[k]:first[k] + count[k]]."""
    m = len(b.power)
    centroid = 0.5 * (b.lo + b.hi)
    order = np.arange(m)
    parent, first, count, depth = [np.array([-1])], [np.array([0])], [np.array([m])], [np.array([0])]
    inner, inner_child = [], []  # each level's split nodes and their first children
    active = np.array([0]) if m > 1 else np.zeros(0, np.int64)
    starts, counts = np.array([0]), np.array([m])
    nodes = 1
    level = 0
    while len(active):
        segments = len(active)
        total = int(counts.sum())
        seg = np.repeat(np.arange(segments), counts)
        seg_start = np.cumsum(counts) - counts
        pos = np.repeat(starts, counts) + np.arange(total) - np.repeat(seg_start, counts)
        members = order[pos]
        c = centroid[members]
        cmin = np.minimum.reduceat(c, seg_start, axis=0)
        cmax = np.maximum.reduceat(c, seg_start, axis=0)
        box = np.maximum.reduceat(b.hi[members], seg_start, axis=0) - np.minimum.reduceat(b.lo[members], seg_start, axis=0)
        largest = box.max(axis=1)
        pad = 1e-3 * largest
        best = np.full(segments, math.inf)
        best_axis = np.full(segments, -1)
        best_cut = np.zeros(segments, np.int64)
        buckets = np.zeros((3, total), np.int64)
        for ax in range(3):
            extent = cmax[:, ax] - cmin[:, ax]
            spread = extent > 0.0
            scale = np.where(spread, BUCKETS / np.where(spread, extent, 1.0), 0.0)
            buckets[ax] = np.clip(((c[:, ax] - cmin[seg, ax]) * scale[seg]).astype(np.int64), 0, BUCKETS - 1)
            costs = _split_costs(seg * BUCKETS + buckets[ax], segments, b, members, pad)
            # A cut across a thin side of the box is worth less (pbrt-v4's K_r).
            # (Only where the centroids spread along ax: a flat side's cut is refused just below,
            # and its factor would be inf, which times a cost of 0 warns of a NaN.)
            costs *= np.where(spread, largest / np.where(spread, np.maximum(box[:, ax], 1e-300), 1.0), 1.0)[:, None]
            costs[~spread] = math.inf
            cut = np.argmin(costs, axis=1)
            low = costs[np.arange(segments), cut]
            better = low < best
            best[better], best_axis[better], best_cut[better] = low[better], ax, cut[better]
        split = best_axis >= 0
        rank = np.arange(total) - np.repeat(seg_start, counts)
        right = np.where(split[seg], buckets[np.maximum(best_axis, 0)[seg], np.arange(total)] > best_cut[seg],
                         rank >= (counts // 2)[seg])
        moved = np.argsort(seg * 2 + right, kind="stable")
        order[pos] = members[moved]
        left = np.bincount(seg, weights=(~right).astype(np.float64), minlength=segments).astype(np.int64)
        # Never empty (a cost is inf where a side is), but a degenerate cut halves by index.
        halve = (left == 0) | (left == counts)
        left[halve] = counts[halve] // 2
        inner.append(active)
        inner_child.append(nodes + 2 * np.arange(segments))
        level += 1
        new_first = np.stack([starts, starts + left], axis=1).ravel()
        new_count = np.stack([left, counts - left], axis=1).ravel()
        parent.append(np.repeat(active, 2))
        depth.append(np.full(2 * segments, level))
        first.append(new_first)
        count.append(new_count)
        ids = nodes + np.arange(2 * segments)
        nodes += 2 * segments
        more = new_count > 1
        active, starts, counts = ids[more], new_first[more], new_count[more]
    child = np.full(nodes, -1, np.int64)
    if inner:
        child[np.concatenate(inner)] = np.concatenate(inner_child)
    return child, np.concatenate(parent), np.concatenate(first), np.concatenate(count), np.concatenate(depth), order


def build_light_tree(b: LightBounds) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tables of a tree over lights with bounds `b` (at least one): (ltree_f, ltree_i with
    `light` the index into b, and the leaf node of each light of b). The caller turns `light`
    into light rows and sets the root's share."""
    m = len(b.power)
    child, parent, first, count, depth, order = _topology(b)
    n = len(child)
    leaf = child < 0
    light = np.where(leaf, order[np.minimum(first, m - 1)], -1)
    lo, hi = np.zeros((n, 3)), np.zeros((n, 3))
    axis, theta_o, theta_e = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
    two, power = np.zeros(n, np.bool_), np.zeros(n)
    at = light[leaf]
    lo[leaf], hi[leaf], axis[leaf] = b.lo[at], b.hi[at], b.axis[at]
    theta_o[leaf], theta_e[leaf], two[leaf], power[leaf] = b.theta_o[at], b.theta_e[at], b.two_sided[at], b.power[at]
    # Interior nodes from their children, deepest level first.
    inner = np.flatnonzero(~leaf)
    for d in range(int(depth[inner].max()) if len(inner) else -1, -1, -1):
        nodes = inner[depth[inner] == d]
        c0, c1 = child[nodes], child[nodes] + 1
        lo[nodes] = np.minimum(lo[c0], lo[c1])
        hi[nodes] = np.maximum(hi[c0], hi[c1])
        axis[nodes], theta_o[nodes] = join_cones(axis[c0], theta_o[c0], axis[c1], theta_o[c1])
        theta_e[nodes] = np.maximum(theta_e[c0], theta_e[c1])
        two[nodes] = two[c0] | two[c1]
        power[nodes] = power[c0] + power[c1]
    ltree_f = LTREE_F.array(n, center=0.5 * (lo + hi), radius=0.5 * np.linalg.norm(hi - lo, axis=1), axis=axis,
                            cos_o=np.cos(theta_o), cos_e=np.cos(np.minimum(theta_e, math.pi)), power=power)
    ltree_i = LTREE_I.array(n, child=child, light=light, parent=parent, two_sided=two.astype(np.int32))
    leaf_of = np.zeros(m, np.int64)
    leaf_of[light[leaf]] = np.flatnonzero(leaf)
    return ltree_f, ltree_i, leaf_of


# --- the kernels ----------------------------------------------------------------------------------


@target.device
def importance(ltree_f, ltree_i, node, p, n):
    """An over-estimate of what node `node`'s lights send to shading point p with unit normal n
    ((0, 0, 0): no cosine at p), as the module's docstring states it; 0 only where none of them
    can reach p, finite always."""
    power = ltree_f[node, LT_POWER]
    if not power > 0.0:
        return 0.0
    vx = p[0] - ltree_f[node, LT_CENTER]
    vy = p[1] - ltree_f[node, LT_CENTER + 1]
    vz = p[2] - ltree_f[node, LT_CENTER + 2]
    d2 = vx * vx + vy * vy + vz * vz
    r = ltree_f[node, LT_RADIUS]
    r2 = r * r
    # The distance is the centre's, never below half the radius: a point inside a wide node is
    # still nearer the lights of the half it is in than a sibling's (the sphere's radius would
    # make them equal), and a point at a light's centre gets a finite importance.
    near = max(d2, 0.25 * r2, MIN_DISTANCE2)
    if not d2 > r2:
        # p within the node's sphere: every direction and every cosine is possible.
        return power / near
    inv = 1.0 / math.sqrt(d2)
    wx, wy, wz = vx * inv, vy * inv, vz * inv  # from the centre toward p
    sin2_b = r2 / d2
    sin_b = math.sqrt(sin2_b)
    cos_b = math.sqrt(max(0.0, 1.0 - sin2_b))
    # At the light: the angle between the cone's axis and p, less the cone, less the sphere.
    cos_w = ltree_f[node, LT_AXIS] * wx + ltree_f[node, LT_AXIS + 1] * wy + ltree_f[node, LT_AXIS + 2] * wz
    if ltree_i[node, LT_TWO_SIDED] != 0:
        cos_w = abs(cos_w)
    sin_w = math.sqrt(max(0.0, 1.0 - cos_w * cos_w))
    cos_o = ltree_f[node, LT_COS_O]
    if cos_w >= cos_o:
        cos_x, sin_x = 1.0, 0.0
    else:
        sin_o = math.sqrt(max(0.0, 1.0 - cos_o * cos_o))
        cos_x = cos_w * cos_o + sin_w * sin_o
        sin_x = sin_w * cos_o - cos_w * sin_o
    if cos_x >= cos_b:
        cos_l = 1.0
    else:
        cos_l = cos_x * cos_b + sin_x * sin_b
    if cos_l < ltree_f[node, LT_COS_E]:
        return 0.0
    value = power * max(cos_l, 0.0) / near
    # At p: the angle between its normal and the centre, less the sphere (|cos|: either side).
    if n[0] != 0.0 or n[1] != 0.0 or n[2] != 0.0:
        cos_i = abs(n[0] * wx + n[1] * wy + n[2] * wz)
        if cos_i < cos_b:
            sin_i = math.sqrt(max(0.0, 1.0 - cos_i * cos_i))
            value *= max(0.0, cos_i * cos_b + sin_i * sin_b)
    return value


@target.device
def first_child_share(ltree_f, ltree_i, node, p, n):
    """The probability that the walk from interior node `node` goes to its first child: its
    importance over both children's, 1/2 where both are 0."""
    c = ltree_i[node, LT_CHILD]
    a = importance(ltree_f, ltree_i, c, p, n)
    b = importance(ltree_f, ltree_i, c + 1, p, n)
    total = a + b
    if total > 0.0 and total < math.inf:
        return a / total
    return 0.5


@target.device
def tree_choose(ltree_f, ltree_i, p, n, u):
    """A light of the tree for shading point p with normal n, by u in [0, 1): (its light row,
    its pmf within the tree)."""
    node = 0
    pmf = 1.0
    while ltree_i[node, LT_CHILD] >= 0:
        share = first_child_share(ltree_f, ltree_i, node, p, n)
        c = ltree_i[node, LT_CHILD]
        if u < share:
            u = min(u / share, ONE_MINUS_EPSILON)
            node = c
            pmf *= share
        else:
            u = min((u - share) / (1.0 - share), ONE_MINUS_EPSILON)
            node = c + 1
            pmf *= 1.0 - share
    return ltree_i[node, LT_LIGHT], pmf


@target.device
def tree_pmf(ltree_f, ltree_i, leaf, p, n):
    """The pmf within the tree that `tree_choose` gives the light of leaf node `leaf` from p with
    normal n: the same choices, walked up from the leaf."""
    pmf = 1.0
    node = leaf
    while ltree_i[node, LT_PARENT] >= 0:
        up = ltree_i[node, LT_PARENT]
        share = first_child_share(ltree_f, ltree_i, up, p, n)
        pmf *= share if node == ltree_i[up, LT_CHILD] else 1.0 - share
        node = up
    return pmf

