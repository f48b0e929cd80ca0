"""Light tracing of caustic paths (integrator caustics): photons from the lights, through
specular targets, onto a matte surface the camera sees.

The split (caustic_targets.py): a path L S+ D E whose specular vertices are purely specular,
none with a normal or bump map, whose first vertex after the light is a caustic target and
whose matte vertex D the camera sees directly (its material neither mapped nor anisotropic) is
this module's; the path tracer leaves out exactly those (`trace`, integrator CAUSTICS), and
renders everything else as mis does. The photon's matte vertex is joined to a point of the
camera's lens by a shadow ray, and its value lands in the pixel that point shows:
beta x f cos x K / |x - l|^2 (camera.camera_importance gives K).

A pass of samples s0..s0 + n - 1 traces `photons` (a quarter of the image's pixels,
PHOTONS_PER_PIXEL) photons for each sample s; photon k of sample s is keyed by (seed, k, s), so each has its own random numbers wherever it
runs. `trace_photons` writes one value per photon (its pixel, or -1, and its colour) and
`splat_photons` adds them up in photon order, divided by `photons`: the same bits on any number
of threads. Sample s of a pixel is the path tracer's sample plus that pixel's share of sample s's
photons, so the film's samples stay independent and identically distributed, and its batches and
error estimate hold as they are.
"""

import math

import numpy as np

from .. import target
from ..camera import CAM_CLOSE, CAM_OPEN, camera_importance
from ..kernel_flags import MOTION
from ..light_emission import emit_photon
from ..materials import (DIELECTRIC, MAT_IOR, MAT_KIND, NO_TANGENT, emits, eval_bsdf, has_density, has_shading_map, is_anisotropic, is_zero,
                         material_at, sample_bsdf, scatters)
from ..numerics.rng import DIM_TIME, bounce_dim, light_dim, path_key, uniform
from ..numerics.vec import dot, neg, sub, unit
from ..shapes.dispatch import hit_material, is_volume, spawn_origin, world_interaction
from .integrator import SHADOW_MARGIN
from .shadow import shadow_transmittance
from .traverse import intersect_scene, traversal_scratch

# Photon keys are made from the render's seed mixed with this, so they share no random numbers
# with the camera's paths.
PHOTON_SALT = 0x5C0FFEE5EED5A17
# Photons traced per pixel per sample (a pass of n samples traces n x pixels x this). Measured with
# benchmarks/caustics.py's renders (48 px, 4 and 16 s, time to a 2% true error, one run): against 1
# photon per pixel, a quarter took 0.40 to 0.62 of the time on caustic_glass's and sky_spheres' matte
# pixels and 0.36 to 0.87 on all unlit ones (a photon costs about what a path does, and most paths
# are no caustic's); a sixteenth was within the runs' noise of a quarter on the matte pixels.
PHOTONS_PER_PIXEL = 0.25


@target.device
def trace_photon(S, key, width, height, max_depth, stack, tstack):
    """One photon: (pixel index or -1, its colour in that pixel before the division by the
    photon count)."""
    cam = S.camera
    time = cam[CAM_OPEN]
    if MOTION:
        time += uniform(key, DIM_TIME) * (cam[CAM_CLOSE] - cam[CAM_OPEN])
    ok, o, d, beta = emit_photon(S, time, uniform(key, 5), uniform(key, 6), uniform(key, 7), uniform(key, light_dim(0, 0)),
                                 uniform(key, light_dim(0, 1)), uniform(key, light_dim(0, 2)))
    if not ok:
        return -1, 0.0, 0.0, 0.0
    br, bg, bb = beta
    specular = 0
    for bounce in range(max_depth):
        t, prim, inst = intersect_scene(
            S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
            S.tri_i, S.verts_f, o, d, 0.0, math.inf, time, key, bounce, stack, tstack,
        )
        if prim < 0 or is_volume(S.prims_i, prim):
            return -1, 0.0, 0.0, 0.0
        if specular == 0 and S.caustic_prim[prim] == 0:
            return -1, 0.0, 0.0, 0.0  # not aimed well enough: the path tracer's path
        mat = hit_material(S.prims_i, prim)
        p, n, u, v, _ = world_interaction(S, prim, inst, o, d, t, time, False, False)
        if emits(S.mat_i, mat) and not scatters(S.mat_i, mat):
            return -1, 0.0, 0.0, 0.0
        if has_shading_map(S.mat_i, mat):
            return -1, 0.0, 0.0, 0.0  # the path tracer keeps every path through a mapped surface
        front = dot(d, n) < 0.0
        n_front = n if front else neg(n)
        color, params = material_at(S, mat, u, v, p)
        if has_density(S.mat_i, mat, params):
            # The matte vertex: the path tracer's first hit. Its path has specular + 2 vertices
            # after the camera's, which max_depth must allow, as the path tracer's loop does.
            if specular == 0 or specular + 2 > max_depth or is_anisotropic(S.mat_i, mat, params):
                return -1, 0.0, 0.0, 0.0
            seen_ok, i, j, lens, k = camera_importance(cam, width, height, p, key)
            if not seen_ok:
                return -1, 0.0, 0.0, 0.0
            to = sub(lens, p)
            dist2 = dot(to, to)
            if not dist2 > 0.0:
                return -1, 0.0, 0.0, 0.0
            wi = unit(to)
            # f cos towards the lens (f is reciprocal: the photon's way reversed is the camera's).
            tint, f = eval_bsdf(S.mat_i, S.mat_f, mat, color, params, d, n_front, NO_TANGENT, front, wi)
            if not f > 0.0:
                return -1, 0.0, 0.0, 0.0
            origin = spawn_origin(p, o, n_front, wi)
            seen = shadow_transmittance(S, origin, sub(lens, origin), 1.0 - SHADOW_MARGIN, time, stack, tstack, key, bounce)
            if not seen > 0.0:
                return -1, 0.0, 0.0, 0.0
            c = seen * f * k / dist2
            return j * width + i, br * tint[0] * c, bg * tint[1] * c, bb * tint[2] * c
        if S.caustic_mat[mat] == 0:
            return -1, 0.0, 0.0, 0.0  # a specular material photons do not pass: the path tracer's path
        specular += 1
        new_d, att, _, delta = sample_bsdf(S.mat_i, S.mat_f, mat, color, params, d, n_front, NO_TANGENT, front, key,
                                          bounce_dim(bounce, 0))
        if is_zero(new_d):
            return -1, 0.0, 0.0, 0.0
        k = 1.0
        if S.mat_i[mat, MAT_KIND] == DIELECTRIC and dot(new_d, n_front) < 0.0:
            # Refracted. A photon carries flux, and the solid angle it fills is squeezed by (n_from /
            # n_to)^2 as it crosses: the radiance it implies beyond is scaled by that. Our glass, as
            # the books', passes radiance unscaled (a path computes T L), so the photon carries
            # (n_from / n_to)^2 its flux to match: the factors cancel on a path into and out of the
            # glass, and a lamp inside a glass ball shows as bright as the path tracer renders it.
            ior = S.mat_f[mat, MAT_IOR]
            k = 1.0 / (ior * ior) if front else ior * ior
        br *= att[0] * k
        bg *= att[1] * k
        bb *= att[2] * k
        if br == 0.0 and bg == 0.0 and bb == 0.0:
            return -1, 0.0, 0.0, 0.0
        o = spawn_origin(p, o, n_front, new_d)
        d = new_d
    return -1, 0.0, 0.0, 0.0


@target.parallel_kernel
def trace_photon_band(S, width, height, seed, sample_start, sample_count, photons, max_depth, pixel, rgb, scratch):
    """Photon k of sample sample_start + s into row s * photons + k of `pixel` and `rgb`."""
    stacks_t, stacks_i, deferred, tstacks = scratch
    salted = seed ^ PHOTON_SALT
    for m in target.prange(sample_count * photons):
        thread = target.thread_index()
        stack = (stacks_t[thread], stacks_i[thread], deferred[thread])
        s = sample_start + m // photons
        k = m % photons
        key = path_key(salted, k, s)
        q, r, g, b = trace_photon(S, key, width, height, max_depth, stack, tstacks[thread])
        if not (math.isfinite(r) and math.isfinite(g) and math.isfinite(b)):
            q = -1  # never a NaN or an inf into a pixel
        pixel[m] = q
        rgb[m, 0] = r
        rgb[m, 1] = g
        rgb[m, 2] = b


def caustic_splats(S, width, height, seed, sample_start, sample_count, max_depth) -> np.ndarray:
    """(sample_count, height * width, 3): each sample's photons' share of each pixel."""
    photons = max(1, int(round(width * height * PHOTONS_PER_PIXEL)))
    total = sample_count * photons
    pixel = np.empty(total, np.int64)
    rgb = np.empty((total, 3), np.float64)
    scratch = traversal_scratch(target.thread_count())
    target.launch(trace_photon_band, S, width, height, seed, sample_start, sample_count, photons, max_depth, pixel, rgb,
                  scratch)
    return splat_photons(pixel, rgb, sample_count, photons, width * height)


def splat_photons(pixel, rgb, sample_count, photons, pixels) -> np.ndarray:
    """The photons' values added into their pixels, in photon order (np.add.at is sequential, so
    the sums do not depend on threads), each sample's divided by its photon count."""
    out = np.zeros((sample_count, pixels, 3), np.float64)
    hit = pixel >= 0
    m = np.flatnonzero(hit)
    if len(m):
        s = m // photons
        np.add.at(out, (s, pixel[m]), rgb[m])
    out /= photons
    return out
