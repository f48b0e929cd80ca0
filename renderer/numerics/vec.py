"""3-vectors as tuples of floats: small njit helpers the kernels inline."""

import math


from .. import target


@target.device
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@target.device
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@target.device
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@target.device
def madd(a, b, s):
    """a + b * s"""
    return (a[0] + b[0] * s, a[1] + b[1] * s, a[2] + b[2] * s)


@target.device
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@target.device
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@target.device
def length(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@target.device
def unit(a):
    n = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    if n == 0.0:
        return (0.0, 0.0, 0.0)
    return (a[0] / n, a[1] / n, a[2] / n)


@target.device
def neg(a):
    return (-a[0], -a[1], -a[2])


@target.device
def max_abs(a):
    return max(abs(a[0]), abs(a[1]), abs(a[2]))


@target.device
def row3(arr, i, k):
    """The 3-vector arr[i, k:k+3]."""
    return (arr[i, k], arr[i, k + 1], arr[i, k + 2])


@target.device
def xform_point(m, i, k, p):
    """Apply the affine map in m[i, k:k+12] (3x4 row-major) to a point."""
    return (
        m[i, k] * p[0] + m[i, k + 1] * p[1] + m[i, k + 2] * p[2] + m[i, k + 3],
        m[i, k + 4] * p[0] + m[i, k + 5] * p[1] + m[i, k + 6] * p[2] + m[i, k + 7],
        m[i, k + 8] * p[0] + m[i, k + 9] * p[1] + m[i, k + 10] * p[2] + m[i, k + 11],
    )


@target.device
def xform_vector(m, i, k, v):
    """Apply the linear part of the map in m[i, k:k+12] to a direction."""
    return (
        m[i, k] * v[0] + m[i, k + 1] * v[1] + m[i, k + 2] * v[2],
        m[i, k + 4] * v[0] + m[i, k + 5] * v[1] + m[i, k + 6] * v[2],
        m[i, k + 8] * v[0] + m[i, k + 9] * v[1] + m[i, k + 10] * v[2],
    )


@target.device
def xform_normal(m, i, k, n):
    """Transform a normal by the transpose of the linear part in m[i, k:k+12] (pass object_from_world)."""
    return (
        m[i, k] * n[0] + m[i, k + 4] * n[1] + m[i, k + 8] * n[2],
        m[i, k + 1] * n[0] + m[i, k + 5] * n[1] + m[i, k + 9] * n[2],
        m[i, k + 2] * n[0] + m[i, k + 6] * n[1] + m[i, k + 10] * n[2],
    )
