"""The path tracer: one path per (pixel, sample), and the parallel pass over the image."""

import math

import numpy as np
from numba import njit, prange, uint64

from ..config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from ..layout import BACKGROUND_SKY, DIFFUSE_LIGHT, MEDIUM
from .features import DEFOCUS, EMITTERS, IMAGE, INSTANCES, MEDIA, MOTION, SKY
from .geometry import spawn_origin, surface
from .materials import is_zero, scatter
from .rng import DIM_LENS_RETRY, DIM_LENS_X, DIM_LENS_Y, DIM_PIXEL_X, DIM_PIXEL_Y, DIM_TIME, bounce_dim, path_key, uniform
from .textures import texture_value
from .traverse import intersect_scene
from .vec import dot, madd, neg, unit, xform_normal, xform_point, xform_vector


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def background(bg, d):
    if SKY and bg[0] == BACKGROUND_SKY:
        a = 0.5 * (unit(d)[1] + 1.0)
        return ((1.0 - a) * bg[1] + a * bg[4], (1.0 - a) * bg[2] + a * bg[5], (1.0 - a) * bg[3] + a * bg[6])
    return (bg[1], bg[2], bg[3])


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def lens_point(key):
    """A uniform point (x, y) of the unit disk for the path with `key`.

    Points of the square [-1, 1]^2 are drawn until one falls inside (pi/4 of them do), which
    costs no sine or cosine: those took 6% of a defocused render. Each try uses dimensions of
    its own, so a kept point is exactly uniform. After eight misses (a chance of 5e-6) the
    polar form, r = sqrt(U) and an angle, gives the point from two more fresh dimensions.
    """
    for k in range(8):
        if k == 0:
            x = 2.0 * uniform(key, DIM_LENS_X) - 1.0
            y = 2.0 * uniform(key, DIM_LENS_Y) - 1.0
        else:
            x = 2.0 * uniform(key, DIM_LENS_RETRY + uint64(2 * k)) - 1.0
            y = 2.0 * uniform(key, DIM_LENS_RETRY + uint64(2 * k + 1)) - 1.0
        if x * x + y * y < 1.0:
            return x, y
    r = math.sqrt(uniform(key, DIM_LENS_RETRY + uint64(16)))
    phi = 2.0 * math.pi * uniform(key, DIM_LENS_RETRY + uint64(17))
    return r * math.cos(phi), r * math.sin(phi)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def camera_ray(cam, i, j, key):
    """Origin, direction and time of the camera ray through pixel (i, j) for the path with `key`."""
    ox = uniform(key, DIM_PIXEL_X) - 0.5
    oy = uniform(key, DIM_PIXEL_Y) - 0.5
    target = (
        cam[3] + (i + ox) * cam[6] + (j + oy) * cam[9],
        cam[4] + (i + ox) * cam[7] + (j + oy) * cam[10],
        cam[5] + (i + ox) * cam[8] + (j + oy) * cam[11],
    )
    origin = (cam[0], cam[1], cam[2])
    if DEFOCUS and cam[18] > 0.0:
        lx, ly = lens_point(key)
        origin = (
            cam[0] + lx * cam[12] + ly * cam[15],
            cam[1] + lx * cam[13] + ly * cam[16],
            cam[2] + lx * cam[14] + ly * cam[17],
        )
    into_shutter = 0.0
    if MOTION:
        into_shutter = uniform(key, DIM_TIME) * (cam[20] - cam[19])
    time = cam[19] + into_shutter
    return origin, (target[0] - origin[0], target[1] - origin[1], target[2] - origin[2]), time


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
            o, d, 0.0, math.inf, time, key, bounce, stack, tstack,
        )
        if prim < 0:
            bg = background(S.background, d)
            r += tr * bg[0]
            g += tg * bg[1]
            b += tb * bg[2]
            break
        prim_kind = S.prims_i[prim, 0]
        mat = S.prims_i[prim, 1]
        kind = S.mat_i[mat, 0]
        if MEDIA and prim_kind == MEDIUM:
            # A scattering event inside a medium: no surface, no normal, no (u, v).
            p = madd(o, d, t)
            n = (1.0, 0.0, 0.0)
            u = v = 0.0
            front = True
            n_front = n
        else:
            # (u, v) only where the material's texture reads it (an image): see surface().
            want_uv = IMAGE and S.mat_i[mat, 2] != 0
            if INSTANCES and S.inst_i[inst, 1] != 1:
                oo = xform_point(S.inst_f, inst, 12, o)
                dd = xform_vector(S.inst_f, inst, 12, d)
                po, no, u, v = surface(prim_kind, S.prims_f, prim, oo, dd, t, time, want_uv)
                p = xform_point(S.inst_f, inst, 0, po)
                n = unit(xform_normal(S.inst_f, inst, 12, no))
            else:
                p, n, u, v = surface(prim_kind, S.prims_f, prim, o, d, t, time, want_uv)
            front = dot(d, n) < 0.0
            n_front = n if front else neg(n)
        tex = S.mat_i[mat, 1]
        if EMITTERS and kind == DIFFUSE_LIGHT:
            e = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, tex, u, v, p)
            r += tr * e[0]
            g += tg * e[1]
            b += tb * e[2]
            break
        new_d = scatter(kind, S.mat_f[mat, 0], S.mat_f[mat, 1], d, n_front, front, key, bounce_dim(bounce, 0))
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
