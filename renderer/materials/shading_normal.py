"""Shading normals: the normal a normal map or a bump map gives a material, and the rules that
keep such a normal from leaking light or creating energy.

A map changes only the normal the material's lobe is built around (its shading frame). The
integrator keeps the surface's own normal for everything geometric: which side a ray hit, where
the next ray starts, and (`same_side`) whether a direction is reflected or transmitted.

Conventions (written down here, where they are defined):

- The tangent frame of a hit is (t, b, n): n the surface's unit outward normal (a smooth mesh's
  interpolated one), t the unit direction of dp/du in n's plane, b = n x t, turned round when
  dp/dv points the other way (mirrored texture coordinates or a mirroring transform), so that b
  always goes the way v grows. The shapes give dp/du and dp/dv (shapes/dispatch.surface_derivatives).
- A normal map is a tangent-space map, glTF 2.0's `normalTexture`: a texel's RGB in [0, 1] is
  the unit normal (2 R - 1, 2 G - 1, 2 B - 1) in (t, b, n), +X to the right of the image (+u),
  +Y up the image (+v) and +Z out of the surface, with `normal_scale` multiplying X and Y before
  the vector is normalised. glTF's texture v runs down the image and ours runs up it (an image
  texture's row 0 is read at v = 1), so "up the image" is +v here: a glTF asset's maps need no
  change once its v is flipped into ours, which a glTF importer does anyway. The map's texels
  are data, to be read as linear values, not as sRGB colours.
- A bump map is a height field: its texture's first channel times `bump_height` (world units
  per texture unit) displaces the surface along n. The displaced surface's derivatives are
  dp/du + (dh/du) n and dp/dv + (dh/dv) n (pbrt's bump mapping without the h dn/du term, which
  is second order for the small heights bump maps hold); their cross product, on n's side, is
  the normal. dh/du and dh/dv are central differences of the height at (u +- du, v) and
  (u, v +- dv), the point moved along dp/du and dp/dv alike (textures that read the point, not
  (u, v), see the step too); an image's between the centres of the neighbouring texels,
  `BUMP_STEP` otherwise.

Rules for a normal that the map bends too far (each keeps every value finite, and none adds
energy):

1. A map's tangent-space normal whose Z is below `MIN_MAP_Z` (pointing into the surface, which
   no valid map holds) is raised to it: the shading normal stays on the outer side of the surface.
2. `facing_viewer`: the viewer (wo) must lie above the shading normal's plane by at least as
   much as above the surface's, up to `VIEW_MARGIN`: where it does not, the shading normal is
   bent toward wo, in the plane of the two, until it does. A lobe then always sees wo.z > 0, and
   a flat map (shading normal = the surface's) is never bent.
3. `same_side`: a direction (a light sample, or a sampled bounce) on one side of the surface and
   the other side of the shading normal's plane contributes nothing: the lobe took it for a
   reflection but it goes through the surface (or the reverse). Light never leaks through a
   normal-mapped wall; the energy of those directions is lost, not moved elsewhere.
"""

import math

from .. import target

from ..kernel_flags import SURFACE_MAPS
from ..numerics.frame import basis
from ..numerics.vec import cross, dot, madd, neg, scale, unit
from ..textures import TEX_HEIGHT, TEX_IMAGE, TEX_KIND, TEX_WIDTH, texture_value
from .table import MAT_BUMP_HEIGHT, MAT_BUMP_MAP, MAT_NORMAL_MAP, MAT_NORMAL_SCALE

# Rule 1: the least Z (cosine to the surface's normal, before normalising) of a map's normal.
MIN_MAP_Z = 0.01
# Rule 2: how far above the shading normal's plane the viewer must be (a cosine), at most.
VIEW_MARGIN = 0.01
# The finite difference step of a bump map in (u, v) for textures that have no texels
# (pbrt's default): small beside the unit square of (u, v), large beside rounding.
BUMP_STEP = 5e-4


@target.device
def tangent_frame(n, dpdu, dpdv):
    """(t, b) completing the unit normal n to the hit's tangent frame (see the module's
    docstring): t along dp/du in n's plane, b = n x t on the side dp/dv points to. Any frame
    (`basis`) where dp/du has no direction in n's plane (a sphere's pole, a degenerate triangle)."""
    along = madd(dpdu, n, -dot(n, dpdu))
    size2 = dot(along, along)
    # Relative to dp/du's own length: a tiny shape's tangents are as valid as a large one's.
    if not size2 > 1e-20 * dot(dpdu, dpdu) or size2 == 0.0:
        return basis(n)
    t = scale(along, 1.0 / math.sqrt(size2))
    b = cross(n, t)
    if dot(b, dpdv) < 0.0:
        b = neg(b)
    return t, b


@target.device
def normal_from_map(n, t, b, rgb, normal_scale):
    """The shading normal (unit, on n's side) a normal map's texel `rgb` gives in the tangent
    frame (t, b, n), glTF's decoding with its scale on X and Y, and rule 1. A flat texel
    ((0.5, 0.5, z) with z > 0.5) gives n itself, to the bit; so does one that is not finite."""
    x = (2.0 * rgb[0] - 1.0) * normal_scale
    y = (2.0 * rgb[1] - 1.0) * normal_scale
    z = max(2.0 * rgb[2] - 1.0, MIN_MAP_Z)
    if x == 0.0 and y == 0.0:
        return n
    m = unit(madd(madd(scale(n, z), t, x), b, y))
    # A texel that is not finite (an HDR image may hold inf or NaN) bends nothing.
    if not (math.isfinite(m[0]) and math.isfinite(m[1]) and math.isfinite(m[2])):
        return n
    return m


@target.device
def normal_from_bump(n, dpdu, dpdv, dhdu, dhdv):
    """The shading normal (unit, on n's side) of the surface displaced along n by a height h
    whose slopes are dh/du, dh/dv: the cross product of the displaced derivatives. Its component
    along n is that of dp/du x dp/dv, whatever the slopes, so its side is read from that. n
    itself where the slopes are 0 (to the bit) or the derivatives are degenerate."""
    if dhdu == 0.0 and dhdv == 0.0:
        return n
    side = dot(cross(dpdu, dpdv), n)
    if side == 0.0 or not math.isfinite(side):
        return n
    m = unit(cross(madd(dpdu, n, dhdu), madd(dpdv, n, dhdv)))
    # Slopes too steep to represent (an infinite or NaN height) leave the normal as it was.
    if (m[0] == 0.0 and m[1] == 0.0 and m[2] == 0.0) or not (math.isfinite(m[0]) and math.isfinite(m[1])
                                                             and math.isfinite(m[2])):
        return n
    return neg(m) if side < 0.0 else m


@target.device
def image_neighbours(tex_f, tex, u, v):
    """(u0, u1, v0, v1): the (u, v) of the centres of the texels on either side of the one an image
    texture row `tex` shows at (u, v), found as `texture_value` finds a texel (u and v clamped
    to [0, 1], row 0 at v = 1); at the image's border the texel itself stands for the missing
    neighbour, so the difference is one-sided there."""
    width, height = tex_f[tex, TEX_WIDTH], tex_f[tex, TEX_HEIGHT]
    i = min(width - 1.0, math.floor(min(1.0, max(0.0, u)) * width))
    j = min(height - 1.0, math.floor((1.0 - min(1.0, max(0.0, v))) * height))
    u0 = (max(i - 1.0, 0.0) + 0.5) / width
    u1 = (min(i + 1.0, width - 1.0) + 0.5) / width
    # Row j + 1 lies below row j: a smaller v.
    v0 = 1.0 - (min(j + 1.0, height - 1.0) + 0.5) / height
    v1 = 1.0 - (max(j - 1.0, 0.0) + 0.5) / height
    return u0, u1, v0, v1


@target.device
def height_slopes(tex_i, tex_f, texels, noise_perm, noise_vec, tex, height, u, v, p, dpdu, dpdv):
    """(dh/du, dh/dv) of the height `height` x (first channel of texture row `tex`) at (u, v) and
    point p, by central differences, the point moved along dp/du or dp/dv with (u, v) (textures
    that read the point see the step too). An image's are taken between the neighbouring texels'
    centres (`image_neighbours`): its lookup is nearest-texel, so a step shorter than a texel
    would see either nothing or a jump. Other textures step `BUMP_STEP` each way."""
    if tex_i[tex, TEX_KIND] == TEX_IMAGE:
        u0, u1, v0, v1 = image_neighbours(tex_f, tex, u, v)
    else:
        u0, u1, v0, v1 = u - BUMP_STEP, u + BUMP_STEP, v - BUMP_STEP, v + BUMP_STEP
    h_u1 = texture_value(tex_i, tex_f, texels, noise_perm, noise_vec, tex, u1, v, madd(p, dpdu, u1 - u))[0]
    h_u0 = texture_value(tex_i, tex_f, texels, noise_perm, noise_vec, tex, u0, v, madd(p, dpdu, u0 - u))[0]
    h_v1 = texture_value(tex_i, tex_f, texels, noise_perm, noise_vec, tex, u, v1, madd(p, dpdv, v1 - v))[0]
    h_v0 = texture_value(tex_i, tex_f, texels, noise_perm, noise_vec, tex, u, v0, madd(p, dpdv, v0 - v))[0]
    dhdu = height * (h_u1 - h_u0) / (u1 - u0) if u1 > u0 else 0.0
    dhdv = height * (h_v1 - h_v0) / (v1 - v0) if v1 > v0 else 0.0
    return dhdu, dhdv


@target.device
def facing_viewer(n_shading, n_surface, wo):
    """Rule 2: the shading normal (unit, on the viewer's side of the surface), bent toward the
    unit direction wo to the viewer only as far as needed for wo . n >= c, c = min(VIEW_MARGIN,
    wo . n_surface): n + s wo, normalised, with the s that gives wo . n = c exactly,

        s = c sqrt((1 - a^2) / (1 - c^2)) - a,   a = wo . n_shading,

    which is > 0 whenever a < c. Both n and wo lie on the outer side of the surface, so the bent
    normal does too. c <= wo . n_surface, so a normal equal to the surface's is never bent."""
    a = dot(wo, n_shading)
    c = min(VIEW_MARGIN, dot(wo, n_surface))
    if a >= c:
        return n_shading
    c = max(c, 0.0)
    s = c * math.sqrt(max(0.0, 1.0 - a * a) / (1.0 - c * c)) - a
    m = unit(madd(n_shading, wo, s))
    if m[0] == 0.0 and m[1] == 0.0 and m[2] == 0.0:
        return n_surface
    return m


@target.device
def same_side(w, n_surface, n_shading):
    """Rule 3: whether direction w lies on the same side of the surface (normal n_surface) as
    of the shading normal's plane: a direction that is a reflection for one and a transmission
    for the other carries nothing. True when the two normals are one."""
    return dot(w, n_surface) * dot(w, n_shading) >= 0.0


# --- what the integrator asks ------------------------------------------------------------------


@target.device
def has_shading_map(mat_i, mat):
    """Whether material row `mat` has a normal map or a bump map: only then does a hit on it
    need (u, v), its tangent frame and `shading_frame`. A kernel compiled without
    SURFACE_MAPS has no code for any of it."""
    return SURFACE_MAPS and (mat_i[mat, MAT_NORMAL_MAP] >= 0 or mat_i[mat, MAT_BUMP_MAP] >= 0)


@target.device
def shading_frame(S, mat, n, front_face, dpdu, dpdv, u, v, p, d):
    """The shading normal on the ray's side and the unit tangent (along dp/du) that material row
    `mat` (one that `has_shading_map`) has at a hit of the flat scene S: n the unit outward
    normal there, `front_face` whether the ray (direction d) came from outside, dp/du and
    dp/dv the shape's (shapes/dispatch.world_derivatives), (u, v) and p the hit's.

    The bump map bends n first, then the normal map bends that in its own tangent frame (the
    two compose as a detail map over a shape); the result is turned to the ray's side and kept
    facing the viewer (rule 2). The tangent is dp/du made orthogonal to n, which a material's
    frame (numerics/frame.frame_of) makes orthogonal to the shading normal in turn."""
    t, b = tangent_frame(n, dpdu, dpdv)
    shading = n
    bump = S.mat_i[mat, MAT_BUMP_MAP]
    if bump >= 0:
        dhdu, dhdv = height_slopes(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, bump,
                                   S.mat_f[mat, MAT_BUMP_HEIGHT], u, v, p, dpdu, dpdv)
        shading = normal_from_bump(n, dpdu, dpdv, dhdu, dhdv)
    normal_map = S.mat_i[mat, MAT_NORMAL_MAP]
    if normal_map >= 0:
        tm, bm = tangent_frame(shading, dpdu, dpdv) if bump >= 0 else (t, b)
        rgb = texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, normal_map, u, v, p)
        shading = normal_from_map(shading, tm, bm, rgb, S.mat_f[mat, MAT_NORMAL_SCALE])
    n_front = n if front_face else neg(n)
    if not front_face:
        shading = neg(shading)
    return facing_viewer(shading, n_front, neg(unit(d))), t
