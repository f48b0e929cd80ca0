"""Transforms that move over the shutter: keyframes, their interpolation and the bounds of their motion.

A moving placement (an instance, a shape given `motion:`, the camera) is a list of keyframes,
each an affine map at a time. As pbrt-v4 does (AnimatedTransform), each map M = T R S is split
once, when flattening, into a translation T, a rotation R (a unit quaternion) and a stretch S
(symmetric, the rest of the polar decomposition); between two keyframes T and S are
interpolated linearly and R by slerp, and before the first or after the last keyframe the map
is held. `motion_f` holds one row per keyframe; a placement names its first row and its count.

The kernels evaluate the map at a ray's time (`maps_at`: world_from_object and its inverse as
12-tuples) and apply it with `map_point`, `map_vector` and `map_normal`, which do the arithmetic
of numerics.vec's xform_* in the same order. The numpy side (`keyframe_rows`, `maps_at_numpy`,
`motion_bounds`) splits the maps and bounds a box over the whole motion (see `motion_bounds`).

Floor: it imports nothing above the tables.
"""

import math

import numpy as np

from . import target
from .columns import Column, Layout
from .kernel_flags import MOTION
from .trees import INST_FIRST_KEY, INST_KEYS

MOTION_F = Layout("motion_f", "float64", [
    Column("time", 1, "the keyframe's time (keyframes of one placement in increasing time)"),
    Column("translation", 3, "T of the map M = T R S at that time"),
    Column("rotation", 4, "R as a unit quaternion (x, y, z, w), on the same side as the keyframe before it"),
    Column("stretch", 9, "S, row-major: the symmetric factor of the polar decomposition (scale and shear)"),
])
KEY_TIME, KEY_T, KEY_Q, KEY_S = MOTION_F.offsets("time", "translation", "rotation", "stretch")

# Bounds: the motion's box is sampled this many times per keyframe interval, then padded by the
# farthest any point can move between two samples (motion_bounds).
BOUND_SAMPLES = 64


# --- numpy: splitting maps into keyframes, evaluating them, bounding them ----------------------


def _quaternion_of(r: np.ndarray) -> np.ndarray:
    """The unit quaternion (x, y, z, w) of rotation matrix r (Shepperd's method: the largest
    of the four squares first, so nothing divides by a small number)."""
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = math.sqrt(trace + 1.0) * 2.0
        q = ((r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s)
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2]) * 2.0
        q = (0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s)
    elif r[1, 1] > r[2, 2]:
        s = math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2]) * 2.0
        q = ((r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s)
    else:
        s = math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1]) * 2.0
        q = ((r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s, (r[1, 0] - r[0, 1]) / s)
    q = np.array(q)
    return q / np.linalg.norm(q)


def decompose(m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(T, q, S) of a 3x4 affine map m = T R S: R the rotation nearest the linear part (its polar
    decomposition, by the SVD), S = R^T L symmetric. A mirror (det < 0) is kept in S, so that R
    stays a rotation that slerp can follow."""
    m = np.asarray(m, np.float64).reshape(3, 4)
    lin = m[:, :3]
    u, sigma, vt = np.linalg.svd(lin)
    r = u @ vt
    if np.linalg.det(r) < 0:
        # L = (U D Vt) with a reflection: put it into S by flipping the last singular direction.
        u = u.copy()
        u[:, 2] = -u[:, 2]
        r = u @ vt
    s = r.T @ lin
    s = 0.5 * (s + s.T)
    return m[:, 3].copy(), _quaternion_of(r), s


def keyframe_rows(times, maps) -> np.ndarray:
    """MOTION_F rows of a placement's keyframes: each map (3x4) split by `decompose`, each
    quaternion turned to the side of the one before it, so slerp takes the shorter way."""
    rows = np.zeros((len(times), MOTION_F.width))
    prev = None
    for k, (t, m) in enumerate(zip(times, maps)):
        tr, q, s = decompose(m)
        if prev is not None and np.dot(prev, q) < 0:
            q = -q
        prev = q
        rows[k, KEY_TIME] = t
        rows[k, KEY_T:KEY_T + 3] = tr
        rows[k, KEY_Q:KEY_Q + 4] = q
        rows[k, KEY_S:KEY_S + 9] = s.reshape(9)
    return rows


def _rotation_matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _slerp_numpy(q0, q1, s):
    cos_theta = float(np.dot(q0, q1))
    if cos_theta > 0.9995:
        q = (1 - s) * q0 + s * q1
        return q / np.linalg.norm(q)
    theta = math.acos(max(-1.0, min(1.0, cos_theta)))
    perp = q1 - q0 * cos_theta
    perp = perp / np.linalg.norm(perp)
    return q0 * math.cos(theta * s) + perp * math.sin(theta * s)


def map_at_numpy(rows: np.ndarray, time: float) -> np.ndarray:
    """The 3x4 world_from_object map of keyframe rows at `time` (as the kernels' `maps_at`)."""
    n = len(rows)
    if time <= rows[0, KEY_TIME] or n == 1:
        k, s = 0, 0.0
    elif time >= rows[n - 1, KEY_TIME]:
        k, s = n - 2, 1.0
    else:
        k = int(np.searchsorted(rows[:, KEY_TIME], time, side="right")) - 1
        s = (time - rows[k, KEY_TIME]) / (rows[k + 1, KEY_TIME] - rows[k, KEY_TIME])
    a, b = rows[k], rows[min(k + 1, n - 1)]
    tr = (1 - s) * a[KEY_T:KEY_T + 3] + s * b[KEY_T:KEY_T + 3]
    q = _slerp_numpy(a[KEY_Q:KEY_Q + 4], b[KEY_Q:KEY_Q + 4], s)
    st = (1 - s) * a[KEY_S:KEY_S + 9] + s * b[KEY_S:KEY_S + 9]
    m = np.zeros((3, 4))
    m[:, :3] = _rotation_matrix(q) @ st.reshape(3, 3)
    m[:, 3] = tr
    return m


def uniform_stretch(rows: np.ndarray) -> bool:
    """Whether every keyframe's stretch is a uniform scale s I (within 1e-9 of its size): then
    every map of the motion is a similarity, and a sphere stays a sphere, a rectangle a rectangle."""
    s = rows[:, KEY_S:KEY_S + 9].reshape(-1, 3, 3)
    scale = np.trace(s, axis1=1, axis2=2) / 3.0
    return bool(np.all(np.abs(s - scale[:, None, None] * np.eye(3)) <= 1e-9 * np.abs(scale)[:, None, None]))


def motion_bounds(rows: np.ndarray, lo, hi, samples: int = BOUND_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """A world box holding the object box lo..hi under every map of the keyframes `rows`, at
    every time: the box of its 8 corners at `samples` + 1 times per interval, padded.

    An affine map takes the box to the hull of its mapped corners, so corners suffice. Between
    two samples h apart (in the interval's parameter s from 0 to 1) a corner p moves at speed
    |dp/ds| <= |dT| + theta |S(s) p| + |dS p|, with theta the rotation's angle over the interval
    (slerp turns at a constant rate) and |S(s) p| <= max(|S0 p|, |S1 p|) (S(s) p is linear in s):
    so every intermediate position lies within h / 2 of that speed bound of a sampled one, and the
    sampled box padded by it holds the whole motion. A relative 1e-9 more covers rounding."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    out_lo, out_hi = np.full(3, np.inf), np.full(3, -np.inf)
    n = len(rows)
    spans = [(rows[0, KEY_TIME], rows[0, KEY_TIME])] if n == 1 else [(rows[k, KEY_TIME], rows[k + 1, KEY_TIME]) for k in range(n - 1)]
    for k, (t0, t1) in enumerate(spans):
        a, b = rows[k], rows[min(k + 1, n - 1)]
        s0, s1 = a[KEY_S:KEY_S + 9].reshape(3, 3), b[KEY_S:KEY_S + 9].reshape(3, 3)
        reach = np.maximum(np.linalg.norm(corners @ s0.T, axis=1), np.linalg.norm(corners @ s1.T, axis=1)).max()
        stretch_speed = np.linalg.norm(corners @ (s1 - s0).T, axis=1).max()
        cos_half = min(1.0, abs(float(np.dot(a[KEY_Q:KEY_Q + 4], b[KEY_Q:KEY_Q + 4]))))
        theta = 2.0 * math.acos(cos_half)
        speed = np.linalg.norm(b[KEY_T:KEY_T + 3] - a[KEY_T:KEY_T + 3]) + theta * reach + stretch_speed
        for j in range(samples + 1):
            t = t0 + (t1 - t0) * j / samples
            m = map_at_numpy(rows, t)
            world = corners @ m[:, :3].T + m[:, 3]
            out_lo = np.minimum(out_lo, world.min(axis=0))
            out_hi = np.maximum(out_hi, world.max(axis=0))
        pad = 0.5 * speed / samples
        out_lo -= pad
        out_hi += pad
    size = np.abs(out_lo).max() + np.abs(out_hi).max()
    eps = 1e-9 * size
    return out_lo - eps, out_hi + eps


# --- the kernels ------------------------------------------------------------------------------


@target.device
def slerp(x0, y0, z0, w0, x1, y1, z1, w1, s):
    """The unit quaternion a fraction s of the way from q0 to q1 at a constant turning rate
    (nearly equal ones are blended and normalised, where acos would lose its digits)."""
    cos_theta = x0 * x1 + y0 * y1 + z0 * z1 + w0 * w1
    if cos_theta > 0.9995:
        x, y, z, w = x0 + s * (x1 - x0), y0 + s * (y1 - y0), z0 + s * (z1 - z0), w0 + s * (w1 - w0)
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        return x / norm, y / norm, z / norm, w / norm
    theta = math.acos(max(-1.0, min(1.0, cos_theta)))
    px, py, pz, pw = x1 - x0 * cos_theta, y1 - y0 * cos_theta, z1 - z0 * cos_theta, w1 - w0 * cos_theta
    norm = math.sqrt(px * px + py * py + pz * pz + pw * pw)
    c, sn = math.cos(theta * s), math.sin(theta * s) / norm
    return x0 * c + px * sn, y0 * c + py * sn, z0 * c + pz * sn, w0 * c + pw * sn


@target.device
def maps_at(motion_f, first, count, time):
    """(world_from_object, object_from_world) of the placement whose keyframes are rows
    first .. first + count - 1 of motion_f, at `time`: each a 3x4 row-major 12-tuple."""
    k, s = first, 0.0
    last = first + count - 1
    if count > 1 and time > motion_f[first, KEY_TIME]:
        if time >= motion_f[last, KEY_TIME]:
            k, s = last - 1, 1.0
        else:
            k = first
            while k < last - 1 and time >= motion_f[k + 1, KEY_TIME]:
                k += 1
            s = (time - motion_f[k, KEY_TIME]) / (motion_f[k + 1, KEY_TIME] - motion_f[k, KEY_TIME])
    j = k + 1 if count > 1 else k
    tx = motion_f[k, KEY_T] + s * (motion_f[j, KEY_T] - motion_f[k, KEY_T])
    ty = motion_f[k, KEY_T + 1] + s * (motion_f[j, KEY_T + 1] - motion_f[k, KEY_T + 1])
    tz = motion_f[k, KEY_T + 2] + s * (motion_f[j, KEY_T + 2] - motion_f[k, KEY_T + 2])
    x, y, z, w = slerp(motion_f[k, KEY_Q], motion_f[k, KEY_Q + 1], motion_f[k, KEY_Q + 2], motion_f[k, KEY_Q + 3],
                       motion_f[j, KEY_Q], motion_f[j, KEY_Q + 1], motion_f[j, KEY_Q + 2], motion_f[j, KEY_Q + 3], s)
    s00 = motion_f[k, KEY_S] + s * (motion_f[j, KEY_S] - motion_f[k, KEY_S])
    s01 = motion_f[k, KEY_S + 1] + s * (motion_f[j, KEY_S + 1] - motion_f[k, KEY_S + 1])
    s02 = motion_f[k, KEY_S + 2] + s * (motion_f[j, KEY_S + 2] - motion_f[k, KEY_S + 2])
    s10 = motion_f[k, KEY_S + 3] + s * (motion_f[j, KEY_S + 3] - motion_f[k, KEY_S + 3])
    s11 = motion_f[k, KEY_S + 4] + s * (motion_f[j, KEY_S + 4] - motion_f[k, KEY_S + 4])
    s12 = motion_f[k, KEY_S + 5] + s * (motion_f[j, KEY_S + 5] - motion_f[k, KEY_S + 5])
    s20 = motion_f[k, KEY_S + 6] + s * (motion_f[j, KEY_S + 6] - motion_f[k, KEY_S + 6])
    s21 = motion_f[k, KEY_S + 7] + s * (motion_f[j, KEY_S + 7] - motion_f[k, KEY_S + 7])
    s22 = motion_f[k, KEY_S + 8] + s * (motion_f[j, KEY_S + 8] - motion_f[k, KEY_S + 8])
    r00, r01, r02 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)
    r10, r11, r12 = 2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)
    r20, r21, r22 = 2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)
    # L = R S.
    l00 = r00 * s00 + r01 * s10 + r02 * s20
    l01 = r00 * s01 + r01 * s11 + r02 * s21
    l02 = r00 * s02 + r01 * s12 + r02 * s22
    l10 = r10 * s00 + r11 * s10 + r12 * s20
    l11 = r10 * s01 + r11 * s11 + r12 * s21
    l12 = r10 * s02 + r11 * s12 + r12 * s22
    l20 = r20 * s00 + r21 * s10 + r22 * s20
    l21 = r20 * s01 + r21 * s11 + r22 * s21
    l22 = r20 * s02 + r21 * s12 + r22 * s22
    # L^-1 = S^-1 R^T, from S's cofactors (S is symmetric and invertible: no scale of 0 is allowed).
    c00 = s11 * s22 - s12 * s21
    c01 = s02 * s21 - s01 * s22
    c02 = s01 * s12 - s02 * s11
    c10 = s12 * s20 - s10 * s22
    c11 = s00 * s22 - s02 * s20
    c12 = s02 * s10 - s00 * s12
    c20 = s10 * s21 - s11 * s20
    c21 = s01 * s20 - s00 * s21
    c22 = s00 * s11 - s01 * s10
    inv_det = 1.0 / (s00 * c00 + s01 * c10 + s02 * c20)
    i00, i01, i02 = c00 * inv_det, c01 * inv_det, c02 * inv_det
    i10, i11, i12 = c10 * inv_det, c11 * inv_det, c12 * inv_det
    i20, i21, i22 = c20 * inv_det, c21 * inv_det, c22 * inv_det
    # (S^-1 R^T): row a, column b = sum_c i[a][c] r[b][c].
    m00 = i00 * r00 + i01 * r01 + i02 * r02
    m01 = i00 * r10 + i01 * r11 + i02 * r12
    m02 = i00 * r20 + i01 * r21 + i02 * r22
    m10 = i10 * r00 + i11 * r01 + i12 * r02
    m11 = i10 * r10 + i11 * r11 + i12 * r12
    m12 = i10 * r20 + i11 * r21 + i12 * r22
    m20 = i20 * r00 + i21 * r01 + i22 * r02
    m21 = i20 * r10 + i21 * r11 + i22 * r12
    m22 = i20 * r20 + i21 * r21 + i22 * r22
    world = (l00, l01, l02, tx, l10, l11, l12, ty, l20, l21, l22, tz)
    back = (m00, m01, m02, -(m00 * tx + m01 * ty + m02 * tz),
            m10, m11, m12, -(m10 * tx + m11 * ty + m12 * tz),
            m20, m21, m22, -(m20 * tx + m21 * ty + m22 * tz))
    return world, back


@target.device
def map_point(m, p):
    """Apply a 3x4 map given as a 12-tuple to a point (the order of vec.xform_point)."""
    return (
        m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3],
        m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7],
        m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11],
    )


@target.device
def map_vector(m, v):
    """Apply the linear part of a 12-tuple map to a direction."""
    return (
        m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
        m[4] * v[0] + m[5] * v[1] + m[6] * v[2],
        m[8] * v[0] + m[9] * v[1] + m[10] * v[2],
    )


@target.device
def map_normal(m, n):
    """Transform a normal by the transpose of the linear part of a 12-tuple map (pass object_from_world)."""
    return (
        m[0] * n[0] + m[4] * n[1] + m[8] * n[2],
        m[1] * n[0] + m[5] * n[1] + m[9] * n[2],
        m[2] * n[0] + m[6] * n[1] + m[10] * n[2],
    )


@target.device
def area_ratio_of(world, back, n_world):
    """lights.area_ratio for maps given as 12-tuples: |det L^-1| |L^T n|."""
    det = (back[0] * (back[5] * back[10] - back[6] * back[9])
           - back[1] * (back[4] * back[10] - back[6] * back[8])
           + back[2] * (back[4] * back[9] - back[5] * back[8]))
    lt = (world[0] * n_world[0] + world[4] * n_world[1] + world[8] * n_world[2],
          world[1] * n_world[0] + world[5] * n_world[1] + world[9] * n_world[2],
          world[2] * n_world[0] + world[6] * n_world[1] + world[10] * n_world[2])
    return abs(det) * math.sqrt(lt[0] * lt[0] + lt[1] * lt[1] + lt[2] * lt[2])


@target.device
def moves(inst_i, inst):
    """Whether instance row `inst` moves (only a kernel with the motion path asks)."""
    return MOTION and inst_i[inst, INST_KEYS] > 0


@target.device
def instance_maps(inst_i, motion_f, inst, time):
    """(world_from_object, object_from_world) of moving instance row `inst` at `time`."""
    return maps_at(motion_f, inst_i[inst, INST_FIRST_KEY], inst_i[inst, INST_KEYS], time)
