"""The slab test of a wide BVH node's four child boxes at once, as one vector computation.

Numba has no vector types, and LLVM does not turn four scalar slab tests into vector code on
its own (it kept them scalar when tried). So this is written as a Numba intrinsic that emits
LLVM vector instructions directly: on x86-64 with AVX each line below is one instruction on
four doubles; elsewhere LLVM splits the vectors into what the CPU has. Either way it computes
exactly what `traverse.slab` computes for each box, lane by lane, with the same operations in
the same order, so a ray meets the same boxes at the same distances.
"""

import math

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

_F64 = ir.DoubleType()
_V4 = ir.VectorType(_F64, 4)
_I32 = ir.IntType(32)
_I64 = ir.IntType(64)
# Widens the far end by a few ulps, as in traverse.slab.
_FAR_WIDEN = 1.0 + 4e-16


def _splat(builder, x):
    v = ir.Constant(_V4, ir.Undefined)
    for k in range(4):
        v = builder.insert_element(v, x, ir.Constant(_I32, k))
    return v


# Numba's min(x, y) is `y if y < x else x` and max(x, y) is `y if y > x else x`: the same here.
def _min(builder, x, y):
    return builder.select(builder.fcmp_ordered("<", y, x), y, x)


def _max(builder, x, y):
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
            lo, hi = _min(builder, t0, t1), _max(builder, t0, t1)
            if near is None:
                near, far = lo, hi
            else:
                near, far = _max(builder, near, lo), _min(builder, far, hi)
        far = builder.fmul(far, _splat(builder, ir.Constant(_F64, _FAR_WIDEN)))
        tmin4 = scalar(tmin_v, signature.args[4])
        tmax4 = scalar(tmax_v, signature.args[5])
        # Ordered comparisons: a nan box (an empty slot) fails them all.
        meets = builder.and_(
            builder.and_(builder.fcmp_ordered("<=", near, far), builder.fcmp_ordered(">=", far, tmin4)),
            builder.fcmp_ordered("<=", near, tmax4),
        )
        t = builder.select(meets, _max(builder, near, tmin4), _splat(builder, ir.Constant(_F64, math.inf)))
        lanes = [builder.extract_element(t, ir.Constant(_I32, k)) for k in range(4)]
        return context.make_tuple(builder, result, lanes)

    return sig, codegen
