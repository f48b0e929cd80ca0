"""The path tracer: one path per (pixel, sample), and the parallel pass over the image."""

import math

import numpy as np

from .. import target
from ..camera import camera_ray_at
from ..flat import INTEGRATOR_CAUSTICS, INTEGRATOR_GUIDED, INTEGRATOR_MIS
from ..guide_records import RECORDS_PER_PATH, add_to_records, no_records, open_record
from ..guiding import guide_leaf, pdf_guide, sample_guide
from ..kernel_flags import CAUSTICS, GUIDING, SURFACE_MAPS
from ..lights import bsdf_weight, light_of_hit, lights_to_sample, pdf_li, radiance_escaped, sample_li
from ..materials import (MICROFACETS, NO_TANGENT, emits, is_anisotropic, emitted_at, eval_bsdf, has_density, has_shading_map, is_zero, material_at,
                         pdf_bsdf, reads_uv, same_side, sample_bsdf, scatters, shading_frame)
from ..adaptive import pixel_converged
from ..config import BATCHES
from ..film_sums import add_sample
from ..numerics.rng import bounce_dim, guide_dim, light_dim, sample_key, uniform
from ..numerics.vec import dot, neg, sub, unit
from ..shapes.dispatch import hit_material, is_volume, spawn_origin, world_derivatives, world_interaction
from .shadow import shadow_transmittance
from .traverse import intersect_scene, traversal_scratch

# The photons' shares of a render that has none (every integrator but caustics).
NO_SPLATS = np.zeros((0, 0, 3))
# Russian roulette starts after this many bounces: the first carry most of the light. Starting
# after 2 rather than 3 gave 8 to 12% more efficiency (1 / (error^2 x time)) on the light-sampled
# book scenes.
ROULETTE_AFTER = 2
# A shadow ray stops this fraction short of the point on the light, so the light itself (whose
# point is exact to a few ulps) never blocks it.
SHADOW_MARGIN = 1e-7
# With integrator guided, the share of bounces at a guided vertex drawn from the guide (the rest
# from the BSDF, which keeps every direction the BSDF reaches possible, whatever the guide learned).
GUIDE_SHARE = 0.5



@target.device
def shading_normal(S, mat, prim, inst, n, n_front, n_tree, front, maps, params, u, v, p, d, time):
    """The normal a material's lobe is built around and its tangent (NO_TANGENT for none): the
    surface's normal facing the ray, or the one a normal or bump map bends; an anisotropic lobe's
    tangent along dp/du. For the path tracer and every pass that follows its rays."""
    n_shade = n_front
    tangent = NO_TANGENT
    # SURFACE_MAPS first: a kernel compiled without it prunes these branches before typing them.
    if SURFACE_MAPS and maps:
        dpdu, dpdv = world_derivatives(S, prim, inst, n_tree, time)
        n_shade, tangent = shading_frame(S, mat, n, front, dpdu, dpdv, u, v, p, d)
    elif MICROFACETS and is_anisotropic(S.mat_i, mat, params):
        # An anisotropic lobe is laid along dp/du (brushed along u); shapes without a (u, v)
        # direction (a box, a sphere's pole) give none, and the lobe takes any frame.
        tangent, _ = world_derivatives(S, prim, inst, n_tree, time)
    return n_shade, tangent

@target.device
def trace(S, key, o, d, time, max_depth, integrator, stack, tstack, rec, rec_first):
    """Radiance along one camera path, and the number of rays it cast (shadow rays included).

    With INTEGRATOR_PATH this is the books' estimator: a path finds a light only by chance.
    With INTEGRATOR_MIS, every vertex whose material's lobe is not a delta (a diffuse surface,
    a scattering event in a medium) also samples a point on a light and casts a shadow ray to
    it (next-event estimation); that estimate and the path's own chance hit on a light are
    weighted by the power heuristic (multiple importance sampling), and paths past a few
    bounces end by Russian roulette.

    Materials answer through their interface (materials.py: `sample_bsdf`, `eval_bsdf`,
    `pdf_bsdf`, `emitted_at`, `scatters`), shapes through theirs (shapes/dispatch.py: `interaction`,
    `is_volume`) and lights through the light category (lights.py): `sample_li` chooses one of
    every kind and samples it, `pdf_li` and `radiance_escaped` give the density it would have
    had for a path that hits a light or escapes to one at infinity (an environment map). This
    loop names no kind of any of them.

    With INTEGRATOR_GUIDED (the `guiding` flag), this is `mis` whose bounce at a surface vertex
    with a density is drawn from the learned guide (guiding.py) with probability GUIDE_SHARE, else
    from the BSDF, and weighed by the mixture of the two densities (one-sample MIS with the
    balance heuristic): f cos / (share pdf_guide + (1 - share) pdf_bsdf); that mixture is also the
    density the light samples are weighed against. A delta lobe the BSDF drew (a plastic's
    mirror) counts as before, over its chance 1 - share. Where the guide has no leaf, the vertex
    is mis's. When `rec` has rows (a training pass, guide_records.py), the path opens a record at
    each of its first RECORDS_PER_PATH such vertices, rows rec_first.., and adds every later
    contribution into them.
    """
    r, g, b = 0.0, 0.0, 0.0
    tr, tg, tb = 1.0, 1.0, 1.0
    rays = 0
    guided = GUIDING and integrator == INTEGRATOR_GUIDED
    caustic = CAUSTICS and integrator == INTEGRATOR_CAUSTICS
    mis = integrator == INTEGRATOR_MIS or guided or caustic
    # integrator caustics leaves to its photons (tracing/caustics.py) the paths whose first hit is
    # matte (its bounce drew a lobe with a density; no map, not anisotropic) and whose every later
    # vertex, up to the light, is purely specular and unmapped, the last one a caustic target:
    # `chain` is 1 after such a first hit, 2 once specular vertices followed it, 0 otherwise.
    chain = 0
    last_target = False
    nee = mis and lights_to_sample(S)
    recording = GUIDING and rec.shape[0] > 0
    records = 0
    # The solid angle density with which the last vertex chose this ray's direction; 0 after
    # the camera and after a delta lobe (a mirror, glass), whose directions no light sampler can give.
    prev_pdf = 0.0
    prev_p = o
    # The normal a light tree weighs lights by at the last vertex: (0, 0, 0) for the camera and in a medium.
    prev_n = (0.0, 0.0, 0.0)
    for bounce in range(max_depth):
        rays += 1
        t, prim, inst = intersect_scene(
            S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
            S.tri_i, S.verts_f, o, d, 0.0, math.inf, time, key, bounce, stack, tstack,
        )
        if prim < 0:
            if caustic and chain == 2 and last_target and S.env_rgb.shape[0] > 0:
                break  # the map and the sun send photons along this path: theirs
            # Weighed against the light sampler where a light at infinity could have given d too.
            bg = radiance_escaped(S, prev_p, prev_n, d, prev_pdf)
            r += tr * bg[0]
            g += tg * bg[1]
            b += tb * bg[2]
            if recording and records > 0:
                add_to_records(rec, rec_first, records, tr * bg[0], tg * bg[1], tb * bg[2])
            break
        mat = hit_material(S.prims_i, prim)
        # A scattering event in a medium has no surface: its point is found on the world's ray.
        volume = is_volume(S.prims_i, prim)
        # A normal or bump map bends the normal the material sees (never the geometric one).
        maps = has_shading_map(S.mat_i, mat)
        # (u, v) only where the material's texture reads it (an image) or a map does: see surface().
        want_uv = reads_uv(S.mat_i, mat) or maps
        p, n, u, v, n_tree = world_interaction(S, prim, inst, o, d, t, time, want_uv, volume)
        # A volume event has no side: its stand-in normal counts as facing the ray.
        front = volume or dot(d, n) < 0.0
        n_front = n if front else neg(n)
        n_light = (0.0, 0.0, 0.0) if volume else n_front
        color, params = material_at(S, mat, u, v, p)
        tangent = NO_TANGENT
        if emits(S.mat_i, mat):
            # Unless the path is one integrator caustics' photons take (see `chain` above).
            if not (caustic and chain == 2 and last_target):
                e = emitted_at(S, mat, color, u, v, p, front)
                if nee and prev_pdf > 0.0:
                    # The light sampler could have found this point too: weigh the two ways.
                    light = pdf_li(S, light_of_hit(S, inst, prim), prev_p, prev_n, p, n, time)
                    w = bsdf_weight(prev_pdf, light)
                    e = (e[0] * w, e[1] * w, e[2] * w)
                r += tr * e[0]
                g += tg * e[1]
                b += tb * e[2]
                if recording and records > 0:
                    add_to_records(rec, rec_first, records, tr * e[0], tg * e[1], tb * e[2])
            # The books' lights absorb what reaches them (sample_bsdf would say so: direction
            # (0, 0, 0)); ending the path here rather than asking was 3% faster on the Cornell box.
            # An emitter that also scatters (a principled surface) goes on like any other.
            if not scatters(S.mat_i, mat):
                break
        # The normal the material's lobe is built around: the surface's, or the one a map bends
        # (materials/shading_normal.py). The surface's stays for the side of the hit and for
        # where the next ray starts.
        n_shade, tangent = shading_normal(S, mat, prim, inst, n, n_front, n_tree, front, maps, params, u, v, p, d, time)
        # Whether the vertex has a part with a density: asked only where light sampling, guiding or the
        # caustic split reads it (the books' path tracer never does).
        dense = mis and has_density(S.mat_i, mat, params)
        # The guide's leaf at a surface vertex with a density (-1: none, the vertex is mis's).
        leaf = guide_leaf(S.guide_f, S.guide_i, p) if guided and dense and not volume else -1
        from_guide = leaf >= 0 and uniform(key, guide_dim(bounce, 0)) < GUIDE_SHARE
        if from_guide:
            new_d, _ = sample_guide(S.guide_f, S.guide_i, leaf, uniform(key, guide_dim(bounce, 2)),
                                    uniform(key, guide_dim(bounce, 3)))
            att = (0.0, 0.0, 0.0)
            delta = False
        else:
            new_d, att, _, delta = sample_bsdf(S.mat_i, S.mat_f, mat, color, params, d, n_shade, tangent, front, key,
                                              bounce_dim(bounce, 0))
        # The density of the bounce's direction under the mixture (guided vertices, and every vertex
        # of a training pass, which records it); -1 where the mis branch below asks it as before.
        mixture = -1.0
        if guided and dense and not volume and (leaf >= 0 or recording) and not is_zero(new_d):
            if delta:
                # The BSDF's delta lobe, drawn with 1 - share of the BSDF's chance.
                if leaf >= 0:
                    att = (att[0] / (1.0 - GUIDE_SHARE), att[1] / (1.0 - GUIDE_SHARE), att[2] / (1.0 - GUIDE_SHARE))
            else:
                wd = unit(new_d)
                mixture = pdf_bsdf(S.mat_i, S.mat_f, mat, params, d, n_shade, tangent, front, wd)
                if leaf >= 0:
                    mixture = GUIDE_SHARE * pdf_guide(S.guide_f, S.guide_i, leaf, wd) + (1.0 - GUIDE_SHARE) * mixture
                    tint, f = eval_bsdf(S.mat_i, S.mat_f, mat, color, params, d, n_shade, tangent, front, wd)
                    k = f / mixture if mixture > 0.0 else 0.0
                    att = (tint[0] * k, tint[1] * k, tint[2] * k)
        if SURFACE_MAPS and maps and not is_zero(new_d) and not same_side(new_d, n_front, n_shade):
            # Reflected for the bent normal but through the surface (or the reverse): the path
            # ends after this vertex's light sample, and no light leaks through the surface.
            att = (0.0, 0.0, 0.0)
        # The shadow ray is the path's next segment: only where max_depth allows one more. It is
        # cast whatever the bounce drew, even when it drew nothing (a microfacet sample lost to
        # single scattering): the light estimate is an expectation over the light's samples
        # alone, and skipping it with the bounce made rough lobes 16-30% dark.
        if nee and bounce + 1 < max_depth and dense:
            u0 = uniform(key, light_dim(bounce, 0))
            u1, u2 = uniform(key, light_dim(bounce, 1)), uniform(key, light_dim(bounce, 2))
            # u0 chooses a light among every kind, u1 and u2 a point on it (or a direction to it).
            ok, x, wi, reach, light, le, delta_light = sample_li(S, p, n_light, time, u0, u1, u2)
            if ok and light > 0.0 and not (SURFACE_MAPS and maps and not same_side(wi, n_front, n_shade)):
                tint, f = eval_bsdf(S.mat_i, S.mat_f, mat, color, params, d, n_shade, tangent, front, wi)
            else:
                tint, f = (0.0, 0.0, 0.0), 0.0
            if f > 0.0:
                density = pdf_bsdf(S.mat_i, S.mat_f, mat, params, d, n_shade, tangent, front, wi)
                if leaf >= 0:
                    density = GUIDE_SHARE * pdf_guide(S.guide_f, S.guide_i, leaf, wi) + (1.0 - GUIDE_SHARE) * density
                origin = p if volume else spawn_origin(p, o, n_front, wi)
                rays += 1
                # A light at infinity is reached along wi; a point, by the segment to it, stopped short.
                if reach == math.inf:
                    toward = wi
                else:
                    toward, reach = sub(x, origin), 1.0 - SHADOW_MARGIN
                seen = shadow_transmittance(S, origin, toward, reach, time, stack, tstack, key, bounce)
                if seen > 0.0:
                    # A delta light (a point, parallel light) is never met by chance: its sample counts in full.
                    w = 1.0 if delta_light else 1.0 / (1.0 + (density / light) ** 2)
                    k = seen * f * w / light
                    r += tr * tint[0] * le[0] * k
                    g += tg * tint[1] * le[1] * k
                    b += tb * tint[2] * le[2] * k
                    if recording and records > 0:
                        add_to_records(rec, rec_first, records, tr * tint[0] * le[0] * k, tg * tint[1] * le[1] * k,
                                       tb * tint[2] * le[2] * k)
        if caustic:
            if bounce == 0:
                chain = 1 if (not volume and dense and not delta and not maps and not is_zero(new_d)
                              and not is_anisotropic(S.mat_i, mat, params)) else 0
            elif chain > 0:
                if volume or dense or maps or S.caustic_mat[mat] == 0:
                    chain = 0
                else:
                    chain = 2
                    last_target = S.caustic_prim[prim] == 1
        if is_zero(new_d):
            break
        tr *= att[0]
        tg *= att[1]
        tb *= att[2]
        if tr == 0.0 and tg == 0.0 and tb == 0.0:
            break
        if mis:
            # The density of the direction just sampled, asked here rather than taken from
            # sample_bsdf: kept alive across the shadow ray, that value cost 5% on the Cornell box.
            if delta:
                prev_pdf = 0.0
            elif mixture >= 0.0:
                prev_pdf = mixture
            else:
                prev_pdf = pdf_bsdf(S.mat_i, S.mat_f, mat, params, d, n_shade, tangent, front, unit(new_d))
            prev_p = p
            prev_n = n_light
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
        if recording and records < RECORDS_PER_PATH and mixture > 0.0:
            # After the roulette: the throughput later contributions carry.
            open_record(rec, rec_first + records, p, unit(new_d), mixture, tr, tg, tb)
            records += 1
        if volume:
            o = p
        else:
            o = spawn_origin(p, o, n_front, new_d)
        d = new_d
    return r, g, b, rays


@target.device
def add_pixel_samples(S, i, j, width, seed, sample_start, sample_count, max_depth, integrator, sampling, sums, row, col,
                      stack, tstack, rec, rec_row, splats):
    """Add the samples sample_start.. of pixel (i, j) into the sums at [row, col] of `sums`
    (film.PixelSums: the film's own pixel, or a tile's); the rays cast and the samples left out
    as not finite. Each pixel's sums grow in sample order wherever they are kept, so a tile of
    the image adds up to the same bits as the whole image.

    A pixel that adaptive sampling has stopped (`done`) takes no samples; at the end of each
    round of BATCHES samples, `adaptive.pixel_converged` may stop it. The rule reads only the
    pixel's own sums, so where a pass or a tile ends never changes the image."""
    if sums.done[row, col] != 0:
        return 0, 0
    pixel = j * width + i
    rays = 0
    bad = 0
    adaptive = sampling.threshold > 0.0
    for s in range(sample_start, sample_start + sample_count):
        key = sample_key(seed, pixel, s, sampling.sampler)
        o, d, time = camera_ray_at(S.camera, S.motion_f, i, j, key)
        # A training pass's records of this path (guide_records.py): RECORDS_PER_PATH rows from
        # rec_row on for the pixel's first sample; rec is empty in a render.
        r, g, b, n = trace(S, key, o, d, time, max_depth, integrator, stack, tstack, rec,
                           rec_row + (s - sample_start) * RECORDS_PER_PATH)
        if splats.shape[0] > 0:
            # integrator caustics: this sample's photons' share of the pixel (tracing/caustics.py).
            r += splats[s - sample_start, pixel, 0]
            g += splats[s - sample_start, pixel, 1]
            b += splats[s - sample_start, pixel, 2]
        rays += n
        sums.counts[row, col] = s + 1
        if math.isfinite(r) and math.isfinite(g) and math.isfinite(b):
            add_sample(sums, row, col, s % BATCHES, r, g, b)
        else:
            bad += 1  # counted and reported, never added to the image
        if adaptive and (s + 1) % BATCHES == 0 and s + 1 >= sampling.floor:
            if pixel_converged(sums, row, col, s + 1, sampling):
                sums.done[row, col] = 1
                break
    return rays, bad


@target.kernel
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


def render_pass(S, width, height, seed, sample_start, sample_count, max_depth, integrator, sampling, sums, row_rays, row_bad,
                band_start, band_stop, rec=None, splats=None):
    """Add `sample_count` samples per pixel, numbered from `sample_start`, into the film sums
    (film.PixelSums), with the estimator `integrator` (flat.INTEGRATOR_PATH or INTEGRATOR_MIS)
    and the sampler and stopping rule of `sampling` (sampling.Sampling), for the rows at
    positions band_start..band_stop of the pass's row order (`row_stride`); 0..height is the
    whole image. A long pass is rendered as several such bands, so that a render can stop
    between them; each pixel's sums are the same however the rows are banded.

    `rec`, for the guide's training only (guide_training.py): records of every path, those of
    sample s of pixel i of the band's m-th row from row ((m * width + i) * sample_count + s -
    sample_start) * RECORDS_PER_PATH on; None in a render. `splats`, for integrator caustics:
    (sample_count, width * height, 3), each sample's photons' share of each pixel
    (caustics.caustic_splats), added to the pixel's sample; None otherwise.

    Allocates each render thread's traversal stacks and launches `render_band` on them."""
    scratch = traversal_scratch(target.thread_count())
    target.launch(render_band, S, width, height, seed, sample_start, sample_count, max_depth, integrator, sampling, sums,
                  row_rays, row_bad, band_start, band_stop, scratch, no_records() if rec is None else rec,
                  NO_SPLATS if splats is None else splats)


@target.parallel_kernel
def render_band(S, width, height, seed, sample_start, sample_count, max_depth, integrator, sampling, sums, row_rays, row_bad,
                band_start, band_stop, scratch, rec, splats):
    """`render_pass` on threads: thread k traverses with row k of `scratch`
    (traverse.traversal_scratch), so the parallel loop allocates nothing; `rec` is empty (a
    render records nothing for the guide)."""
    stride = row_stride(height)
    stacks_t, stacks_i, deferred, tstacks = scratch
    for m in target.prange(band_stop - band_start):
        j = ((band_start + m) * stride) % height
        thread = target.thread_index()
        stack = (stacks_t[thread], stacks_i[thread], deferred[thread])
        tstack = tstacks[thread]
        rays = 0
        bad = 0
        for i in range(width):
            n, nbad = add_pixel_samples(S, i, j, width, seed, sample_start, sample_count, max_depth, integrator,
                                        sampling, sums, j, i, stack, tstack, rec,
                                        (m * width + i) * sample_count * RECORDS_PER_PATH, splats)
            rays += n
            bad += nbad
        row_rays[j] += rays
        row_bad[j] += bad
