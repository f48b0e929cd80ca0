"""Compiled wrappers over the guide's kernels (renderer/guiding.py) for its tests and its
measurement (benchmarks/guide_records.py), as kernel_calls.py: the renderer's own functions,
called many times from arrays."""

import numpy as np
from renderer import target

from renderer.guiding import guide_leaf, pdf_guide, sample_guide


@target.kernel
def leaves(gf, gi, points):
    """`guide_leaf` at each point (n, 3)."""
    out = np.empty(points.shape[0], np.int64)
    for k in range(points.shape[0]):
        out[k] = guide_leaf(gf, gi, (points[k, 0], points[k, 1], points[k, 2]))
    return out


@target.kernel
def samples(gf, gi, leaf, us):
    """`sample_guide` of `leaf` for each (u0, u1) of us (n, 2): rows (direction 3, its density,
    `pdf_guide` of the same direction)."""
    out = np.empty((us.shape[0], 5))
    for k in range(us.shape[0]):
        d, pdf = sample_guide(gf, gi, leaf, us[k, 0], us[k, 1])
        out[k, 0], out[k, 1], out[k, 2] = d[0], d[1], d[2]
        out[k, 3] = pdf
        out[k, 4] = pdf_guide(gf, gi, leaf, d)
    return out


@target.kernel
def densities(gf, gi, leaf, dirs):
    """`pdf_guide` of `leaf` for each unit direction of dirs (n, 3)."""
    out = np.empty(dirs.shape[0])
    for k in range(dirs.shape[0]):
        out[k] = pdf_guide(gf, gi, leaf, (dirs[k, 0], dirs[k, 1], dirs[k, 2]))
    return out


@target.kernel
def densities_at(gf, gi, points, dirs):
    """`pdf_guide` at each point's leaf for each direction (0 where `guide_leaf` gives -1)."""
    out = np.zeros(points.shape[0])
    for k in range(points.shape[0]):
        leaf = guide_leaf(gf, gi, (points[k, 0], points[k, 1], points[k, 2]))
        if leaf >= 0:
            out[k] = pdf_guide(gf, gi, leaf, (dirs[k, 0], dirs[k, 1], dirs[k, 2]))
    return out


@target.kernel
def mixture_samples(gf, gi, points, us):
    """For each point and each triple (u, u0, u1) of us (n, k, 3): a direction drawn from the
    guide with probability 1/2 (where the point has a leaf), else uniformly over the sphere, and
    the density of that mixture there, as a guided bounce with a uniform BSDF would draw it:
    (directions (n, k, 3), densities (n, k))."""
    n, k = us.shape[0], us.shape[1]
    dirs = np.empty((n, k, 3))
    dens = np.empty((n, k))
    uniform = 1.0 / (4.0 * np.pi)
    for a in range(n):
        leaf = guide_leaf(gf, gi, (points[a, 0], points[a, 1], points[a, 2]))
        for b in range(k):
            if leaf >= 0 and us[a, b, 0] < 0.5:
                d, _ = sample_guide(gf, gi, leaf, us[a, b, 1], us[a, b, 2])
            else:
                z = 1.0 - 2.0 * us[a, b, 1]
                r = np.sqrt(max(0.0, 1.0 - z * z))
                phi = 2.0 * np.pi * us[a, b, 2]
                d = (r * np.cos(phi), r * np.sin(phi), z)
            q = uniform
            if leaf >= 0:
                q = 0.5 * pdf_guide(gf, gi, leaf, d) + 0.5 * uniform
            dirs[a, b, 0], dirs[a, b, 1], dirs[a, b, 2] = d[0], d[1], d[2]
            dens[a, b] = q
    return dirs, dens
