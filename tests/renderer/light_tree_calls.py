"""Compiled wrappers over the light selection for the light tree's tests (as kernel_calls.py):
they call the renderer's own `select_light` and `light_pmf` many times from given points."""

import numpy as np
from renderer import target

from renderer.light_tree import importance
from renderer.lights import light_pmf, select_light


@target.kernel
def choices(S, points, normals, us):
    """For each (point, normal, u0): rows (the light `select_light` chooses, its share, its pmf
    within the group, the pmf `light_pmf` gives the same light from the same point)."""
    out = np.zeros((us.shape[0], 4))
    for k in range(us.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        n = (normals[k, 0], normals[k, 1], normals[k, 2])
        light, share, pmf = select_light(S, p, n, us[k])
        out[k, 0], out[k, 1], out[k, 2] = light, share, pmf
        if light >= 0:
            out[k, 3] = light_pmf(S, light, p, n)
    return out


@target.kernel
def pmf_table(S, points, normals, first):
    """(points, lights): `light_pmf` of every light row from `first` on at each (point, normal)."""
    count = S.light_i.shape[0] - first
    out = np.zeros((points.shape[0], count))
    for k in range(points.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        n = (normals[k, 0], normals[k, 1], normals[k, 2])
        for j in range(count):
            out[k, j] = light_pmf(S, first + j, p, n)
    return out


@target.kernel
def importances(S, points, normals):
    """(points, nodes): each tree node's importance at each (point, normal)."""
    out = np.zeros((points.shape[0], S.ltree_f.shape[0]))
    for k in range(points.shape[0]):
        p = (points[k, 0], points[k, 1], points[k, 2])
        n = (normals[k, 0], normals[k, 1], normals[k, 2])
        for j in range(S.ltree_f.shape[0]):
            out[k, j] = importance(S.ltree_f, S.ltree_i, j, p, n)
    return out
