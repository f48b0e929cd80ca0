"""The path tracer: one path per (pixel, sample), and the parallel pass over the image."""

import math

import numpy as np
from numba import njit, prange

from ..camera import camera_ray
from ..config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from ..flat import INTEGRATOR_MIS
from ..kernel_flags import EMITTERS, IMAGE, INSTANCES, MEDIA
from ..lights import light_of_hit, lights_to_sample, pdf_li, radiance_escaped, sample_li
from ..materials import DIFFUSE_LIGHT, ISOTROPIC, LAMBERTIAN, MAT_KIND, MAT_READS_UV, MAT_TEXTURE, is_zero, scatter
from ..shapes import MEDIUM, PRIM_KIND, PRIM_MATERIAL
from ..shapes.dispatch import spawn_origin, surface
from ..textures import texture_value
from .rng import bounce_dim, light_dim, path_key, uniform
from .shadow import transmittance
from .traverse import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT, intersect_scene
from .vec import dot, madd, neg, sub, unit, xform_normal, xform_point, xform_vector

# Russian roulette starts after this many bounces: the first carry most of the light. Starting
# after 2 rather than 3 gave 8 to 12% more efficiency (1 / (error^2 x time)) on the light-sampled
# book scenes.
ROULETTE_AFTER = 2
# A shadow ray stops this fraction short of the point on the light, so the light itself (whose
# point is exact to a few ulps) never blocks it.
SHADOW_MARGIN = 1e-7


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def trace(S, key, o, d, time, max_depth, integrator, stack, tstack):
    """Radiance along one camera path, and the number of rays it cast (shadow rays included).

    With INTEGRATOR_PATH this is the books' estimator: a path finds a light only by chance.
    With INTEGRATOR_MIS, every diffuse surface and every scattering event in a medium also
    samples a point on a light and casts a shadow ray to it (next-event estimation); that
    estimate and the path's own chance hit on a light are weighted by the power heuristic
    (multiple importance sampling), and paths past a few bounces end by Russian roulette.
    The lights are the light category's (lights.py): `sample_li` chooses one of every kind and
    samples it, `pdf_li` and `radiance_escaped` give the density it would have had for a path
    that hits a light or escapes to one at infinity (an environment map).
    """
    r, g, b = 0.0, 0.0, 0.0
    tr, tg, tb = 1.0, 1.0, 1.0
    rays = 0
    mis = integrator == INTEGRATOR_MIS
    nee = mis and lights_to_sample(S)
    # The solid angle density with which the last vertex chose this ray's direction; 0 after
    # the camera and after a metal or a dielectric, whose directions no light sampler can give.
    prev_pdf = 0.0
    prev_p = o
    for bounce in range(max_depth):
        rays += 1
        t, prim, inst = intersect_scene(
            S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
            S.tri_i, S.verts_f, o, d, 0.0, math.inf, time, key, bounce, stack, tstack,
        )
        if prim < 0:
            bg, light = radiance_escaped(S, d)
            if light > 0.0 and prev_pdf > 0.0:
                # A light at infinity's sampler could have given this direction too: weigh the two ways.
                w = 1.0 / (1.0 + (light / prev_pdf) ** 2)
                bg = (bg[0] * w, bg[1] * w, bg[2] * w)
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
            if nee and prev_pdf > 0.0:
                # The light sampler could have found this point too: weigh the two ways.
                light = pdf_li(S, light_of_hit(S, inst, prim), prev_p, p, n, time)
                w = 1.0 / (1.0 + (light / prev_pdf) ** 2)
                e = (e[0] * w, e[1] * w, e[2] * w)
            r += tr * e[0]
            g += tg * e[1]
            b += tb * e[2]
            break
        new_d = scatter(S.mat_i, S.mat_f, mat, d, n_front, front, key, bounce_dim(bounce, 0))
        if is_zero(new_d):
            break
        att = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, tex, u, v, p)
        # The shadow ray is the path's next segment: only where max_depth allows one more.
        if nee and bounce + 1 < max_depth and (kind == LAMBERTIAN or kind == ISOTROPIC):
            u0 = uniform(key, light_dim(bounce, 0))
            u1, u2 = uniform(key, light_dim(bounce, 1)), uniform(key, light_dim(bounce, 2))
            # u0 chooses a light among every kind, u1 and u2 a point on it (or a direction to it).
            ok, x, wi, reach, light, le = sample_li(S, p, time, u0, u1, u2)
            if kind == LAMBERTIAN:
                density = dot(wi, n_front) / math.pi  # the cosine lobe's, and the BRDF times the cosine
            else:
                density = 1.0 / (4.0 * math.pi)  # the isotropic phase function
            if ok and density > 0.0 and light > 0.0:
                origin = p if prim_kind == MEDIUM else spawn_origin(p, o, n_front, wi)
                rays += 1
                # A light at infinity is reached along wi; a point, by the segment to it, stopped short.
                if reach == math.inf:
                    toward = wi
                else:
                    toward, reach = sub(x, origin), 1.0 - SHADOW_MARGIN
                seen = transmittance(S, origin, toward, reach, time, stack, tstack)
                if seen > 0.0:
                    w = 1.0 / (1.0 + (density / light) ** 2)
                    k = seen * density * w / light
                    r += tr * att[0] * le[0] * k
                    g += tg * att[1] * le[1] * k
                    b += tb * att[2] * le[2] * k
        tr *= att[0]
        tg *= att[1]
        tb *= att[2]
        if tr == 0.0 and tg == 0.0 and tb == 0.0:
            break
        if mis:
            if kind == LAMBERTIAN:
                prev_pdf = max(0.0, dot(unit(new_d), n_front)) / math.pi
            elif kind == ISOTROPIC:
                prev_pdf = 1.0 / (4.0 * math.pi)
            else:
                prev_pdf = 0.0
            prev_p = p
            if bounce >= ROULETTE_AFTER:
                # Continue with probability of the path's largest throughput, and weigh it up by
                # the same: unbiased, and a path that carries little stops early.
                q = max(tr, tg, tb)
                if q < 1.0:
                    if uniform(key, light_dim(bounce, 3)) >= q:
                        break
                    tr /= q
                    tg /= q
                    tb /= q
        if MEDIA and prim_kind == MEDIUM:
            o = p
        else:
            o = spawn_origin(p, o, n_front, new_d)
        d = new_d
    return r, g, b, rays


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def add_pixel_samples(S, i, j, width, seed, sample_start, sample_count, max_depth, integrator, total, total_sq, row, col,
                      stack, tstack):
    """Add the samples sample_start.. of pixel (i, j) into total[row, col] and total_sq[row, col]
    (the film's own pixel, or a tile's); the rays cast and the samples left out as not finite.
    Each pixel's sums grow in sample order wherever they are kept, so a tile of the image adds
    up to the same bits as the whole image."""
    pixel = j * width + i
    rays = 0
    bad = 0
    for s in range(sample_start, sample_start + sample_count):
        key = path_key(seed, pixel, s)
        o, d, time = camera_ray(S.camera, i, j, key)
        r, g, b, n = trace(S, key, o, d, time, max_depth, integrator, stack, tstack)
        rays += n
        if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
            bad += 1  # counted and reported, never added to the image
            continue
        total[row, col, 0] += r
        total[row, col, 1] += g
        total[row, col, 2] += b
        total_sq[row, col, 0] += r * r
        total_sq[row, col, 1] += g * g
        total_sq[row, col, 2] += b * b
    return rays, bad


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
def render_pass(S, width, height, seed, sample_start, sample_count, max_depth, integrator, total, total_sq, row_rays, row_bad,
                band_start, band_stop):
    """Add `sample_count` samples per pixel, numbered from `sample_start`, into the film sums,
    with the estimator `integrator` (flat.INTEGRATOR_PATH or INTEGRATOR_MIS), for the rows at
    positions band_start..band_stop of the pass's row order (`row_stride`); 0..height is the
    whole image. A long pass is rendered as several such bands, so that a render can stop
    between them; each pixel's sums are the same however the rows are banded."""
    stride = row_stride(height)
    for m in prange(band_stop - band_start):
        j = ((band_start + m) * stride) % height
        stack = (np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64))
        tstack = np.empty((BVH_STACK, 2))
        rays = 0
        bad = 0
        for i in range(width):
            n, nbad = add_pixel_samples(S, i, j, width, seed, sample_start, sample_count, max_depth, integrator,
                                        total, total_sq, j, i, stack, tstack)
            rays += n
            bad += nbad
        row_rays[j] += rays
        row_bad[j] += bad
