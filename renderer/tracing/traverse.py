"""Closest-hit search: a top-level tree over instances, each a bottom-level tree of primitives.

The bottom-level trees are four wide (see bvh.WideBvh): a step tests a node's four child boxes
at once and visits them nearest first. The top level, over a scene's few instances, is a
binary tree visiting the child nearer along its split axis first. A constant medium is a
primitive whose hit distance is drawn from its free-flight distribution (media.py); media are
tested after the surfaces of a tree.
"""

import math

import numpy as np

from .. import target
from ..config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from ..kernel_flags import INSTANCES, MEDIA, MESHES, MOTION
from ..media import medium_hit
from ..motion import instance_maps, map_point, map_vector, moves
from ..numerics.simd import slab4
from ..numerics.vec import dot, xform_point, xform_vector
from ..shapes import MEDIUM, MESH_TRIANGLE, PRIM_KIND
from ..shapes.dispatch import hit_primitive
from ..shapes.meshes import NO_SHEAR, hit_mesh_triangle, ray_shear
from ..target import uint64
from ..trees import (INST_OBJECT_FROM_WORLD, INST_ROOT, INST_SERIAL, INST_UNTRANSFORMED, NODE_CHILD, NODE_COUNT, TLAS_AXIS, TLAS_COUNT,
                     TLAS_HI, TLAS_LO, TLAS_NEXT, tree_prims)

INF = math.inf

# Stands in for 1/0 in slab tests: large enough to act as infinity, finite so 0 * it is 0, not NaN.
BIG = 1e300


def traversal_scratch(threads: int):
    """Traversal stacks for `threads` threads of a parallel kernel (row k is thread k's, see
    target.thread_index): the closest-hit search's (entry distances, entries, media set aside;
    see intersect_tree) and the shadow rays' top-level one (shadow.transmittance)."""
    return (np.empty((threads, BVH_WIDE_STACK)), np.empty((threads, BVH_WIDE_STACK, 2), np.int64),
            np.empty((threads, MEDIA_DEFERRED), np.int64), np.empty((threads, BVH_STACK, 2)))


@target.device
def inverse_direction(d):
    return (
        1.0 / d[0] if d[0] != 0.0 else math.copysign(BIG, d[0]),
        1.0 / d[1] if d[1] != 0.0 else math.copysign(BIG, d[1]),
        1.0 / d[2] if d[2] != 0.0 else math.copysign(BIG, d[2]),
    )


@target.device
def ray_constants(d):
    """What a walk of a tree needs of a ray's direction, once per walk: its inverse (box slabs),
    1 / (d . d) (spheres) and its sheared frame (mesh triangles, when the kernel has them)."""
    shear = NO_SHEAR
    if MESHES:
        shear = ray_shear(d)
    return inverse_direction(d), 1.0 / dot(d, d), shear


@target.device
def slab(box, k, o, inv, tmin, tmax):
    """Entry distance of the ray into box k (lo 0:3, hi 3:6) if it meets [tmin, tmax], else inf."""
    t0 = (box[k, TLAS_LO] - o[0]) * inv[0]
    t1 = (box[k, TLAS_HI] - o[0]) * inv[0]
    near, far = min(t0, t1), max(t0, t1)
    t0 = (box[k, TLAS_LO + 1] - o[1]) * inv[1]
    t1 = (box[k, TLAS_HI + 1] - o[1]) * inv[1]
    near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    t0 = (box[k, TLAS_LO + 2] - o[2]) * inv[2]
    t1 = (box[k, TLAS_HI + 2] - o[2]) * inv[2]
    near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    # Widen the far end by a few ulps so rounding never drops a box the ray grazes (pbrt's gamma).
    far *= 1.0 + 4e-16
    # Bitwise & rather than `and`: one select instead of three branches the CPU must guess.
    return max(near, tmin) if (near <= far) & (far >= tmin) & (near <= tmax) else INF


@target.device
def descend(box, info, node, o, inv, neg0, neg1, neg2, tmin, best_t, stack, sp):
    """At interior `node`: the child to visit next (-1 if the ray meets neither) and the stack size.

    The nearer child (by the ray's direction along the split axis) is visited first; the other
    is pushed with its entry distance when the ray meets it too.
    """
    near, far = node + 1, info[node, TLAS_NEXT]
    axis = info[node, TLAS_AXIS]
    if neg0 if axis == 0 else (neg1 if axis == 1 else neg2):
        near, far = far, near
    t_near = slab(box, near, o, inv, tmin, best_t)
    t_far = slab(box, far, o, inv, tmin, best_t)
    if t_near < INF:
        if t_far < INF:
            stack[sp, 0] = far
            stack[sp, 1] = t_far
            sp += 1
        return near, sp
    if t_far < INF:
        return far, sp
    return -1, sp


@target.device
def pop(stack, sp, best_t):
    """The next pushed node the ray entered before the best hit so far (-1 if none), and the stack size."""
    while sp > 0:
        sp -= 1
        if stack[sp, 1] <= best_t:
            return int(stack[sp, 0]), sp
    return -1, sp


@target.device
def at(i):
    """Index i, known to be >= 0, as an unsigned number: Numba then leaves out the code that
    would count a negative index from the end (three instructions per access of the hot loop)."""
    return uint64(i)


@target.device
def push_sorted(stack_t, stack_i, base, sp, t, code, count):
    """Push (t, code, count) onto the stack's entries base..sp-1, kept in order of falling t,
    and return the new size. A node's children are pushed this way, so the nearest is popped first."""
    j = sp
    while j > base and stack_t[at(j - 1)] < t:
        stack_t[at(j)] = stack_t[at(j - 1)]
        stack_i[at(j), 0], stack_i[at(j), 1] = stack_i[at(j - 1), 0], stack_i[at(j - 1), 1]
        j -= 1
    stack_t[at(j)] = t
    stack_i[at(j), 0], stack_i[at(j), 1] = code, count
    return sp + 1


@target.device
def intersect_tree(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f, root, o, d, tmin, tmax, time, key, bounce,
                   inst, stack):
    """Closest primitive of the wide tree at `root` hit in (tmin, tmax): (t, prim), prim -1 if none.

    Each step tests the four child boxes of a node at once (simd.slab4), goes on to the nearest
    the ray meets and pushes the others, nearest on top. `stack` holds three arrays: entry
    distances, (node or first primitive, primitive count), and room for the media met, which
    are tested after the surfaces. A popped entry is skipped without another test when a
    nearer hit has been found since it was pushed. Mesh triangles (rows from P = the number
    of prims_f rows on) are tested in the ray's sheared frame (shapes/meshes.py).
    """
    stack_t, stack_i, deferred = stack
    n_deferred = 0
    inv, inv_a, shear = ray_constants(d)
    first_triangle = prims_f.shape[0]
    best_t, best_prim = tmax, -1
    sp = 0
    node = root
    while True:
        t0, t1, t2, t3 = slab4(nodes_f, node, o, inv, tmin, best_t)
        # The nearest child met is visited at once; the others are pushed, nearest on top.
        near, near_t = -1, INF
        if t0 < near_t:
            near, near_t = 0, t0
        if t1 < near_t:
            near, near_t = 1, t1
        if t2 < near_t:
            near, near_t = 2, t2
        if t3 < near_t:
            near, near_t = 3, t3
        base = sp
        if t0 < INF and near != 0:
            sp = push_sorted(stack_t, stack_i, base, sp, t0, nodes_i[at(node), NODE_CHILD + 0], nodes_i[at(node), NODE_COUNT + 0])
        if t1 < INF and near != 1:
            sp = push_sorted(stack_t, stack_i, base, sp, t1, nodes_i[at(node), NODE_CHILD + 1], nodes_i[at(node), NODE_COUNT + 1])
        if t2 < INF and near != 2:
            sp = push_sorted(stack_t, stack_i, base, sp, t2, nodes_i[at(node), NODE_CHILD + 2], nodes_i[at(node), NODE_COUNT + 2])
        if t3 < INF and near != 3:
            sp = push_sorted(stack_t, stack_i, base, sp, t3, nodes_i[at(node), NODE_CHILD + 3], nodes_i[at(node), NODE_COUNT + 3])
        code, count = -1, -1
        if near >= 0:
            code, count = nodes_i[at(node), at(NODE_CHILD + near)], nodes_i[at(node), at(NODE_COUNT + near)]
        node = -1
        while True:
            if count == 0:
                node = code
                break
            if count > 0:
                for prim in range(code, code + count):
                    kind = prims_i[at(prim), PRIM_KIND]
                    if MEDIA and kind == MEDIUM:
                        if n_deferred < deferred.shape[0]:
                            deferred[n_deferred] = prim
                            n_deferred += 1
                            continue
                        t = medium_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, best_t, time, key, bounce, inst)
                    elif MESHES and kind == MESH_TRIANGLE:
                        t = hit_mesh_triangle(tri_i, verts_f, at(prim - first_triangle), o, shear, tmin, best_t)
                    else:
                        t = hit_primitive(kind, prims_f, at(prim), o, d, inv, inv_a, tmin, best_t, time)
                    if t < best_t:
                        best_t, best_prim = t, prim
            # The next pushed entry the ray reaches before the best hit so far.
            count = -1
            while sp > 0:
                sp -= 1
                if stack_t[at(sp)] <= best_t:
                    code, count = stack_i[at(sp), 0], stack_i[at(sp), 1]
                    break
            if count < 0:
                break
        if node < 0:
            break
    if MEDIA:
        # Media met on the way are tested last, against the nearest surface: most rays through a
        # thin medium then pass it on a bound alone (see medium_hit).
        for k in range(n_deferred):
            prim = deferred[k]
            t = medium_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, best_t, time, key, bounce, inst)
            if t < best_t:
                best_t, best_prim = t, prim
    return best_t, best_prim


@target.device
def intersect_scene(tlas_f, tlas_i, inst_i, inst_f, motion_f, nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f,
                    o, d, tmin, tmax, time, key, bounce, stack, tstack):
    """Closest hit in the scene: (t, prim, instance); prim -1 if the ray escapes."""
    n_inst = inst_i.shape[0]
    if n_inst == 0:
        return tmax, -1, -1
    if INSTANCES:
        if n_inst > 1 or inst_i[0, INST_UNTRANSFORMED] != 1:
            return intersect_instances(tlas_f, tlas_i, inst_i, inst_f, motion_f, nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f,
                                       tri_i, verts_f, o, d, tmin, tmax, time, key, bounce, stack, tstack)
    # No instancing at all: one tree in world space.
    t, prim = intersect_tree(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f, inst_i[0, INST_ROOT],
                             o, d, tmin, tmax, time, key, bounce, inst_i[0, INST_SERIAL], stack)
    return t, prim, 0 if prim >= 0 else -1


@target.device
def intersect_instances(tlas_f, tlas_i, inst_i, inst_f, motion_f, nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f,
                        o, d, tmin, tmax, time, key, bounce, stack, tstack):
    """Closest hit through the top-level tree: each instance's tree in its own space (a moving
    instance's at the ray's time)."""
    best_t, best_prim, best_inst = tmax, -1, -1
    inv = inverse_direction(d)
    if slab(tlas_f, 0, o, inv, tmin, best_t) == INF:
        return best_t, best_prim, best_inst
    sp = 0
    node = 0
    while True:
        count = tlas_i[node, TLAS_COUNT]
        if count > 0:
            first = tlas_i[node, TLAS_NEXT]
            for inst in range(first, first + count):
                if inst_i[inst, INST_UNTRANSFORMED] == 1:
                    oo, dd = o, d
                elif MOTION and moves(inst_i, inst):
                    _, back = instance_maps(inst_i, motion_f, inst, time)
                    oo, dd = map_point(back, o), map_vector(back, d)
                else:
                    oo = xform_point(inst_f, inst, INST_OBJECT_FROM_WORLD, o)
                    dd = xform_vector(inst_f, inst, INST_OBJECT_FROM_WORLD, d)
                t, prim = intersect_tree(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f, inst_i[inst, INST_ROOT],
                                         oo, dd, tmin, best_t, time, key, bounce, inst_i[inst, INST_SERIAL], stack)
                if prim >= 0 and t < best_t:
                    best_t, best_prim, best_inst = t, prim, inst
        else:
            child, sp = descend(tlas_f, tlas_i, node, o, inv, d[0] < 0.0, d[1] < 0.0, d[2] < 0.0, tmin, best_t, tstack, sp)
            if child >= 0:
                node = child
                continue
        node, sp = pop(tstack, sp, best_t)
        if node < 0:
            break
    return best_t, best_prim, best_inst


@target.kernel
def intersect_brute_force(S, o, d, tmin, tmax, time, key, bounce):
    """The same answer as `intersect_scene` by testing every primitive of every instance (for tests)."""
    best_t, best_prim, best_inst = tmax, -1, -1
    for inst in range(S.inst_i.shape[0]):
        oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, o)
        dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
        if S.inst_i[inst, INST_UNTRANSFORMED] == 1:
            oo, dd = o, d
        elif moves(S.inst_i, inst):
            _, back = instance_maps(S.inst_i, S.motion_f, inst, time)
            oo, dd = map_point(back, o), map_vector(back, d)
        inv, inv_a = inverse_direction(dd), 1.0 / dot(dd, dd)
        shear = ray_shear(dd)
        for prim in tree_prims(S.nodes_i, S.inst_i[inst, INST_ROOT]):
            kind = S.prims_i[prim, PRIM_KIND]
            if kind == MESH_TRIANGLE:
                t = hit_mesh_triangle(S.tri_i, S.verts_f, prim - S.prims_f.shape[0], oo, shear, tmin, best_t)
            elif kind == MEDIUM:
                t = medium_hit(S.prims_f, S.bnd_i, S.bnd_f, prim, oo, dd, tmin, best_t, time, key, bounce, S.inst_i[inst, INST_SERIAL])
            else:
                t = hit_primitive(kind, S.prims_f, prim, oo, dd, inv, inv_a, tmin, best_t, time)
            if t < best_t:
                best_t, best_prim, best_inst = t, prim, inst
    return best_t, best_prim, best_inst
