"""Path guiding: where light arrives from, learned per region of space, as a sampling density.

A path that leaves a matte surface in a direction drawn from its BSDF finds light that reaches it
only through glass or a mirror (a caustic) by luck. The guide is a distribution of incident
radiance over directions, one per cell of a spatial tree over the scene, learned from the paths
of a short training render (guide_training.py) and built in numpy (guide_build.py). At a vertex
with a density (materials.has_density) the integrator draws its next direction from the guide or
from the BSDF, one or the other at random, and weighs by the mixture of both densities, so the
estimate stays unbiased whatever the guide has learned (tracing/integrator.py).

The contract the integrator keeps with this module (tables `guide_f`, `guide_i` of the flat
scene; both empty when the scene is not guided):

- `guide_leaf(gf, gi, p)`: the spatial leaf whose directional distribution holds at point p, or
  -1 where there is none (an empty guide, p outside the tree's box, a leaf that learned nothing):
  the vertex then samples its BSDF alone.
- `sample_guide(gf, gi, leaf, u0, u1) -> (d, pdf)`: a unit direction d drawn from the leaf's
  distribution, and its density per unit solid angle (> 0).
- `pdf_guide(gf, gi, leaf, d)`: the density per unit solid angle with which `sample_guide` draws
  the unit direction d from that leaf (0 where it never does).
"""

from __future__ import annotations

import math

import numpy as np

from . import target


def empty_guide() -> dict:
    """The guide tables of a scene that is not guided: no leaves anywhere."""
    return {"guide_f": np.zeros((0, 1), np.float64), "guide_i": np.zeros((0, 1), np.int64)}


@target.device
def guide_leaf(gf, gi, p):
    """The leaf of the spatial tree holding p, or -1 where the guide has nothing to say."""
    if gi.shape[0] == 0:
        return -1
    return -1


@target.device
def sample_guide(gf, gi, leaf, u0, u1):
    """(unit direction, solid angle density) drawn from leaf `leaf`'s distribution."""
    # Uniform over the sphere until the directional trees fill this in.
    z = 1.0 - 2.0 * u0
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * u1
    return (r * math.cos(phi), r * math.sin(phi), z), 1.0 / (4.0 * math.pi)


@target.device
def pdf_guide(gf, gi, leaf, d):
    """The solid angle density with which `sample_guide` draws unit direction d from `leaf`."""
    return 1.0 / (4.0 * math.pi)
