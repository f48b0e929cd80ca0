"""GGX (Trowbridge-Reitz) microfacet distribution and Smith shadowing, in a local shading frame.

Every rough lobe (conductor, rough dielectric, plastic, principled) is built from these. The
frame is the one of `numerics/frame.py`: z is the shading normal, s and t the tangents; the
distribution is anisotropic with width `ax` along s and `ay` along t (alpha = roughness^2 in
the glTF convention, given directly in Mitsuba's). Directions and normals are unit 3-tuples.

The formulas are written in forms that stay finite everywhere a lobe can reach:

- D(m) = 1 / (pi ax ay (mx^2/ax^2 + my^2/ay^2 + mz^2)^2) for a unit m: the textbook form with
  its cos^4 and tan^2 multiplied out, so nothing divides by m.z. With alpha >= MIN_ALPHA the
  peak 1 / (pi ax ay) is at most about 3e7, far from overflow.
- Smith's Lambda(w) = (sqrt(1 + alpha_w^2 tan^2 theta) - 1) / 2 is infinite at w.z = 0, so G1
  and G are computed from s(w) = sqrt(w.z^2 + ax^2 w.x^2 + ay^2 w.y^2) instead: G1 = 2 |w.z| /
  (|w.z| + s(w)), and the height-correlated 1 / (1 + Lo + Li) = 2 |zo| |zi| / (s(wo) |zi| +
  s(wi) |zo|), both 0 at grazing directions instead of 1 / inf.

Lambda depends only on tan^2 theta, so it takes |w.z|: a transmitted direction (w.z < 0) has the
same Lambda as its mirror image, which is what rough dielectrics need. Sign conditions (a
microfacet seen from the wrong side) are applied by `smith_g1` and `smith_g`.
"""

import math

from .. import target

# Below this width a lobe is treated as smooth (a delta: mirror or refraction), never as GGX: D's
# peak 1 / (pi ax ay) stays below about 3.2e7 and its (mx/ax)^4 term below 1e16, so single
# precision arithmetic of the callers would be safe too.
MIN_ALPHA = 1e-4

# What `ggx_lambda` answers at w.z = 0, where Lambda is infinite: finite, and large enough that
# 1 / (1 + Lambda) is 0 to double precision.
LAMBDA_AT_GRAZING = 1e300


@target.device
def ggx_d(ax, ay, m):
    """The GGX normal distribution D(m) per unit solid angle of microfacet normals (not projected):
    its integral of D(m) m.z over the upper hemisphere is 1. 0 for m.z <= 0."""
    if m[2] <= 0.0:
        return 0.0
    x = m[0] / ax
    y = m[1] / ay
    q = x * x + y * y + m[2] * m[2]
    return 1.0 / (math.pi * ax * ay * q * q)


@target.device
def _smith_root(ax, ay, w):
    """s(w) = sqrt(w.z^2 + ax^2 w.x^2 + ay^2 w.y^2) = |w.z| (1 + 2 Lambda(w)); > 0 for a unit w."""
    x = ax * w[0]
    y = ay * w[1]
    return math.sqrt(w[2] * w[2] + x * x + y * y)


@target.device
def ggx_lambda(ax, ay, w):
    """Smith's Lambda(w) for GGX: (sqrt(1 + (ax^2 w.x^2 + ay^2 w.y^2) / w.z^2) - 1) / 2.

    Even in w.z. At w.z = 0 (infinite in theory) and for a w.z so small that it would overflow it
    returns LAMBDA_AT_GRAZING."""
    z = abs(w[2])
    if z <= 0.0:
        return LAMBDA_AT_GRAZING
    # Clamped: for a subnormal w.z the quotient overflows.
    return min(LAMBDA_AT_GRAZING, 0.5 * (_smith_root(ax, ay, w) - z) / z)


@target.device
def smith_g1(ax, ay, w, m):
    """Smith's masking G1(w, m) = 1 / (1 + Lambda(w)) where m is visible from w, i.e. where
    dot(w, m) and w.z have the same sign; 0 otherwise, and 0 at w.z = 0."""
    if (w[0] * m[0] + w[1] * m[1] + w[2] * m[2]) * w[2] <= 0.0:
        return 0.0
    z = abs(w[2])
    return 2.0 * z / (z + _smith_root(ax, ay, w))


@target.device
def smith_g(ax, ay, wo, wi, m, correlated):
    """Smith's masking-shadowing G(wo, wi, m); 0 where m is not visible from wo or from wi.

    `correlated` True: the height-correlated form 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014,
    the file format's default); False: the separable product G1(wo, m) G1(wi, m), which Mitsuba 3
    uses. The correlated form is the larger of the two, always within [G1 G1, min(G1, G1)]."""
    if (wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2]) * wo[2] <= 0.0:
        return 0.0
    if (wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2]) * wi[2] <= 0.0:
        return 0.0
    zo = abs(wo[2])
    zi = abs(wi[2])
    so = _smith_root(ax, ay, wo)
    si = _smith_root(ax, ay, wi)
    if correlated:
        # 1 / (1 + Lo + Li) with Lo = (so - zo) / (2 zo), multiplied through by 2 zo zi.
        den = so * zi + si * zo
        if den <= 0.0:
            return 0.0
        return 2.0 * zo * zi / den
    return (2.0 * zo / (zo + so)) * (2.0 * zi / (zi + si))


@target.device
def sample_visible_normal(ax, ay, w, u1, u2):
    """A microfacet normal m drawn from the distribution of normals visible from w (w.z > 0),
    whose density is `visible_normal_pdf(ax, ay, w, m)`; u1, u2 uniform in [0, 1).

    Heitz 2018 ("Sampling the GGX distribution of visible normals"): stretch w to the
    configuration where alpha is 1, where the visible normals are those of a hemisphere seen from
    w: sample the disk it projects to (its lower half squeezed by the hemisphere's foreshortening),
    lift the point onto the hemisphere, and unstretch the normal.
    """
    # Stretched view direction.
    vx = ax * w[0]
    vy = ay * w[1]
    vz = w[2]
    inv = 1.0 / math.sqrt(vx * vx + vy * vy + vz * vz)
    vx *= inv
    vy *= inv
    vz *= inv
    # An orthonormal frame (t1, t2, v) about it; any t1 when v is the normal itself.
    lensq = vx * vx + vy * vy
    if lensq > 0.0:
        r = 1.0 / math.sqrt(lensq)
        t1x, t1y, t1z = -vy * r, vx * r, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    t2x = vy * t1z - vz * t1y
    t2y = vz * t1x - vx * t1z
    t2z = vx * t1y - vy * t1x
    # A uniform point of the unit disk, its second coordinate squeezed toward the half-disk the
    # hemisphere shows at this angle.
    r = math.sqrt(u1)
    phi = 2.0 * math.pi * u2
    p1 = r * math.cos(phi)
    p2 = r * math.sin(phi)
    h = 0.5 * (1.0 + vz)
    p2 = (1.0 - h) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + h * p2
    # Lift onto the hemisphere about v.
    pn = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1x + p2 * t2x + pn * vx
    ny = p1 * t1y + p2 * t2y + pn * vy
    nz = p1 * t1z + p2 * t2z + pn * vz
    # Unstretch: normals transform with the inverse transpose of the stretch.
    mx = ax * nx
    my = ay * ny
    mz = max(0.0, nz)
    length = math.sqrt(mx * mx + my * my + mz * mz)
    if length <= 0.0:
        return (0.0, 0.0, 1.0)
    return (mx / length, my / length, mz / length)


@target.device
def visible_normal_pdf(ax, ay, w, m):
    """The density per unit solid angle of m that `sample_visible_normal` gives:
    D_w(m) = G1(w, m) max(0, dot(w, m)) D(m) / w.z; 0 for w.z <= 0."""
    if w[2] <= 0.0:
        return 0.0
    cos_wm = w[0] * m[0] + w[1] * m[1] + w[2] * m[2]
    if cos_wm <= 0.0:
        return 0.0
    return smith_g1(ax, ay, w, m) * cos_wm * ggx_d(ax, ay, m) / w[2]
