"""Small compiled wrappers that run the renderer's own kernel routines many times, for tests;
declared through renderer/target.py, so that their cached code is kept with the renderer's and
is compiled again whenever a renderer source changes.

The kernels are inlined into the render loop; these loops call the very same functions with
the renderer's counter-based random numbers (keys from `path_key`), so a test sees exactly the
draws a render makes.
"""

import math

import numpy as np
from renderer import target

from renderer.camera import camera_ray
from renderer.config import BVH_STACK, BVH_WIDE_STACK, MEDIA_DEFERRED
from renderer.tracing.shadow import transmittance
from renderer.tracing.traverse import intersect_scene
from renderer.trees import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT
from renderer.numerics.vec import unit, xform_normal, xform_point, xform_vector
from renderer.lights import (LIGHT_PRIMITIVE, light_of_hit, pdf_li, radiance_escaped, sample_li, sample_light_surface,
                             select_light, share_of)
from renderer.shapes.planar import rectangle_frame
from renderer.shapes.spheres import sample_cone
from renderer.shapes import PRIM_KIND
from renderer.shapes.dispatch import surface
from renderer.environment import environment_radiance, sample_environment
from renderer.numerics.rng import bounce_dim, independent_key, light_dim, path_key, uniform
from renderer.materials import (MATERIAL_F, MATERIAL_I, NO_PARAMETERS, NO_TANGENT, emits, emitted, eval_bsdf, has_density, pdf_bsdf,
                                random_unit_vector, sample_bsdf)
from renderer.media import medium_hit
from renderer.textures import texture_value


@target.kernel
def unit_vectors(seed, n, bounce):
    """n draws of `random_unit_vector` at bounce `bounce` of paths 0..n-1."""
    out = np.empty((n, 3))
    for k in range(n):
        v = random_unit_vector(path_key(seed, k, 0), bounce_dim(bounce, 0))
        out[k, 0], out[k, 1], out[k, 2] = v[0], v[1], v[2]
    return out


def scatter_many(kind, fuzz, ior, d, normal, front, seed, n, bounce):
    """n scattered directions of material `kind` for incoming d on a surface with unit normal `normal`."""
    mat_i = np.array([MATERIAL_I.row(kind=kind)], np.int32)
    mat_f = np.array([MATERIAL_F.row(fuzz=fuzz, ior=ior)], np.float64)
    return _scatter_many(mat_i, mat_f, np.asarray(d, np.float64), np.asarray(normal, np.float64), front, seed, n, bounce)


@target.kernel
def _scatter_many(mat_i, mat_f, d, normal, front, seed, n, bounce):
    out = np.empty((n, 3))
    for k in range(n):
        v = sample_bsdf(mat_i, mat_f, 0, (1.0, 1.0, 1.0), NO_PARAMETERS, (d[0], d[1], d[2]),
                        (normal[0], normal[1], normal[2]), NO_TANGENT, front, path_key(seed, k, 0), bounce_dim(bounce, 0))[0]
        out[k, 0], out[k, 1], out[k, 2] = v[0], v[1], v[2]
    return out


def material_rows(kind, fuzz=0.0, ior=1.0):
    """The (mat_i, mat_f) tables of one material of `kind` in row 0 (no emission texture: -1, as
    table.material_rows writes it for a material that sends no light)."""
    return (np.array([MATERIAL_I.row(kind=kind, emission=-1)], np.int32),
            np.array([MATERIAL_F.row(fuzz=fuzz, ior=ior)], np.float64))


@target.device
def _tuple8(a):
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7])


def bsdf_samples(mat_i, mat_f, color, d, n_front, front, seed, bounce, params=None, tangent=None):
    """`sample_bsdf` of material row 0 for each incoming direction d[k] on a surface with unit
    normal n_front[k] on the ray's side, paths 0..n-1: rows (direction 3, weight 3, pdf, delta,
    and for the direction's unit vector: `pdf_bsdf`, then `eval_bsdf`'s tint 3 and value).
    `params`: the row's eight parameter slots (zeros by default); `tangent`: one per direction
    (none by default)."""
    params = np.zeros(8) if params is None else np.asarray(params, np.float64)
    tangent = np.zeros_like(np.asarray(d, np.float64)) if tangent is None else np.asarray(tangent, np.float64)
    return _bsdf_samples(mat_i, mat_f, color, d, n_front, front, seed, bounce, params, tangent)


@target.kernel
def _bsdf_samples(mat_i, mat_f, color, d, n_front, front, seed, bounce, params, tangent):
    c = (color[0], color[1], color[2])
    pr = _tuple8(params)
    out = np.zeros((d.shape[0], 13))
    for k in range(d.shape[0]):
        dk = (d[k, 0], d[k, 1], d[k, 2])
        nk = (n_front[k, 0], n_front[k, 1], n_front[k, 2])
        tk = (tangent[k, 0], tangent[k, 1], tangent[k, 2])
        wi, weight, pdf, delta = sample_bsdf(mat_i, mat_f, 0, c, pr, dk, nk, tk, front, path_key(seed, k, 0),
                                             bounce_dim(bounce, 0))
        out[k, 0], out[k, 1], out[k, 2] = wi[0], wi[1], wi[2]
        out[k, 3], out[k, 4], out[k, 5] = weight[0], weight[1], weight[2]
        out[k, 6], out[k, 7] = pdf, 1.0 if delta else 0.0
        if wi[0] != 0.0 or wi[1] != 0.0 or wi[2] != 0.0:
            w = unit(wi)
            out[k, 8] = pdf_bsdf(mat_i, mat_f, 0, pr, dk, nk, tk, front, w)
            tint, value = eval_bsdf(mat_i, mat_f, 0, c, pr, dk, nk, tk, front, w)
            out[k, 9], out[k, 10], out[k, 11], out[k, 12] = tint[0], tint[1], tint[2], value
    return out


def bsdf_values(mat_i, mat_f, color, d, n_front, wi, params=None, tangent=None, front=True):
    """`eval_bsdf` and `pdf_bsdf` of material row 0 for each (d[k], n_front[k], wi[k]): rows
    (tint 3, value, pdf); `params` and `tangent` as for `bsdf_samples`."""
    params = np.zeros(8) if params is None else np.asarray(params, np.float64)
    tangent = np.zeros_like(np.asarray(d, np.float64)) if tangent is None else np.asarray(tangent, np.float64)
    return _bsdf_values(mat_i, mat_f, color, d, n_front, wi, params, tangent, front)


@target.kernel
def _bsdf_values(mat_i, mat_f, color, d, n_front, wi, params, tangent, front):
    c = (color[0], color[1], color[2])
    pr = _tuple8(params)
    out = np.zeros((d.shape[0], 5))
    for k in range(d.shape[0]):
        dk = (d[k, 0], d[k, 1], d[k, 2])
        nk = (n_front[k, 0], n_front[k, 1], n_front[k, 2])
        tk = (tangent[k, 0], tangent[k, 1], tangent[k, 2])
        wk = (wi[k, 0], wi[k, 1], wi[k, 2])
        tint, value = eval_bsdf(mat_i, mat_f, 0, c, pr, dk, nk, tk, front, wk)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = tint[0], tint[1], tint[2], value
        out[k, 4] = pdf_bsdf(mat_i, mat_f, 0, pr, dk, nk, tk, front, wk)
    return out


@target.kernel
def _has_density_of(mat_i, params):
    return has_density(mat_i, 0, _tuple8(params))


def has_density_of(mat_i, params):
    """`has_density` of material row 0 with these eight parameter slots."""
    return bool(_has_density_of(mat_i, np.asarray(params, np.float64)))


@target.kernel
def emission_of(mat_i, mat_f, color, front):
    """(`emits`, `emitted`) of material row 0 whose texture has colour `color` at the hit."""
    e = emitted(mat_i, mat_f, 0, (color[0], color[1], color[2]), front)
    return emits(mat_i, 0), np.array([e[0], e[1], e[2]])


@target.kernel
def camera_rays(cam, seed, n):
    """Origin, direction and time of n camera rays through pixel (0, 0)."""
    o = np.empty((n, 3))
    d = np.empty((n, 3))
    t = np.empty(n)
    for k in range(n):
        oo, dd, tt = camera_ray(cam, 0, 0, path_key(seed, 0, k))
        for q in range(3):
            o[k, q] = oo[q]
            d[k, q] = dd[q]
        t[k] = tt
    return o, d, t


@target.kernel
def medium_distances(prims_f, bnd_i, bnd_f, seed, n):
    """Scattering distance along +z from the origin in medium row 0 for n paths (inf: passed through)."""
    out = np.empty(n)
    for k in range(n):
        out[k] = medium_hit(prims_f, bnd_i, bnd_f, 0, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.0, math.inf, 0.0,
                            path_key(seed, k, 0), 0, 0)
    return out


@target.kernel
def texture_at(flat, tex, uv, points):
    """Colour of texture row `tex` at each (u, v) and point."""
    out = np.empty((points.shape[0], 3))
    for k in range(points.shape[0]):
        c = texture_value(flat.tex_i, flat.tex_f, flat.texels, flat.noise_perm, flat.noise_vec, tex,
                          uv[k, 0], uv[k, 1], (points[k, 0], points[k, 1], points[k, 2]))
        out[k, 0], out[k, 1], out[k, 2] = c[0], c[1], c[2]
    return out


# --- lights -----------------------------------------------------------------------------------



@target.kernel
def _stacks():
    return ((np.empty(BVH_WIDE_STACK), np.empty((BVH_WIDE_STACK, 2), np.int64), np.empty(MEDIA_DEFERRED, np.int64)),
            np.empty((BVH_STACK, 2)))


@target.kernel
def _hit(S, p, d, time, stack, tstack):
    """(prim, inst, point, unit normal) of the first surface along p + t d; prim -1 if none."""
    t, prim, inst = intersect_scene(S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f,
                                    S.bnd_i, S.bnd_f, S.tri_i, S.verts_f, p, d, 0.0, math.inf, time, independent_key(1), 0, stack, tstack)
    if prim < 0:
        return prim, inst, p, p
    kind = S.prims_i[prim, PRIM_KIND]
    if S.inst_i[inst, INST_UNTRANSFORMED] != 1:
        oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p)
        dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
        po, no, _, _ = surface(kind, S, prim, oo, dd, t, time, False)
        return prim, inst, xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, po), unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, no))
    x, n, _, _ = surface(kind, S, prim, p, d, t, time, False)
    return prim, inst, x, n


@target.kernel
def light_samples(S, p, time, seed, n):
    """n draws of `sample_li` from point p: rows (ok, direction 3, distance, pdf, emission 3,
    the pdf `pdf_li` gives the first surface along the direction, that surface's distance)."""
    out = np.zeros((n, 11))
    stack, tstack = _stacks()
    p = (p[0], p[1], p[2])
    for k in range(n):
        key = path_key(seed, k, 0)
        ok, x, wi, dist, pdf, le, _ = sample_li(S, p, (0.0, 0.0, 0.0), time, uniform(key, light_dim(0, 0)),
                                             uniform(key, light_dim(0, 1)), uniform(key, light_dim(0, 2)))
        out[k, 0] = 1.0 if ok else 0.0
        out[k, 1], out[k, 2], out[k, 3] = wi[0], wi[1], wi[2]
        out[k, 4], out[k, 5] = dist, pdf
        out[k, 6], out[k, 7], out[k, 8] = le[0], le[1], le[2]
        if ok:
            prim, inst, xh, nh = _hit(S, p, wi, time, stack, tstack)
            if prim >= 0:
                out[k, 9] = pdf_li(S, light_of_hit(S, inst, prim), p, (0.0, 0.0, 0.0), xh, nh, time)
                out[k, 10] = math.sqrt((xh[0] - p[0]) ** 2 + (xh[1] - p[1]) ** 2 + (xh[2] - p[2]) ** 2)
    return out


@target.kernel
def light_pdf_along(S, p, dirs, time):
    """The light sampler's solid angle density from p in each direction of `dirs` (0 where no light is met first)."""
    out = np.zeros(dirs.shape[0])
    stack, tstack = _stacks()
    p = (p[0], p[1], p[2])
    for k in range(dirs.shape[0]):
        d = (dirs[k, 0], dirs[k, 1], dirs[k, 2])
        prim, inst, xh, nh = _hit(S, p, d, time, stack, tstack)
        if prim >= 0:
            out[k] = pdf_li(S, light_of_hit(S, inst, prim), p, (0.0, 0.0, 0.0), xh, nh, time)
    return out


@target.kernel
def segment_transmittance(S, o, target, time):
    stack, tstack = _stacks()
    d = (target[0] - o[0], target[1] - o[1], target[2] - o[2])
    return transmittance(S, (o[0], o[1], o[2]), d, 1.0, time, stack, tstack)


# --- the environment map ----------------------------------------------------------------------


@target.kernel
def environment_samples(S, seed, n):
    """n draws of `sample_environment`: rows (ok, direction 3, pdf, radiance 3, the pdf and the
    first radiance channel `environment_radiance` gives the drawn direction)."""
    out = np.zeros((n, 10))
    for k in range(n):
        key = path_key(seed, k, 0)
        ok, d, pdf, le = sample_environment(S.background, S.env_rgb, S.env_row_f, S.env_texel_f,
                                            uniform(key, light_dim(0, 1)), uniform(key, light_dim(0, 2)))
        out[k, 0] = 1.0 if ok else 0.0
        out[k, 1], out[k, 2], out[k, 3], out[k, 4] = d[0], d[1], d[2], pdf
        out[k, 5], out[k, 6], out[k, 7] = le[0], le[1], le[2]
        if ok:
            back, back_pdf = environment_radiance(S.background, S.env_rgb, S.env_texel_f, d)
            out[k, 8], out[k, 9] = back_pdf, back[0]
    return out


@target.kernel
def environment_lookup(S, dirs):
    """Rows (radiance 3, solid angle density) of the map along each direction of `dirs`."""
    out = np.zeros((dirs.shape[0], 4))
    for k in range(dirs.shape[0]):
        le, pdf = environment_radiance(S.background, S.env_rgb, S.env_texel_f, (dirs[k, 0], dirs[k, 1], dirs[k, 2]))
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = le[0], le[1], le[2], pdf
    return out


@target.kernel
def ray_transmittance(S, o, d, tmax, time):
    """`transmittance` along o + t d for t in (0, tmax); tmax may be inf (a shadow ray to the environment)."""
    stack, tstack = _stacks()
    return transmittance(S, (o[0], o[1], o[2]), (d[0], d[1], d[2]), tmax, time, stack, tstack)


# --- the light category's interface -----------------------------------------------------------


@target.kernel
def line_crossings(S, centre, radius, dirs, offsets):
    """How many times each of a family of lines crosses the scene's surfaces: line k runs along
    unit dirs[k] through centre + offsets[k] (a point of the disk of `radius` about the centre,
    perpendicular to the line), and every crossing within the ball of `radius` counts."""
    out = np.zeros(dirs.shape[0], np.int64)
    stack, tstack = _stacks()
    for k in range(dirs.shape[0]):
        d = (dirs[k, 0], dirs[k, 1], dirs[k, 2])
        o = (centre[0] + offsets[k, 0] - 2.0 * radius * d[0], centre[1] + offsets[k, 1] - 2.0 * radius * d[1],
             centre[2] + offsets[k, 2] - 2.0 * radius * d[2])
        t = 0.0
        while out[k] < 64:
            t_hit, prim, _ = intersect_scene(S.tlas_f, S.tlas_i, S.inst_i, S.inst_f, S.motion_f, S.nodes_f, S.nodes_i, S.prims_i, S.prims_f,
                                             S.bnd_i, S.bnd_f, S.tri_i, S.verts_f, o, d, t, 4.0 * radius, 0.0, independent_key(1), 0,
                                             stack, tstack)
            if prim < 0:
                break
            out[k] += 1
            t = t_hit
    return out


@target.kernel
def surface_samples(S, light, us, time):
    """Rows (point 3, normal 3, density per area) of area light row `light`'s surface sampler
    (tree space) at each (u1, u2) of `us`."""
    out = np.zeros((us.shape[0], 7))
    prim = S.light_i[light, LIGHT_PRIMITIVE]
    kind = S.prims_i[prim, PRIM_KIND]
    for k in range(us.shape[0]):
        x, n, pdf = sample_light_surface(S, light, kind, prim, time, us[k, 0], us[k, 1])
        out[k, 0], out[k, 1], out[k, 2] = x[0], x[1], x[2]
        out[k, 3], out[k, 4], out[k, 5] = n[0], n[1], n[2]
        out[k, 6] = pdf
    return out


@target.kernel
def li_and_pdf_li(S, p, time, seed, n, map_row):
    """n draws of `sample_li` from p, each beside the density `pdf_li` gives what it drew: rows
    (ok, distance, pdf, pdf_li, distance to the first surface along wi (inf: none), pdf of
    `radiance_escaped` along wi). A draw at infinity is light row `map_row`'s; any other is the
    light the ray along wi meets first."""
    out = np.zeros((n, 6))
    stack, tstack = _stacks()
    p = (p[0], p[1], p[2])
    no_normal = (0.0, 0.0, 0.0)
    for k in range(n):
        key = path_key(seed, k, 0)
        ok, x, wi, dist, pdf, le, _ = sample_li(S, p, no_normal, time, uniform(key, light_dim(0, 0)),
                                             uniform(key, light_dim(0, 1)), uniform(key, light_dim(0, 2)))
        out[k, 0] = 1.0 if ok else 0.0
        out[k, 1], out[k, 2] = dist, pdf
        if not ok:
            continue
        prim, inst, xh, nh = _hit(S, p, wi, time, stack, tstack)
        out[k, 4] = math.sqrt((xh[0] - p[0]) ** 2 + (xh[1] - p[1]) ** 2 + (xh[2] - p[2]) ** 2) if prim >= 0 else math.inf
        # The density radiance_escaped weighs by, read back from its weight against a BSDF density pdf.
        plain = radiance_escaped(S, p, no_normal, wi, 0.0)
        weighted = radiance_escaped(S, p, no_normal, wi, pdf)
        lum = plain[0] + plain[1] + plain[2]
        if lum > 0.0:
            w = (weighted[0] + weighted[1] + weighted[2]) / lum
            out[k, 5] = pdf * math.sqrt(max(0.0, 1.0 / w - 1.0))
        if dist == math.inf:
            out[k, 3] = pdf_li(S, map_row, p, no_normal, wi, wi, time)
        elif prim >= 0:
            out[k, 3] = pdf_li(S, light_of_hit(S, inst, prim), p, no_normal, xh, nh, time)
    return out


@target.kernel
def selections(S, us):
    """For each u0 of `us`: the light row `select_light` chooses and the share it reports, and
    the share `share_of` gives that row."""
    out = np.zeros((us.shape[0], 3))
    for k in range(us.shape[0]):
        light, share, _ = select_light(S, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), us[k])
        out[k, 0], out[k, 1] = light, share
        out[k, 2] = share_of(S, light) if light >= 0 else -1.0
    return out


@target.kernel
def cone_samples(p, c, r, us):
    """Rows (point 3, normal 3, density) of `sample_cone` from p toward the sphere (c, r)."""
    out = np.zeros((us.shape[0], 7))
    d = (p[0] - c[0], p[1] - c[1], p[2] - c[2])
    dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    for k in range(us.shape[0]):
        x, n, pdf = sample_cone((p[0], p[1], p[2]), (c[0], c[1], c[2]), r, dist2, us[k, 0], us[k, 1])
        out[k, 0], out[k, 1], out[k, 2] = x[0], x[1], x[2]
        out[k, 3], out[k, 4], out[k, 5] = n[0], n[1], n[2]
        out[k, 6] = pdf
    return out


@target.kernel
def rectangle_solid_angle(q, eu, ev, p):
    """The solid angle `rectangle_frame` finds for the rectangle (q, eu, ev) seen from p."""
    return rectangle_frame((q[0], q[1], q[2]), (eu[0], eu[1], eu[2]), (ev[0], ev[1], ev[2]), (p[0], p[1], p[2]))[8]
