"""Small @njit wrappers that run the renderer's own kernel routines many times, for tests.

The kernels are inlined into the render loop; these loops call the very same functions with
the renderer's counter-based random numbers (keys from `path_key`), so a test sees exactly the
draws a render makes.
"""

import math

import numpy as np
from numba import njit

from renderer.camera import camera_ray
from renderer.kernels.rng import bounce_dim, path_key
from renderer.materials import MATERIAL_F, MATERIAL_I, random_unit_vector, scatter
from renderer.media import medium_hit
from renderer.textures import texture_value


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _scatter_many(mat_i, mat_f, d, normal, front, seed, n, bounce):
    out = np.empty((n, 3))
    for k in range(n):
        v = scatter(mat_i, mat_f, 0, (d[0], d[1], d[2]), (normal[0], normal[1], normal[2]), front,
                    path_key(seed, k, 0), bounce_dim(bounce, 0))
        out[k, 0], out[k, 1], out[k, 2] = v[0], v[1], v[2]
    return out


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def medium_distances(prims_f, bnd_i, bnd_f, seed, n):
    """Scattering distance along +z from the origin in medium row 0 for n paths (inf: passed through)."""
    out = np.empty(n)
    for k in range(n):
        out[k] = medium_hit(prims_f, bnd_i, bnd_f, 0, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.0, math.inf, 0.0,
                            path_key(seed, k, 0), 0, 0)
    return out


@njit(cache=True, error_model="numpy")
def texture_at(flat, tex, uv, points):
    """Colour of texture row `tex` at each (u, v) and point."""
    out = np.empty((points.shape[0], 3))
    for k in range(points.shape[0]):
        c = texture_value(flat.tex_i, flat.tex_f, flat.texels, flat.noise_perm, flat.noise_vec, tex,
                          uv[k, 0], uv[k, 1], (points[k, 0], points[k, 1], points[k, 2]))
        out[k, 0], out[k, 1], out[k, 2] = c[0], c[1], c[2]
    return out
