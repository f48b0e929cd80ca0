"""Shadow rays: how much of the light at the far end of a segment reaches its start.

A surface anywhere on the segment blocks it (0). Each constant-density medium it crosses
attenuates it by exp(-density x length inside), the medium's transmittance, computed exactly
from the boundary rather than drawn as a free-flight distance: a camera inside a medium and
media inside media add their lengths alike. A medium whose density varies (the
`varying_media` flag) attenuates it by ratio tracking's estimate of its transmittance
(media.varying_transmittance), with random numbers keyed by the path's key and the vertex's
bounce (`shadow_transmittance`; `transmittance` keys them by a fixed key, for callers that have
no path). Order does not matter, so the trees are walked
without sorting, a leaf's primitives are tested as soon as its node is (a leaf is never
pushed), and the walk ends at the first node where a surface is met.
"""

import math


from .. import target
from ..kernel_flags import INSTANCES, MEDIA, MESHES, MOTION, VARYING_MEDIA
from ..media import MEDIUM_BOUNDARIES, MEDIUM_FIELD, MEDIUM_FIRST_BOUNDARY, MEDIUM_NEG_INV_DENSITY, medium_span, varying_transmittance
from ..motion import instance_maps, map_point, map_vector, moves
from ..numerics.rng import independent_key
from ..numerics.simd import slab4
from ..numerics.vec import length, xform_point, xform_vector
from ..shapes import MEDIUM, MESH_TRIANGLE, PRIM_KIND
from ..shapes.dispatch import hit_primitive
from ..shapes.meshes import hit_mesh_triangle
from ..trees import INST_OBJECT_FROM_WORLD, INST_ROOT, INST_SERIAL, INST_UNTRANSFORMED, NODE_CHILD, NODE_COUNT, TLAS_COUNT, TLAS_NEXT
from .traverse import INF, at, inverse_direction, ray_constants, slab


@target.device
def leaf_depth(prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f, first, count, o, d, inv, inv_a, shear, tmax, time, key, bounce,
               inst):
    """Optical depth of the media among `count` primitives from row `first` along o + t d for t
    in (0, tmax), or inf when one of its surfaces lies there (or a varying medium's estimate is 0)."""
    first_triangle = prims_f.shape[0]
    depth = 0.0
    for prim in range(first, first + count):
        kind = prims_i[at(prim), PRIM_KIND]
        if VARYING_MEDIA and kind == MEDIUM and prims_f[prim, MEDIUM_FIELD] > 0.0:
            tr = varying_transmittance(prims_f, bnd_i, bnd_f, prim, o, d, tmax, time, key, bounce, inst)
            if not tr > 0.0:
                return INF
            depth -= math.log(tr)
        elif MEDIA and kind == MEDIUM:
            start = int(prims_f[prim, MEDIUM_FIRST_BOUNDARY])
            enter, leave = medium_span(bnd_i, bnd_f, start, int(prims_f[prim, MEDIUM_BOUNDARIES]), o, d, time)
            t0, t1 = max(enter, 0.0), min(leave, tmax)
            if t0 < t1:
                depth += (t1 - t0) * length(d) / -prims_f[prim, MEDIUM_NEG_INV_DENSITY]
        elif MESHES and kind == MESH_TRIANGLE:
            if hit_mesh_triangle(tri_i, verts_f, at(prim - first_triangle), o, shear, 0.0, tmax) < INF:
                return INF
        elif hit_primitive(kind, prims_f, at(prim), o, d, inv, inv_a, 0.0, tmax, time) < INF:
            return INF
    return depth


@target.device
def tree_depth(nodes_f, nodes_i, prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f, root, o, d, tmax, time, stack, key, bounce, inst):
    """Optical depth of the media of the wide tree at `root` along o + t d for t in (0, tmax), or
    inf when a surface lies there. `stack` is intersect_tree's (its node column is reused)."""
    _, stack_i, _ = stack
    inv, inv_a, shear = ray_constants(d)
    depth = 0.0
    stack_i[0, 0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack_i[at(sp), 0]
        # Every child the segment meets, in any order. A leaf's primitives are tested where its
        # node finds it rather than pushed and popped later (a shadow ray's walk of the Cornell
        # box's tree took 15% less time so); one surface anywhere ends the walk.
        t0, t1, t2, t3 = slab4(nodes_f, node, o, inv, 0.0, tmax)
        for c in range(4):
            if (t0 if c == 0 else t1 if c == 1 else t2 if c == 2 else t3) < INF:
                code, count = nodes_i[at(node), NODE_CHILD + c], nodes_i[at(node), NODE_COUNT + c]
                if count > 0:
                    depth += leaf_depth(prims_i, prims_f, bnd_i, bnd_f, tri_i, verts_f, code, count, o, d, inv, inv_a, shear,
                                        tmax, time, key, bounce, inst)
                    if depth == INF:
                        return INF
                elif count == 0:
                    stack_i[at(sp), 0] = code
                    sp += 1
    return depth


@target.device
def transmittance(S, o, d, tmax, time, stack, tstack):
    """`shadow_transmittance` with a fixed key: for callers with no path (tests, probes). Exact
    where every medium crossed is constant."""
    return shadow_transmittance(S, o, d, tmax, time, stack, tstack, independent_key(0), 0)


@target.device
def shadow_transmittance(S, o, d, tmax, time, stack, tstack, key, bounce):
    """The fraction of light carried from o + tmax d back to o: 0 if a surface lies between, else
    exp(-optical depth of every medium crossed) (for a medium whose density varies, an unbiased
    estimate of its factor, from random numbers keyed by the path's `key` and the vertex's `bounce`)."""
    n_inst = S.inst_i.shape[0]
    if n_inst == 0:
        return 1.0
    if not INSTANCES or (n_inst == 1 and S.inst_i[0, INST_UNTRANSFORMED] == 1):
        depth = tree_depth(S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f, S.tri_i, S.verts_f, S.inst_i[0, INST_ROOT],
                           o, d, tmax, time, stack, key, bounce, S.inst_i[0, INST_SERIAL])
        return math.exp(-depth) if depth < INF else 0.0
    depth = 0.0
    inv = inverse_direction(d)
    if slab(S.tlas_f, 0, o, inv, 0.0, tmax) == INF:
        return 1.0
    tstack[0, 0] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        node = int(tstack[sp, 0])
        count = S.tlas_i[node, TLAS_COUNT]
        if count > 0:
            first = S.tlas_i[node, TLAS_NEXT]
            for inst in range(first, first + count):
                if S.inst_i[inst, INST_UNTRANSFORMED] == 1:
                    oo, dd = o, d
                elif MOTION and moves(S.inst_i, inst):
                    _, back = instance_maps(S.inst_i, S.motion_f, inst, time)
                    oo, dd = map_point(back, o), map_vector(back, d)
                else:
                    oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, o)
                    dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
                depth += tree_depth(S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f, S.tri_i, S.verts_f,
                                    S.inst_i[inst, INST_ROOT],
                                    oo, dd, tmax, time, stack, key, bounce, S.inst_i[inst, INST_SERIAL])
                if depth == INF:
                    return 0.0
            continue
        near, far = node + 1, S.tlas_i[node, TLAS_NEXT]
        if slab(S.tlas_f, near, o, inv, 0.0, tmax) < INF:
            tstack[sp, 0] = near
            sp += 1
        if slab(S.tlas_f, far, o, inv, 0.0, tmax) < INF:
            tstack[sp, 0] = far
            sp += 1
    return math.exp(-depth)
