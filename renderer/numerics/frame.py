"""Orthonormal shading frames: a local coordinate system whose z axis is a surface's normal.

Materials that depend on angles (microfacet lobes, coated surfaces) work in such a frame, as
pbrt's and Mitsuba's BSDFs do: cos theta is a vector's z, and the lobe's code needs no normal.
"""

import math

from .. import target
from .vec import cross, dot, madd, scale, unit


@target.device
def basis(n):
    """Two unit vectors (s, t) that make (s, t, n) a right-handed orthonormal frame for a unit n.

    The branch-free construction of Duff et al. (2017, "Building an orthonormal basis,
    revisited"): continuous except across n.z = 0's sign, and exact for n = (0, 0, -1).
    """
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    s = (1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0])
    t = (b, sign + n[1] * n[1] * a, -n[1])
    return s, t


@target.device
def frame_of(n, tangent):
    """(s, t) completing the unit normal n to a frame whose s lies along `tangent` projected
    onto the plane of n (Gram-Schmidt); any frame (`basis`) when the tangent is zero or
    (nearly) parallel to n. Anisotropic lobes stretch along s and t."""
    along = madd(tangent, n, -dot(n, tangent))
    if dot(along, along) < 1e-12:
        return basis(n)
    s = unit(along)
    return s, cross(n, s)


@target.device
def to_local(s, t, n, v):
    """v's coordinates in the frame (s, t, n)."""
    return (dot(v, s), dot(v, t), dot(v, n))


@target.device
def to_world(s, t, n, v):
    """The vector whose coordinates in the frame (s, t, n) are v."""
    return madd(madd(scale(s, v[0]), t, v[1]), n, v[2])
