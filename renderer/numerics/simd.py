"""The slab test of a wide BVH node's four child boxes at once.

A wide node's row of the box table holds each coordinate of its four children side by side
(lo x of children 0..3, then lo y, ..., hi z: bvh.WideBvh), so lane k reads the k-th value of
each group of four, and computes exactly what `traverse.slab` computes for one box, with the
same operations in the same order: a ray meets the same boxes at the same distances.

`slab4_lanes` is that test as plain code, four independent lanes, portable to any target.
`slab4`, which the CPU's traversal calls, is the same computation written as LLVM vector
instructions (on x86-64 with AVX each step is one instruction on four doubles; elsewhere LLVM
splits the vectors): Numba leaves LLVM's SLP vectoriser off (NUMBA_SLP_VECTORIZE is 0 by
default), so the plain lanes stay scalar, and they cost 15-17% of a render's processor time
(the Cornell box and the final scene, one thread, measured against this form). It uses Numba's
public extension API (`numba.extending.intrinsic`); tests/renderer/test_kernel_target.py checks
that both forms and `traverse.slab` agree bit for bit, signed zeros, infinities and NaN included.
"""

import math

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

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
def slab4_lanes(box, node, o, inv, tmin, tmax):
    """What `slab4` answers, as four independent lanes of plain code: the box test of a target
    without the vector form (and the definition the vector form is tested against)."""
    row = uint64(node)  # known to be >= 0: no code for an index counted from the end
    return (slab_lane(box, row, 0, o, inv, tmin, tmax), slab_lane(box, row, 1, o, inv, tmin, tmax),
            slab_lane(box, row, 2, o, inv, tmin, tmax), slab_lane(box, row, 3, o, inv, tmin, tmax))


# The vector form.
_F64 = ir.DoubleType()
_V4 = ir.VectorType(_F64, 4)
_I32 = ir.IntType(32)
_I64 = ir.IntType(64)


def _splat(builder, x):
    v = ir.Constant(_V4, ir.Undefined)
    for k in range(4):
        v = builder.insert_element(v, x, ir.Constant(_I32, k))
    return v


# As `_min` and `_max` above (and Numba's min and max), lane by lane.
def _vector_min(builder, x, y):
    return builder.select(builder.fcmp_ordered("<", y, x), y, x)


def _vector_max(builder, x, y):
    return builder.select(builder.fcmp_ordered(">", y, x), y, x)


@intrinsic
def slab4(typingctx, box, node, o, inv, tmin, tmax):
    """(t0, t1, t2, t3): entry distance of the ray into each child box of wide node `node`
    that it meets within [tmin, tmax], else inf. `box` is a WideBvh box table (see bvh.py)."""
    if not (isinstance(box, types.Array) and box.ndim == 2 and box.dtype == types.float64 and box.layout == "C"):
        return None
    if not isinstance(node, types.Integer):
        return None
    result = types.UniTuple(types.float64, 4)
    sig = result(box, node, o, inv, tmin, tmax)

    def codegen(context, builder, signature, args):
        box_v, node_v, o_v, inv_v, tmin_v, tmax_v = args
        arr = context.make_array(signature.args[0])(context, builder, box_v)
        node_v = context.cast(builder, node_v, signature.args[1], types.int64)
        row = builder.extract_value(arr.shape, 1)
        base = builder.bitcast(builder.gep(arr.data, [builder.mul(node_v, row)]), _V4.as_pointer())

        def load(k):
            return builder.load(builder.gep(base, [ir.Constant(_I64, k)]), align=8)

        def scalar(value, ty):
            return _splat(builder, context.cast(builder, value, ty, types.float64))

        o4 = [scalar(builder.extract_value(o_v, k), signature.args[2][k]) for k in range(3)]
        inv4 = [scalar(builder.extract_value(inv_v, k), signature.args[3][k]) for k in range(3)]
        near = far = None
        for axis in range(3):
            t0 = builder.fmul(builder.fsub(load(axis), o4[axis]), inv4[axis])
            t1 = builder.fmul(builder.fsub(load(3 + axis), o4[axis]), inv4[axis])
            lo, hi = _vector_min(builder, t0, t1), _vector_max(builder, t0, t1)
            if near is None:
                near, far = lo, hi
            else:
                near, far = _vector_max(builder, near, lo), _vector_min(builder, far, hi)
        far = builder.fmul(far, _splat(builder, ir.Constant(_F64, FAR_WIDEN)))
        tmin4 = scalar(tmin_v, signature.args[4])
        tmax4 = scalar(tmax_v, signature.args[5])
        # Ordered comparisons: a nan box (an empty slot) fails them all.
        meets = builder.and_(
            builder.and_(builder.fcmp_ordered("<=", near, far), builder.fcmp_ordered(">=", far, tmin4)),
            builder.fcmp_ordered("<=", near, tmax4),
        )
        t = builder.select(meets, _vector_max(builder, near, tmin4), _splat(builder, ir.Constant(_F64, math.inf)))
        lanes = [builder.extract_element(t, ir.Constant(_I32, k)) for k in range(4)]
        return context.make_tuple(builder, result, lanes)

    return sig, codegen
