"""Closest-hit search: a top-level tree over instances, each a bottom-level tree of primitives.

The bottom-level trees are four wide (see bvh.WideBvh): a step tests a node's four child boxes
at once and visits them nearest first. The top level, over a scene's few instances, is a
binary tree visiting the child nearer along its split axis first. A constant medium is a
primitive whose hit distance is drawn from its free-flight distribution, with a random number
keyed by (bounce, instance, primitive) so the answer does not depend on the order nodes are
visited in; media are tested after the surfaces of a tree.
"""

import math

from numba import njit, uint64

from ..layout import MEDIUM, MOVING_SPHERE, SPHERE
from .features import INSTANCES, MEDIA
from .geometry import hit_planar, hit_primitive, sphere_center
from .rng import DIM_MEDIUM, mix64, uniform
from .simd import slab4
from .vec import dot, length, sub, xform_point, xform_vector

INF = math.inf
# Stands in for 1/0 in slab tests: large enough to act as infinity, finite so 0 * it is 0, not NaN.
BIG = 1e300


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def inverse_direction(d):
    return (
        1.0 / d[0] if d[0] != 0.0 else math.copysign(BIG, d[0]),
        1.0 / d[1] if d[1] != 0.0 else math.copysign(BIG, d[1]),
        1.0 / d[2] if d[2] != 0.0 else math.copysign(BIG, d[2]),
    )


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def slab(box, k, o, inv, tmin, tmax):
    """Entry distance of the ray into box k (lo 0:3, hi 3:6) if it meets [tmin, tmax], else inf."""
    t0 = (box[k, 0] - o[0]) * inv[0]
    t1 = (box[k, 3] - o[0]) * inv[0]
    near, far = min(t0, t1), max(t0, t1)
    t0 = (box[k, 1] - o[1]) * inv[1]
    t1 = (box[k, 4] - o[1]) * inv[1]
    near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    t0 = (box[k, 2] - o[2]) * inv[2]
    t1 = (box[k, 5] - o[2]) * inv[2]
    near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    # Widen the far end by a few ulps so rounding never drops a box the ray grazes (pbrt's gamma).
    far *= 1.0 + 4e-16
    # Bitwise & rather than `and`: one select instead of three branches the CPU must guess.
    return max(near, tmin) if (near <= far) & (far >= tmin) & (near <= tmax) else INF


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def descend(box, info, node, o, inv, neg0, neg1, neg2, tmin, best_t, stack, sp):
    """At interior `node`: the child to visit next (-1 if the ray meets neither) and the stack size.

    The nearer child (by the ray's direction along the split axis) is visited first; the other
    is pushed with its entry distance when the ray meets it too.
    """
    near, far = node + 1, info[node, 0]
    axis = info[node, 2]
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


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def pop(stack, sp, best_t):
    """The next pushed node the ray entered before the best hit so far (-1 if none), and the stack size."""
    while sp > 0:
        sp -= 1
        if stack[sp, 1] <= best_t:
            return int(stack[sp, 0]), sp
    return -1, sp


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def medium_span(bnd_i, bnd_f, start, count, o, d, time):
    """(enter, leave) distances of the ray's whole line through a convex boundary; enter >= leave if it misses."""
    enter, leave = INF, -INF
    for b in range(start, start + count):
        kind = bnd_i[b]
        if kind == SPHERE or kind == MOVING_SPHERE:
            c = sphere_center(kind, bnd_f, b, time)
            r = bnd_f[b, 3]
            f = sub(o, c)
            a = dot(d, d)
            half_b = dot(f, d)
            s = half_b / a
            lx, ly, lz = f[0] - s * d[0], f[1] - s * d[1], f[2] - s * d[2]
            disc = a * (r * r - (lx * lx + ly * ly + lz * lz))
            if disc <= 0.0:
                continue
            root = math.sqrt(disc)
            q = -half_b - math.copysign(root, half_b)
            t0, t1 = q / a, (dot(f, f) - r * r) / q if q != 0.0 else q / a
            enter = min(enter, min(t0, t1))
            leave = max(leave, max(t0, t1))
        else:
            t = hit_planar(kind, bnd_f, b, o, d, -INF, INF)
            if t < INF:
                enter = min(enter, t)
                leave = max(leave, t)
    return enter, leave


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def medium_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, tmax, time, key, bounce, inst):
    # `inst` is the instance's serial number.
    """Distance at which the ray scatters in medium `prim`, or inf if it passes through."""
    # Keyed by serial numbers, not table rows: the BVH reorders rows, and must not change the image.
    medium = uint64(prims_f[prim, 3])
    dim = DIM_MEDIUM + mix64(uint64(bounce) * uint64(0x100000001B3) + uint64(inst) * uint64(0x2545F4914F6CDD1D) + medium)
    u = uniform(key, dim)
    speed = length(d)
    # The free-flight distance -ln(1 - u) / density is at least u / density. When that already
    # reaches past where the ray can be inside the medium, it passes through, and neither the
    # boundary nor the logarithm is needed. The answer is the one they would give. Two bounds:
    # the ray's whole extent (tmin, tmax), known before the boundary is intersected (the
    # traversal tests media last, so tmax is then the nearest surface), and the part inside.
    reach = u * -prims_f[prim, 0]
    if reach > (tmax - max(tmin, 0.0)) * speed:
        return INF
    start, count = int(prims_f[prim, 1]), int(prims_f[prim, 2])
    enter, leave = medium_span(bnd_i, bnd_f, start, count, o, d, time)
    t0, t1 = max(enter, tmin), min(leave, tmax)
    if not t0 < t1:
        return INF
    t0 = max(t0, 0.0)
    inside = (t1 - t0) * speed
    if reach > inside:
        return INF
    # -ln(1 - u) / density with u in [0, 1): finite, never log(0).
    distance = prims_f[prim, 0] * math.log1p(-u)
    if distance > inside:
        return INF
    return t0 + distance / speed


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def at(i):
    """Index i, known to be >= 0, as an unsigned number: Numba then leaves out the code that
    would count a negative index from the end (three instructions per access of the hot loop)."""
    return uint64(i)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
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


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def intersect_tree(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, root, o, d, tmin, tmax, time, key, bounce, inst, stack):
    """Closest primitive of the wide tree at `root` hit in (tmin, tmax): (t, prim), prim -1 if none.

    Each step tests the four child boxes of a node at once (simd.slab4), goes on to the nearest
    the ray meets and pushes the others, nearest on top. `stack` holds three arrays: entry
    distances, (node or first primitive, primitive count), and room for the media met, which
    are tested after the surfaces. A popped entry is skipped without another test when a
    nearer hit has been found since it was pushed.
    """
    stack_t, stack_i, deferred = stack
    n_deferred = 0
    inv = inverse_direction(d)
    inv_a = 1.0 / dot(d, d)
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
            sp = push_sorted(stack_t, stack_i, base, sp, t0, nodes_i[at(node), 0], nodes_i[at(node), 4])
        if t1 < INF and near != 1:
            sp = push_sorted(stack_t, stack_i, base, sp, t1, nodes_i[at(node), 1], nodes_i[at(node), 5])
        if t2 < INF and near != 2:
            sp = push_sorted(stack_t, stack_i, base, sp, t2, nodes_i[at(node), 2], nodes_i[at(node), 6])
        if t3 < INF and near != 3:
            sp = push_sorted(stack_t, stack_i, base, sp, t3, nodes_i[at(node), 3], nodes_i[at(node), 7])
        code, count = -1, -1
        if near >= 0:
            code, count = nodes_i[at(node), at(near)], nodes_i[at(node), at(4 + near)]
        node = -1
        while True:
            if count == 0:
                node = code
                break
            if count > 0:
                for prim in range(code, code + count):
                    kind = prims_i[at(prim), 0]
                    if MEDIA and kind == MEDIUM:
                        if n_deferred < deferred.shape[0]:
                            deferred[n_deferred] = prim
                            n_deferred += 1
                            continue
                        t = medium_hit(prims_f, bnd_i, bnd_f, prim, o, d, tmin, best_t, time, key, bounce, inst)
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


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def intersect_scene(tlas_f, tlas_i, inst_i, inst_f, nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f,
                    o, d, tmin, tmax, time, key, bounce, stack, tstack):
    """Closest hit in the scene: (t, prim, instance); prim -1 if the ray escapes."""
    n_inst = inst_i.shape[0]
    if n_inst == 0:
        return tmax, -1, -1
    if INSTANCES:
        if n_inst > 1 or inst_i[0, 1] != 1:
            return intersect_instances(tlas_f, tlas_i, inst_i, inst_f, nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f,
                                       o, d, tmin, tmax, time, key, bounce, stack, tstack)
    # No instancing at all: one tree in world space.
    t, prim = intersect_tree(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, inst_i[0, 0],
                             o, d, tmin, tmax, time, key, bounce, inst_i[0, 2], stack)
    return t, prim, 0 if prim >= 0 else -1


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def intersect_instances(tlas_f, tlas_i, inst_i, inst_f, nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f,
                        o, d, tmin, tmax, time, key, bounce, stack, tstack):
    """Closest hit through the top-level tree: each instance's tree in its own space."""
    best_t, best_prim, best_inst = tmax, -1, -1
    inv = inverse_direction(d)
    if slab(tlas_f, 0, o, inv, tmin, best_t) == INF:
        return best_t, best_prim, best_inst
    sp = 0
    node = 0
    while True:
        count = tlas_i[node, 1]
        if count > 0:
            first = tlas_i[node, 0]
            for inst in range(first, first + count):
                if inst_i[inst, 1] == 1:
                    oo, dd = o, d
                else:
                    oo = xform_point(inst_f, inst, 12, o)
                    dd = xform_vector(inst_f, inst, 12, d)
                t, prim = intersect_tree(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, inst_i[inst, 0],
                                         oo, dd, tmin, best_t, time, key, bounce, inst_i[inst, 2], stack)
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


@njit(cache=True, error_model="numpy")
def intersect_brute_force(S, o, d, tmin, tmax, time, key, bounce):
    """The same answer as `intersect_scene` by testing every primitive of every instance (for tests)."""
    best_t, best_prim, best_inst = tmax, -1, -1
    for inst in range(S.inst_i.shape[0]):
        oo = xform_point(S.inst_f, inst, 12, o)
        dd = xform_vector(S.inst_f, inst, 12, d)
        if S.inst_i[inst, 1] == 1:
            oo, dd = o, d
        inv, inv_a = inverse_direction(dd), 1.0 / dot(dd, dd)
        lo_prim, hi_prim = tree_prim_range(S.nodes_i, S.inst_i[inst, 0])
        for prim in range(lo_prim, hi_prim):
            kind = S.prims_i[prim, 0]
            if kind == MEDIUM:
                t = medium_hit(S.prims_f, S.bnd_i, S.bnd_f, prim, oo, dd, tmin, best_t, time, key, bounce, S.inst_i[inst, 2])
            else:
                t = hit_primitive(kind, S.prims_f, prim, oo, dd, inv, inv_a, tmin, best_t, time)
            if t < best_t:
                best_t, best_prim, best_inst = t, prim, inst
    return best_t, best_prim, best_inst


@njit(cache=True, error_model="numpy")
def tree_prim_range(nodes_i, root):
    """The rows [lo, hi) of the primitives of the wide tree at `root` (they are contiguous)."""
    lo, hi = 1 << 62, -1
    stack = [root]
    while len(stack) > 0:
        node = stack.pop()
        for c in range(4):
            code, count = nodes_i[node, c], nodes_i[node, 4 + c]
            if count > 0:
                lo = min(lo, code)
                hi = max(hi, code + count)
            elif count == 0:
                stack.append(code)
    return lo, hi
