"""The slab test of a wide BVH node's four child boxes, lane by lane.

A wide node's row of the box table holds each coordinate of its four children side by side
(lo x of children 0..3, then lo y, ..., hi z: bvh.WideBvh), so lane k reads the k-th value of
each group of four. Each lane computes exactly what `traverse.slab` computes for one box, with
the same operations in the same order, so a ray meets the same boxes at the same distances.
The minimum and maximum are written as the comparisons they are (`b if b < a else a`), so that
the result is defined bit for bit for -0, infinities and NaN (an empty slot is NaN and fails
every comparison) whatever the compiler makes of them; the four lanes are independent, which
leaves LLVM free to compute them as one vector operation.
"""

import math

from .. import target
from ..target import uint64

INF = math.inf
# Widens the far end by a few ulps, as in traverse.slab.
FAR_WIDEN = 1.0 + 4e-16


@target.device
def _min(a, b):
    return b if b < a else a


@target.device
def _max(a, b):
    return b if b > a else a


@target.device
def slab_lane(box, node, k, o, inv, tmin, tmax):
    """Entry distance of the ray into child box k of wide node `node` if it meets [tmin, tmax], else inf."""
    t0 = (box[node, k] - o[0]) * inv[0]
    t1 = (box[node, 12 + k] - o[0]) * inv[0]
    near, far = _min(t0, t1), _max(t0, t1)
    t0 = (box[node, 4 + k] - o[1]) * inv[1]
    t1 = (box[node, 16 + k] - o[1]) * inv[1]
    near, far = _max(near, _min(t0, t1)), _min(far, _max(t0, t1))
    t0 = (box[node, 8 + k] - o[2]) * inv[2]
    t1 = (box[node, 20 + k] - o[2]) * inv[2]
    near, far = _max(near, _min(t0, t1)), _min(far, _max(t0, t1))
    far = far * FAR_WIDEN
    # Bitwise & of ordered comparisons: one select, and a NaN box fails it.
    return _max(near, tmin) if (near <= far) & (far >= tmin) & (near <= tmax) else INF


@target.device
def slab4(box, node, o, inv, tmin, tmax):
    """(t0, t1, t2, t3): entry distance of the ray into each child box of wide node `node`
    that it meets within [tmin, tmax], else inf. `box` is a WideBvh box table (see bvh.py)."""
    row = uint64(node)  # known to be >= 0: no code for an index counted from the end
    return (slab_lane(box, row, 0, o, inv, tmin, tmax), slab_lane(box, row, 1, o, inv, tmin, tmax),
            slab_lane(box, row, 2, o, inv, tmin, tmax), slab_lane(box, row, 3, o, inv, tmin, tmax))
