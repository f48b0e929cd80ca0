"""Cast a batch of rays and report what they hit: for tests and diagnostics, not for rendering."""

import math

import numpy as np

from .. import target
from ..config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from ..numerics.rng import independent_key
from ..numerics.vec import unit, xform_normal, xform_point, xform_vector
from ..shapes import MEDIUM, PRIM_KIND
from ..motion import moves
from ..shapes.dispatch import moving_interaction, surface
from ..trees import INST_OBJECT_FROM_WORLD, INST_WORLD_FROM_OBJECT
from .traverse import intersect_brute_force, intersect_scene, traversal_scratch

# Rays per task of `closest_hits`.
CLOSEST_HITS_CHUNK = 4096


@target.kernel
def probe_rays(S, origins, dirs, time, tmin, brute):
    """For each ray: distance (inf on a miss), primitive row, instance, world point, unit outward normal and (u, v)."""
    n = origins.shape[0]
    t_out = np.full(n, np.inf)
    prim_out = np.full(n, -1, np.int64)
    inst_out = np.full(n, -1, np.int64)
    p_out = np.zeros((n, 3))
    n_out = np.zeros((n, 3))
    uv_out = np.zeros((n, 2))
    stack = (np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64))
    tstack = np.empty((BVH_STACK, 2))
    key = independent_key(12345)
    for k in range(n):
        o = (origins[k, 0], origins[k, 1], origins[k, 2])
        d = (dirs[k, 0], dirs[k, 1], dirs[k, 2])
        if brute:
            t, prim, inst = intersect_brute_force(S, o, d, tmin, math.inf, time, key, 0)
        else:
            t, prim, inst = intersect_scene(
                S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
                S.tri_i, S.verts_f, o, d, tmin, math.inf, time, key, 0, stack, tstack,
            )
        if prim < 0:
            continue
        t_out[k], prim_out[k], inst_out[k] = t, prim, inst
        if S.prims_i[prim, PRIM_KIND] == MEDIUM:  # no surface
            continue
        if moves(S.inst_i, inst):
            p, nw, u, v, _ = moving_interaction(S, prim, inst, o, d, t, time, True)
        else:
            oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, o)
            dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
            po, no, u, v = surface(S.prims_i[prim, PRIM_KIND], S, prim, oo, dd, t, time, True)
            p = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, po)
            nw = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, no))
        for q in range(3):
            p_out[k, q] = p[q]
            n_out[k, q] = nw[q]
        uv_out[k, 0], uv_out[k, 1] = u, v
    return t_out, prim_out, inst_out, p_out, n_out, uv_out


def closest_hits(S, origins, dirs, time, tmin):
    """For each ray, in parallel: distance (inf on a miss), primitive row and instance (-1 on a miss).

    The same search as `probe_rays` without the surface query, so what Embree's intersect
    answers; benchmarks/embree.py times it. The rays are cut into chunks of
    CLOSEST_HITS_CHUNK handed out to the threads, each thread with its own stacks.
    """
    return target.launch(closest_hits_on_threads, S, origins, dirs, time, tmin, traversal_scratch(target.thread_count()))


@target.parallel_kernel
def closest_hits_on_threads(S, origins, dirs, time, tmin, scratch):
    """`closest_hits`, thread k traversing with row k of `scratch` (traverse.traversal_scratch)."""
    n = origins.shape[0]
    t_out = np.full(n, np.inf)
    prim_out = np.full(n, -1, np.int64)
    inst_out = np.full(n, -1, np.int64)
    key = independent_key(12345)
    n_chunks = (n + CLOSEST_HITS_CHUNK - 1) // CLOSEST_HITS_CHUNK
    stacks_t, stacks_i, deferred, tstacks = scratch
    for c in target.prange(n_chunks):
        thread = target.thread_index()
        stack = (stacks_t[thread], stacks_i[thread], deferred[thread])
        tstack = tstacks[thread]
        for k in range(c * CLOSEST_HITS_CHUNK, min(n, (c + 1) * CLOSEST_HITS_CHUNK)):
            o = (origins[k, 0], origins[k, 1], origins[k, 2])
            d = (dirs[k, 0], dirs[k, 1], dirs[k, 2])
            t, prim, inst = intersect_scene(
                S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
                S.tri_i, S.verts_f, o, d, tmin, math.inf, time, key, 0, stack, tstack,
            )
            if prim >= 0:
                t_out[k], prim_out[k], inst_out[k] = t, prim, inst
    return t_out, prim_out, inst_out
