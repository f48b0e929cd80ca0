"""Auxiliary passes: albedo, shading normal and depth per pixel, from camera rays of their own.

These are the feature images a denoiser such as Intel Open Image Denoise (OIDN) reads beside a
noisy render, and the passes compositing reads. They are defined as OIDN's documentation
defines its `albedo` and `normal` inputs, and traced by this kernel alone: the beauty render is
never touched, so asking for passes changes no pixel of the image.

Per camera sample (a jittered ray through the pixel, as the beauty render's), the ray is
followed through perfect specular vertices (materials without a density: a mirror, the books'
glass, a smooth conductor), each drawing its lobe as the path tracer would (glass reflects with
the Fresnel probability, else refracts), up to MAX_SPECULAR of them, to the first vertex whose
material has a density (a lambertian surface, a rough lobe, a medium's scattering). There:

- albedo: the material's colour there (`materials.material_at`: a lambertian's albedo, a
  principled material's base colour, a conductor's tint), each channel clamped to [0, 1],
  times the weights of the specular lobes passed on the way (each clamped to [0, 1]: the
  books' glass weighs 1, a metal its tint). Averaged over the samples this is OIDN's
  "Fresnel blend of the reflected and transmitted albedos". A light that only emits (the
  books' diffuse light) gives its radiance clamped to [0, 1]; a ray that escapes gives 0.
- normal: the unit shading normal there (normal and bump maps applied), in world space, on the
  side the ray arrived from; 0 for a ray that escapes and for a scattering event in a medium
  (which has no surface). The pixel holds the mean of its samples' unit normals, so its length
  is at most 1 (less along silhouettes), as OIDN asks ("accumulating the normalized normals").
- depth: the distance from the lens along the camera's view axis to the FIRST hit (not the one
  past a mirror), averaged over the samples that hit anything; 0 where none did (never inf).

Every value is finite: a sample whose values are not is left out as if it had escaped.
"""

import math

import numpy as np

from .. import target
from ..camera import CAM_DU, CAM_DV, CAM_FIRST_KEY, CAM_KEYS, CAM_ORIGIN, CAM_PIXEL00, camera_ray_at
from ..kernel_flags import EMITTERS, MOTION
from ..materials import (emits, emitted_at, has_density, has_shading_map, is_zero, material_at, reads_uv, sample_bsdf,
                         scatters)
from ..numerics.rng import bounce_dim, sample_key
from ..numerics.vec import dot, neg, sub
from ..sampling import SAMPLER_INDEPENDENT
from ..motion import map_point, map_vector, maps_at
from ..shapes.dispatch import hit_material, is_volume, spawn_origin, world_interaction
from .integrator import shading_normal
from .traverse import intersect_scene, traversal_scratch

# The most perfect specular vertices a sample follows before it takes the albedo and normal of
# the last one it met (a ray caught between two mirrors). OIDN needs the first non-specular
# hit only where one is near; eight covers a glass ball (two refractions) with room to spare.
MAX_SPECULAR = 8
# The passes render_aux returns, in the order the front ends list them.
AUX_PASSES = ("albedo", "normal", "depth")


@target.device
def clamp01(c):
    return (min(max(c[0], 0.0), 1.0), min(max(c[1], 0.0), 1.0), min(max(c[2], 0.0), 1.0))


@target.device
def view_axis(cam):
    """The camera's unit view axis (towards the scene): the normal of the focus plane, on which
    the pixels lie, pointing away from the lens. (0, 0, 0) for a degenerate camera."""
    du = (cam[CAM_DU], cam[CAM_DU + 1], cam[CAM_DU + 2])
    dv = (cam[CAM_DV], cam[CAM_DV + 1], cam[CAM_DV + 2])
    n = (du[1] * dv[2] - du[2] * dv[1], du[2] * dv[0] - du[0] * dv[2], du[0] * dv[1] - du[1] * dv[0])
    length = math.sqrt(dot(n, n))
    if not length > 0.0:
        return (0.0, 0.0, 0.0)
    n = (n[0] / length, n[1] / length, n[2] / length)
    towards = sub((cam[CAM_PIXEL00], cam[CAM_PIXEL00 + 1], cam[CAM_PIXEL00 + 2]),
                  (cam[CAM_ORIGIN], cam[CAM_ORIGIN + 1], cam[CAM_ORIGIN + 2]))
    return n if dot(n, towards) >= 0.0 else neg(n)


@target.device
def aux_sample(S, key, o, d, time, axis, stack, tstack):
    """One camera ray's (hit, depth, albedo, normal) as the module's docstring defines them:
    `hit` whether the first ray met anything, `depth` the first hit's distance along `axis`
    from the lens centre (0 on a miss)."""
    zero = (0.0, 0.0, 0.0)
    lens = (S.camera[CAM_ORIGIN], S.camera[CAM_ORIGIN + 1], S.camera[CAM_ORIGIN + 2])
    if MOTION and S.camera[CAM_KEYS] > 0.0:
        # A moving camera's lens and axis are in its own space: placed where it is at this time.
        world, _ = maps_at(S.motion_f, int(S.camera[CAM_FIRST_KEY]), int(S.camera[CAM_KEYS]), time)
        lens, axis = map_point(world, lens), map_vector(world, axis)
    tr = (1.0, 1.0, 1.0)
    hit = False
    depth = 0.0
    for bounce in range(MAX_SPECULAR + 1):
        t, prim, inst = intersect_scene(
            S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f, S.bnd_i, S.bnd_f,
            S.tri_i, S.verts_f, o, d, 0.0, math.inf, time, key, bounce, stack, tstack,
        )
        if prim < 0:
            return hit, depth, zero, zero
        mat = hit_material(S.prims_i, prim)
        volume = is_volume(S.prims_i, prim)
        maps = has_shading_map(S.mat_i, mat)
        want_uv = reads_uv(S.mat_i, mat) or maps
        # The surface in world space, as the path tracer finds it (tracing/integrator.trace).
        p, n, u, v, n_tree = world_interaction(S, prim, inst, o, d, t, time, want_uv, volume)
        if bounce == 0:
            hit = True
            depth = dot(sub(p, lens), axis)
        color, params = material_at(S, mat, u, v, p)
        if volume:
            # A medium's scattering event: its albedo, and no surface to give a normal.
            c = clamp01(color)
            return hit, depth, (tr[0] * c[0], tr[1] * c[1], tr[2] * c[2]), zero
        front = dot(d, n) < 0.0
        n_front = n if front else neg(n)
        if EMITTERS and emits(S.mat_i, mat) and not scatters(S.mat_i, mat):
            # A light that only emits: what it shows, clamped, stands for its colour.
            c = clamp01(emitted_at(S, mat, color, u, v, p, front))
            return hit, depth, (tr[0] * c[0], tr[1] * c[1], tr[2] * c[2]), n_front
        n_shade, tangent = shading_normal(S, mat, prim, inst, n, n_front, n_tree, front, maps, params, u, v, p, d, time)
        c = clamp01(color)
        if has_density(S.mat_i, mat, params) or bounce == MAX_SPECULAR:
            return hit, depth, (tr[0] * c[0], tr[1] * c[1], tr[2] * c[2]), n_shade
        # A perfect specular vertex: follow the lobe the material draws, weighed by its weight.
        new_d, att, _, _ = sample_bsdf(S.mat_i, S.mat_f, mat, color, params, d, n_shade, tangent, front, key,
                                       bounce_dim(bounce, 0))
        if is_zero(new_d):
            return hit, depth, (tr[0] * c[0], tr[1] * c[1], tr[2] * c[2]), n_shade
        w = clamp01(att)
        tr = (tr[0] * w[0], tr[1] * w[1], tr[2] * w[2])
        o = spawn_origin(p, o, n_front, new_d)
        d = new_d
    return hit, depth, zero, zero


@target.parallel_kernel
def aux_rows(S, width, height, samples, seed, albedo, normal, depth, scratch):
    """`render_aux`'s passes on threads, a row per iteration: thread k traverses with row k of
    `scratch` (traverse.traversal_scratch). Each pixel's sums are its own, so the result does
    not depend on how rows are shared among threads."""
    stacks_t, stacks_i, deferred, tstacks = scratch
    axis = view_axis(S.camera)
    for j in target.prange(height):
        thread = target.thread_index()
        stack = (stacks_t[thread], stacks_i[thread], deferred[thread])
        tstack = tstacks[thread]
        for i in range(width):
            pixel = j * width + i
            ar, ag, ab = 0.0, 0.0, 0.0
            nx, ny, nz = 0.0, 0.0, 0.0
            z = 0.0
            hits = 0
            for s in range(samples):
                key = sample_key(seed, pixel, s, SAMPLER_INDEPENDENT)
                o, d, time = camera_ray_at(S.camera, S.motion_f, i, j, key)
                hit, zs, a, n = aux_sample(S, key, o, d, time, axis, stack, tstack)
                if not (math.isfinite(zs) and math.isfinite(a[0]) and math.isfinite(a[1]) and math.isfinite(a[2])
                        and math.isfinite(n[0]) and math.isfinite(n[1]) and math.isfinite(n[2])):
                    continue  # left out, as a ray that escaped
                ar += a[0]
                ag += a[1]
                ab += a[2]
                nx += n[0]
                ny += n[1]
                nz += n[2]
                if hit:
                    z += zs
                    hits += 1
            albedo[j, i, 0] = ar / samples
            albedo[j, i, 1] = ag / samples
            albedo[j, i, 2] = ab / samples
            normal[j, i, 0] = nx / samples
            normal[j, i, 1] = ny / samples
            normal[j, i, 2] = nz / samples
            depth[j, i] = z / hits if hits > 0 else 0.0


def render_aux(flat, width: int, height: int, *, samples: int = 16, seed: int = 0) -> dict:
    """The auxiliary passes of a flat scene (renderer.compile.compile_scene) at width x height:
    {"albedo": (H, W, 3), "normal": (H, W, 3), "depth": (H, W)}, float32, finite, as the module's
    docstring defines them, each pixel the mean of `samples` jittered camera rays of its own
    (seeded by `seed`; independent of the beauty render, which this never touches). The kernel
    is compiled on the first call (then loaded from the disk cache)."""
    width, height, samples, seed = int(width), int(height), int(samples), int(seed)
    if width < 1 or height < 1:
        raise ValueError(f"the passes need an image of at least 1 x 1 pixels, not {width} x {height}")
    if samples < 1:
        raise ValueError(f"the passes need at least 1 sample per pixel, not {samples}")
    if seed < 0:
        raise ValueError(f"the passes' seed must be 0 or more, not {seed}")
    albedo = np.zeros((height, width, 3), np.float32)
    normal = np.zeros((height, width, 3), np.float32)
    depth = np.zeros((height, width), np.float32)
    scratch = traversal_scratch(target.thread_count())
    target.launch(aux_rows, flat, width, height, samples, seed, albedo, normal, depth, scratch)
    # float32 may round a huge depth to inf: keep the promise of finite values.
    np.nan_to_num(depth, copy=False, nan=0.0, posinf=np.finfo(np.float32).max, neginf=0.0)
    return {"albedo": albedo, "normal": normal, "depth": depth}
