"""Slow, obvious reference implementations that the kernels are checked against.

Plain Python floats, textbook formulas, no cleverness: if a kernel and this file disagree on
random input, the kernel is wrong (or the input sits on a boundary, which callers skip).
"""

from __future__ import annotations

import cmath
import math

INF = math.inf


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(dot(a, a))


def unit(a):
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def det3(c0, c1, c2):
    return dot(c0, cross(c1, c2))


def sphere(center, radius, o, d, tmin=0.0):
    """(t, outward normal, (u, v)) of the nearest hit beyond tmin, or None."""
    oc = sub(o, center)
    a, b, c = dot(d, d), 2 * dot(oc, d), dot(oc, oc) - radius * radius
    disc = b * b - 4 * a * c
    if disc < 0:
        return None
    for t in sorted(((-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a))):
        if t > tmin:
            n = mul(sub(add(o, mul(d, t)), center), 1 / radius)
            return t, n, sphere_uv(n)
    return None


def sphere_uv(n):
    theta = math.acos(max(-1.0, min(1.0, -n[1])))
    phi = math.atan2(-n[2], n[0]) + math.pi
    return phi / (2 * math.pi), theta / math.pi


def plane_coords(q, u, v, o, d):
    """(t, alpha, beta) with o + t d = q + alpha u + beta v, by Cramer's rule; None if parallel."""
    m = det3(u, v, mul(d, -1))
    if abs(m) < 1e-300:
        return None
    rhs = sub(o, q)
    alpha = det3(rhs, v, mul(d, -1)) / m
    beta = det3(u, rhs, mul(d, -1)) / m
    t = det3(u, v, rhs) / m
    return t, alpha, beta


def quad(q, u, v, o, d, tmin=0.0, shape="quad"):
    """(t, normal u x v, (alpha, beta), distance of (alpha, beta) from the boundary) or None."""
    hit = plane_coords(q, u, v, o, d)
    if hit is None:
        return None
    t, a, b = hit
    if t <= tmin:
        return None
    if shape == "quad":
        inside, margin = 0 <= a <= 1 and 0 <= b <= 1, min(a, 1 - a, b, 1 - b)
    elif shape == "triangle":
        inside, margin = a >= 0 and b >= 0 and a + b <= 1, min(a, b, 1 - a - b)
    else:  # disk: u, v are radius-long orthogonal axes
        inside, margin = a * a + b * b <= 1, 1 - math.sqrt(a * a + b * b)
    if not inside:
        return None
    uv = (0.5 * a + 0.5, 0.5 * b + 0.5) if shape == "disk" else (a, b)
    return t, unit(cross(u, v)), uv, margin


def box(lo, hi, o, d, tmin=0.0):
    """(t, outward normal) of the nearest hit of an axis-aligned box's surface beyond tmin, or None."""
    best = None
    for axis in range(3):
        for side, value in ((-1, lo[axis]), (1, hi[axis])):
            if d[axis] == 0:
                continue
            t = (value - o[axis]) / d[axis]
            if t <= tmin:
                continue
            p = add(o, mul(d, t))
            others = [k for k in range(3) if k != axis]
            if all(lo[k] <= p[k] <= hi[k] for k in others):
                if best is None or t < best[0]:
                    n = [0.0, 0.0, 0.0]
                    n[axis] = float(side)
                    best = (t, tuple(n))
    return best


def apply(m, p):
    """A 3x4 affine map (rows) applied to a point."""
    return tuple(m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3] for r in range(3))


def apply_linear(m, v):
    return tuple(m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2] for r in range(3))


def inverse(m):
    """Inverse of a 3x4 affine map, by the adjugate."""
    a = [row[:3] for row in m]
    det = det3((a[0][0], a[1][0], a[2][0]), (a[0][1], a[1][1], a[2][1]), (a[0][2], a[1][2], a[2][2]))
    inv = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            r = [k for k in range(3) if k != j]
            c = [k for k in range(3) if k != i]
            minor = a[r[0]][c[0]] * a[r[1]][c[1]] - a[r[0]][c[1]] * a[r[1]][c[0]]
            inv[i][j] = (-1) ** (i + j) * minor / det
    t = [m[r][3] for r in range(3)]
    shift = [-sum(inv[i][k] * t[k] for k in range(3)) for i in range(3)]
    return tuple(tuple(inv[i]) + (shift[i],) for i in range(3))


def transform_normal(m, n):
    """World normal of an object normal under world_from_object m: inverse transpose, normalised."""
    inv = inverse(m)
    return unit(tuple(sum(inv[k][i] * n[k] for k in range(3)) for i in range(3)))


# --- microfacets and Fresnel (issue 31) ---------------------------------------------------------
# Textbook forms in angles, as the papers write them; callers skip the boundaries (m.z or w.z 0)
# where these divide by zero.


def ggx_d(ax, ay, m):
    """Trowbridge-Reitz D(m) = 1 / (pi ax ay cos^4 theta (1 + tan^2 theta (cos^2 phi / ax^2 +
    sin^2 phi / ay^2))^2) for m.z > 0, else 0."""
    if m[2] <= 0:
        return 0.0
    cos2 = m[2] * m[2]
    sin2 = 1 - cos2
    tan2 = sin2 / cos2
    if sin2 > 0:
        cos2_phi, sin2_phi = m[0] * m[0] / sin2, m[1] * m[1] / sin2
    else:
        cos2_phi, sin2_phi = 1.0, 0.0
    e = tan2 * (cos2_phi / (ax * ax) + sin2_phi / (ay * ay))
    return 1 / (math.pi * ax * ay * cos2 * cos2 * (1 + e) ** 2)


def ggx_lambda(ax, ay, w):
    """Smith's Lambda for GGX: (-1 + sqrt(1 + alpha(phi)^2 tan^2 theta)) / 2, with alpha(phi)^2 =
    ax^2 cos^2 phi + ay^2 sin^2 phi."""
    cos2 = w[2] * w[2]
    sin2 = 1 - cos2
    if sin2 <= 0:
        return 0.0
    alpha2 = (ax * ax * w[0] * w[0] + ay * ay * w[1] * w[1]) / sin2
    return (-1 + math.sqrt(1 + alpha2 * sin2 / cos2)) / 2


def smith_g1(ax, ay, w, m):
    if dot(w, m) * w[2] <= 0:
        return 0.0
    return 1 / (1 + ggx_lambda(ax, ay, w))


def smith_g(ax, ay, wo, wi, m, correlated=True):
    if dot(wo, m) * wo[2] <= 0 or dot(wi, m) * wi[2] <= 0:
        return 0.0
    if correlated:
        return 1 / (1 + ggx_lambda(ax, ay, wo) + ggx_lambda(ax, ay, wi))
    return smith_g1(ax, ay, wo, m) * smith_g1(ax, ay, wi, m)


def visible_normal_pdf(ax, ay, w, m):
    return smith_g1(ax, ay, w, m) * max(0.0, dot(w, m)) * ggx_d(ax, ay, m) / w[2]


def fresnel_dielectric(cos_i, eta):
    """Unpolarised reflectance from Snell's law and the s and p amplitude ratios; eta = incident
    index over transmitted index."""
    sin_t = eta * math.sqrt(max(0.0, 1 - cos_i * cos_i))
    if sin_t >= 1:
        return 1.0
    cos_t = math.sqrt(1 - sin_t * sin_t)
    n1, n2 = eta, 1.0
    rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)
    rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t)
    return (rs * rs + rp * rp) / 2


def fresnel_conductor(cos_i, eta, k):
    """Unpolarised reflectance at a conductor of complex index n = eta + i k (relative to the
    incident medium), by the Fresnel equations in complex arithmetic: cos_t from Snell's law
    sin_t = sin_i / n, then |r_s|^2 and |r_p|^2."""
    n = complex(eta, k)
    sin2_i = 1 - cos_i * cos_i
    cos_t = cmath.sqrt(1 - sin2_i / (n * n))
    rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    rp = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return (abs(rs) ** 2 + abs(rp) ** 2) / 2


def schlick(f0, cos):
    return f0 + (1 - f0) * (1 - cos) ** 5
