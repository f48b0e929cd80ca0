"""A compiled wrapper that finds, for given rays, what the path tracer computes at their first
hit when its material has a normal or bump map: the same calls as `tracing/integrator.trace`
(interaction, world_derivatives, shading_frame), so a test sees the normal a render uses."""

import math

import numpy as np
from renderer import target

from renderer.materials import has_shading_map, shading_frame
from renderer.numerics.rng import independent_key
from renderer.numerics.vec import dot, neg, unit, xform_normal, xform_point, xform_vector
from renderer.shapes.dispatch import hit_material, interaction, world_derivatives
from renderer.trees import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT
from renderer.tracing.traverse import intersect_scene
from tests.renderer.kernel_calls import _stacks

# The columns of a row of `shading_at`.
HIT, POINT, NORMAL, UV, DPDU, DPDV, SHADING, TANGENT, FRONT = 0, slice(1, 4), slice(4, 7), slice(7, 9), slice(9, 12), \
    slice(12, 15), slice(15, 18), slice(18, 21), 21


@target.kernel
def _shading_at(S, origins, dirs, stack, tstack):
    out = np.zeros((origins.shape[0], 22))
    for k in range(origins.shape[0]):
        o = (origins[k, 0], origins[k, 1], origins[k, 2])
        d = (dirs[k, 0], dirs[k, 1], dirs[k, 2])
        t, prim, inst = intersect_scene(S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f,
                                        S.bnd_i, S.bnd_f, S.tri_i, S.verts_f, o, d, 0.0, math.inf, 0.0, independent_key(1), 0,
                                        stack, tstack)
        if prim < 0:
            continue
        mat = hit_material(S.prims_i, prim)
        if S.inst_i[inst, INST_UNTRANSFORMED] != 1:
            oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, o)
            dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
            po, no, u, v = interaction(S, prim, oo, dd, t, 0.0, True)
            p = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, po)
            n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, no))
            n_tree = no
        else:
            p, n, u, v = interaction(S, prim, o, d, t, 0.0, True)
            n_tree = n
        front = dot(d, n) < 0.0
        dpdu, dpdv = world_derivatives(S, prim, inst, n_tree, 0.0)
        shading, tangent = (n if front else neg(n)), (0.0, 0.0, 0.0)
        if has_shading_map(S.mat_i, mat):
            shading, tangent = shading_frame(S, mat, n, front, dpdu, dpdv, u, v, p, d)
        row = (1.0, p[0], p[1], p[2], n[0], n[1], n[2], u, v, dpdu[0], dpdu[1], dpdu[2], dpdv[0], dpdv[1], dpdv[2],
               shading[0], shading[1], shading[2], tangent[0], tangent[1], tangent[2], 1.0 if front else 0.0)
        for j in range(22):
            out[k, j] = row[j]
    return out


def shading_at(flat, origins, dirs):
    """Rows (columns named above) of the first hit of each ray (origins[k], dirs[k]) in `flat`:
    whether it hit, the point, the outward normal, (u, v), dp/du, dp/dv (world), the shading
    normal on the ray's side and the tangent, and whether the ray hit the front."""
    stack, tstack = _stacks()
    return _shading_at(flat, np.asarray(origins, np.float64), np.asarray(dirs, np.float64), stack, tstack)
