"""The path tracer: one path per (pixel, sample), and the parallel pass over the image."""

import math

import numpy as np
from numba import njit, prange

from ..background import background
from ..camera import camera_ray
from ..config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from ..kernel_flags import EMITTERS, IMAGE, INSTANCES, MEDIA
from ..materials import DIFFUSE_LIGHT, MAT_KIND, MAT_READS_UV, MAT_TEXTURE, is_zero, scatter
from ..shapes import MEDIUM, PRIM_KIND, PRIM_MATERIAL
from ..shapes.dispatch import spawn_origin, surface
from ..textures import texture_value
from .rng import bounce_dim, path_key
from .traverse import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT, intersect_scene
from .vec import dot, madd, neg, unit, xform_normal, xform_point, xform_vector


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def trace(S, key, o, d, time, max_depth, stack, tstack):
    """Radiance along one camera path, and the number of rays it cast."""
    r, g, b = 0.0, 0.0, 0.0
    tr, tg, tb = 1.0, 1.0, 1.0
    rays = 0
    for bounce in range(max_depth):
        rays += 1
        t, prim, inst = intersect_scene(
            S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
            S.tri_i, S.verts_f, o, d, 0.0, math.inf, time, key, bounce, stack, tstack,
        )
        if prim < 0:
            bg = background(S.background, d)
            r += tr * bg[0]
            g += tg * bg[1]
            b += tb * bg[2]
            break
        prim_kind = S.prims_i[prim, PRIM_KIND]
        mat = S.prims_i[prim, PRIM_MATERIAL]
        kind = S.mat_i[mat, MAT_KIND]
        if MEDIA and prim_kind == MEDIUM:
            # A scattering event inside a medium: no surface, no normal, no (u, v).
            p = madd(o, d, t)
            n = (1.0, 0.0, 0.0)
            u = v = 0.0
            front = True
            n_front = n
        else:
            # (u, v) only where the material's texture reads it (an image): see surface().
            want_uv = IMAGE and S.mat_i[mat, MAT_READS_UV] != 0
            if INSTANCES and S.inst_i[inst, INST_UNTRANSFORMED] != 1:
                oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, o)
                dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
                po, no, u, v = surface(prim_kind, S, prim, oo, dd, t, time, want_uv)
                p = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, po)
                n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, no))
            else:
                p, n, u, v = surface(prim_kind, S, prim, o, d, t, time, want_uv)
            front = dot(d, n) < 0.0
            n_front = n if front else neg(n)
        tex = S.mat_i[mat, MAT_TEXTURE]
        if EMITTERS and kind == DIFFUSE_LIGHT:
            e = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, tex, u, v, p)
            r += tr * e[0]
            g += tg * e[1]
            b += tb * e[2]
            break
        new_d = scatter(S.mat_i, S.mat_f, mat, d, n_front, front, key, bounce_dim(bounce, 0))
        if is_zero(new_d):
            break
        att = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, tex, u, v, p)
        tr *= att[0]
        tg *= att[1]
        tb *= att[2]
        if tr == 0.0 and tg == 0.0 and tb == 0.0:
            break
        if MEDIA and prim_kind == MEDIUM:
            o = p
        else:
            o = spawn_origin(p, o, n_front, new_d)
        d = new_d
    return r, g, b, rays


@njit(cache=True, error_model="numpy")
def row_stride(height):
    """A step through the rows, coprime with their number, near the golden ratio of it.

    Numba hands each thread one contiguous block of the loop's iterations. Rows differ a lot in
    cost (sky above, a cluttered floor below), so blocks of adjacent rows left one thread idle
    while the other finished: two threads were only 1.4 times as fast as one. Visiting row
    (k * stride) mod height at step k spreads every block over the whole image. Each row is
    still computed alone, so the image does not change.
    """
    stride = max(1, int(height * 0.6180339887498949))
    while math.gcd(stride, height) != 1:
        stride += 1
    return stride


@njit(parallel=True, cache=True, error_model="numpy")
def render_pass(S, width, height, seed, sample_start, sample_count, max_depth, total, total_sq, row_rays, row_bad):
    """Add `sample_count` samples per pixel, numbered from `sample_start`, into the film sums."""
    stride = row_stride(height)
    for k in prange(height):
        j = (k * stride) % height
        stack = (np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64))
        tstack = np.empty((BVH_STACK, 2))
        rays = 0
        bad = 0
        for i in range(width):
            pixel = j * width + i
            for s in range(sample_start, sample_start + sample_count):
                key = path_key(seed, pixel, s)
                o, d, time = camera_ray(S.camera, i, j, key)
                r, g, b, n = trace(S, key, o, d, time, max_depth, stack, tstack)
                rays += n
                if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
                    bad += 1  # counted and reported, never added to the image
                    continue
                total[j, i, 0] += r
                total[j, i, 1] += g
                total[j, i, 2] += b
                total_sq[j, i, 0] += r * r
                total_sq[j, i, 1] += g * g
                total_sq[j, i, 2] += b * b
        row_rays[j] += rays
        row_bad[j] += bad
