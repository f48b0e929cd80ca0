"""Where a light's caustic paths start: the specular spheres that light tracing aims at.

`integrator: caustics` splits the light transport in two (tracing/integrator.py,
tracing/caustics.py). The paths that a camera sees on a matte surface, lit through a chain of
purely specular vertices (glass, the books' metals) whose last vertex before the light is a
*target* listed here, are traced from the light: L S+ D E. Every other path stays with mis. A
path tracer finds such a path only when a diffuse bounce happens to leave towards the glass and
the glass happens to refract onto the light (a small lamp, the sun); a photon sent from the light
towards the glass finds the matte surface behind it every time, and is joined to the camera.

A photon passes only through the books' glass and metals without a map (`caustic_mat`): their
scattering is its own reverse (exact Fresnel at the glass, a lobe about the mirror direction at the
metal, no radiance scaled by the index), so a photon traced through them carries what a path traced
the other way would. A target is a sphere of such a material, each placement of it in world space; a primitive is a target in every placement or in none (`caustic_prim`), so the
path tracer can tell a path the photons cover by the primitive it hit. Shapes of other kinds stay
with the path tracer: a photon whose first hit is not a target is dropped, and a path whose last
specular vertex is not one is kept by the path tracer, so the split is exact whatever is listed.

Photons leave an area light towards the targets (a target chosen with probability proportional to
the solid angle it subtends, a direction uniform in its cone) and a light at infinity (the
environment map, the sun) from a disc perpendicular to the light's direction over a target
(chosen in proportion to its cross-section): `sample_toward_targets` / `pdf_toward_targets` and
`sample_across_targets` / `pdf_across_targets`; each density is the mixture over every target
whose cone or disc holds the direction or the point, so overlapping targets are counted right.

Tables (flat scene): `caustic_f` one row per target placement (CAUSTIC_F); `caustic_prim` (P,)
int32, 1 where the primitive is a target.
"""

from __future__ import annotations

import math

import numpy as np

from . import target
from .columns import Column, Layout
from .numerics.vec import cross, dot, unit

CAUSTIC_F = Layout("caustic_f", "float64", [
    Column("center", 3, "world centre of a specular sphere placed in the scene"),
    Column("radius", 1, "its world radius"),
])
CT_CENTER, CT_RADIUS = CAUSTIC_F.offsets("center", "radius")


def no_targets(prims: int, materials: int) -> dict:
    """The tables of a scene without caustic targets (or not rendered with integrator caustics)."""
    return {"caustic_f": np.zeros((0, CAUSTIC_F.width), np.float64), "caustic_prim": np.zeros(prims, np.int32),
            "caustic_mat": np.zeros(materials, np.int32)}


def target_tables(flat, sphere_kind: int, specular_materials: np.ndarray, radius_column: int, center_column: int,
                  inst_root: int, world_from_object: int, tree_prims) -> dict:
    """The caustic tables of `flat`: every placement of each sphere primitive (kind `sphere_kind`)
    whose material row is set in `specular_materials` (bool per material row), where every
    placement maps spheres to spheres (a similarity)."""
    prims = len(flat.prims_i)
    if prims == 0 or not specular_materials.any():
        return no_targets(prims, len(flat.mat_i))
    from .shapes import PRIM_KIND, PRIM_MATERIAL

    candidate = np.zeros(prims, np.bool_)
    n_surf = len(flat.prims_f)
    kinds = flat.prims_i[:n_surf, PRIM_KIND]
    mats = flat.prims_i[:n_surf, PRIM_MATERIAL]
    candidate[:n_surf] = (kinds == sphere_kind) & specular_materials[mats]
    if not candidate.any():
        return no_targets(prims, len(flat.mat_i))
    lin_all = flat.inst_f[:, world_from_object:world_from_object + 12].reshape(-1, 3, 4)
    placements: dict[int, list] = {}
    refused = np.zeros(prims, np.bool_)
    for k, root in enumerate(flat.inst_i[:, inst_root]):
        rows = np.asarray(tree_prims(flat.nodes_i, root), np.int64)
        rows = rows[candidate[rows]]
        if len(rows) == 0:
            continue
        m = lin_all[k]
        gram = m[:, :3].T @ m[:, :3]
        scale2 = np.trace(gram) / 3.0
        if not np.all(np.abs(gram - scale2 * np.eye(3)) <= 1e-9 * scale2):
            refused[rows] = True
            continue
        centers = flat.prims_f[rows, center_column:center_column + 3] @ m[:, :3].T + m[:, 3]
        radii = np.abs(flat.prims_f[rows, radius_column]) * math.sqrt(scale2)  # a bubble's radius is negative
        for r, c, rad in zip(rows.tolist(), centers, radii):
            placements.setdefault(r, []).append((c, rad))
    rows_out = []
    caustic_prim = np.zeros(prims, np.int32)
    for prim, where in placements.items():
        if refused[prim]:
            continue  # a placement that is no sphere: the primitive stays with the path tracer
        caustic_prim[prim] = 1
        rows_out += where
    table = CAUSTIC_F.array(len(rows_out), center=np.array([c for c, _ in rows_out]).reshape(-1, 3),
                            radius=np.array([r for _, r in rows_out], np.float64))
    return {"caustic_f": table, "caustic_prim": caustic_prim, "caustic_mat": specular_materials.astype(np.int32)}


@target.device
def _frame(w):
    """Two unit vectors completing unit w to an orthonormal frame."""
    a = (1.0, 0.0, 0.0) if abs(w[0]) < 0.9 else (0.0, 1.0, 0.0)
    s = unit(cross(a, w))
    return s, cross(w, s)


@target.device
def _cone_of(cf, t, x):
    """(unit axis from x to target t's centre, cosine of the cone's half-angle, its solid angle);
    a cosine of -1 (the whole sphere) when x is inside the target."""
    c = (cf[t, CT_CENTER] - x[0], cf[t, CT_CENTER + 1] - x[1], cf[t, CT_CENTER + 2] - x[2])
    d2 = dot(c, c)
    r = cf[t, CT_RADIUS]
    if d2 <= r * r:
        return (0.0, 0.0, 1.0), -1.0, 4.0 * math.pi
    d = math.sqrt(d2)
    cos_max = math.sqrt(max(0.0, 1.0 - r * r / d2))
    return (c[0] / d, c[1] / d, c[2] / d), cos_max, 2.0 * math.pi * (1.0 - cos_max)


@target.device
def _weight_from(cf, t, x):
    """Target t's share of the photons from point x: the solid angle it subtends (never 0)."""
    axis, cos_max, solid = _cone_of(cf, t, x)
    return max(solid, 1e-12)


@target.device
def _pick(cf, x, across, u0):
    """The target u0 chooses: in proportion to its cross-section (`across`: light at infinity)
    or to the solid angle it subtends from point x."""
    n = cf.shape[0]
    total = 0.0
    for t in range(n):
        total += cf[t, CT_RADIUS] * cf[t, CT_RADIUS] if across else _weight_from(cf, t, x)
    pick = u0 * total
    acc = 0.0
    for t in range(n):
        acc += cf[t, CT_RADIUS] * cf[t, CT_RADIUS] if across else _weight_from(cf, t, x)
        if pick < acc:
            return t
    return n - 1


@target.device
def sample_toward_targets(cf, x, u0, u1, u2):
    """A unit direction from point x towards the targets (one chosen by solid angle, then uniform
    in its cone) and the mixture's solid angle density; density 0 when there are no targets."""
    if cf.shape[0] == 0:
        return (0.0, 0.0, 1.0), 0.0
    chosen = _pick(cf, x, False, u0)
    axis, cos_max, solid = _cone_of(cf, chosen, x)
    cos_t = 1.0 - u1 * (1.0 - cos_max)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * math.pi * u2
    s, b = _frame(axis)
    d = (sin_t * math.cos(phi) * s[0] + sin_t * math.sin(phi) * b[0] + cos_t * axis[0],
         sin_t * math.cos(phi) * s[1] + sin_t * math.sin(phi) * b[1] + cos_t * axis[1],
         sin_t * math.cos(phi) * s[2] + sin_t * math.sin(phi) * b[2] + cos_t * axis[2])
    d = unit(d)
    return d, pdf_toward_targets(cf, x, d)


@target.device
def pdf_toward_targets(cf, x, d):
    """The solid angle density with which `sample_toward_targets` from x gives unit direction d."""
    n = cf.shape[0]
    total = 0.0
    pdf = 0.0
    for t in range(n):
        axis, cos_max, solid = _cone_of(cf, t, x)
        w = max(solid, 1e-12)
        total += w
        if dot(axis, d) >= cos_max or cos_max <= -1.0:
            pdf += w / solid
    return pdf / total if total > 0.0 else 0.0


@target.device
def sample_across_targets(cf, w, u0, u1, u2):
    """For light arriving along -w (w: unit, towards the light at infinity): a point on the plane
    through the origin perpendicular to w, in the disc a target casts on it (one chosen by its
    cross-section, then uniform in its disc), and the mixture's density per unit area there."""
    if cf.shape[0] == 0:
        return (0.0, 0.0, 0.0), 0.0
    chosen = _pick(cf, w, True, u0)
    r = cf[chosen, CT_RADIUS] * math.sqrt(u1)
    phi = 2.0 * math.pi * u2
    s, b = _frame(w)
    c = (cf[chosen, CT_CENTER], cf[chosen, CT_CENTER + 1], cf[chosen, CT_CENTER + 2])
    along = dot(c, w)
    y = (c[0] - along * w[0] + r * (math.cos(phi) * s[0] + math.sin(phi) * b[0]),
         c[1] - along * w[1] + r * (math.cos(phi) * s[1] + math.sin(phi) * b[1]),
         c[2] - along * w[2] + r * (math.cos(phi) * s[2] + math.sin(phi) * b[2]))
    return y, pdf_across_targets(cf, w, y)


@target.device
def pdf_across_targets(cf, w, y):
    """The density per unit area with which `sample_across_targets` for w gives point y of its plane."""
    n = cf.shape[0]
    total = 0.0
    pdf = 0.0
    for t in range(n):
        r = cf[t, CT_RADIUS]
        total += r * r
        c = (cf[t, CT_CENTER], cf[t, CT_CENTER + 1], cf[t, CT_CENTER + 2])
        along = dot(c, w)
        q = (y[0] - c[0] + along * w[0], y[1] - c[1] + along * w[1], y[2] - c[2] + along * w[2])
        if dot(q, q) <= r * r:
            pdf += (r * r) / (math.pi * r * r)
    return pdf / total if total > 0.0 else 0.0
