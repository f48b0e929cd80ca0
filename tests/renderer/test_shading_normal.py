"""Shading normals from normal and bump maps (renderer/materials/shading_normal.py) and the
tangents the shapes give them (shapes/*: `*_derivatives`, shapes/dispatch.surface_derivatives).

The device functions are called un-jitted (`.py_func`; what they call is compiled, small), so
this file stays fast. Each shape family's dp/du and dp/dv are checked against its own (u, v):
two nearby points of the surface differ by dp/du du + dp/dv dv to first order. The maps are
checked on the normals they give: a flat texel leaves the normal alone to the bit, a tilted
one tilts it by its angle in the direction of +u or +v, a ramp of heights tilts it by the
arc tangent of its slope, and the three rules for a normal bent too far keep every value
finite and the viewer above the shading plane.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.materials import shading_normal as sn
from renderer.shapes import DISK, MOVING_SPHERE, QUAD, SPHERE, TRIANGLE
from renderer.shapes import meshes, planar, spheres
from renderer.shapes.meshes import MESH_I, TRIANGLE_I
from renderer.textures import IMAGE_F, TEX_IMAGE, TEXTURE_I, TEXTURE_WIDTH

SEED = 31


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def tup(v):
    return tuple(float(x) for x in v)


def random_rotation(rng, mirror=False):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    if mirror:
        q[:, 2] = -q[:, 2]
    return q


# --- the tangent frame ------------------------------------------------------------------------


def test_tangent_frame_is_orthonormal_along_u_and_on_the_side_of_v():
    rng = np.random.default_rng(SEED)
    for _ in range(200):
        n = unit(rng.normal(size=3))
        dpdu, dpdv = rng.normal(size=3) * 3.0, rng.normal(size=3) * 0.2
        t, b = (np.array(x) for x in sn.tangent_frame.py_func(tup(n), tup(dpdu), tup(dpdv)))
        for x in (t, b):
            assert np.linalg.norm(x) == pytest.approx(1.0, abs=1e-12)
            assert abs(x @ n) < 1e-12
        assert abs(t @ b) < 1e-12
        # t is dp/du in n's plane: along it, and b goes the way v grows.
        assert t @ dpdu > 0 and np.linalg.norm(np.cross(t, dpdu - (dpdu @ n) * n)) < 1e-9 * np.linalg.norm(dpdu)
        assert b @ dpdv >= 0
        # Right-handed (t, b, n) exactly when (u, v) turns counter-clockwise about n.
        assert np.sign(np.cross(t, b) @ n) == np.sign(np.cross(dpdu, dpdv) @ n)


def test_tangent_frame_falls_back_to_any_frame_where_u_has_no_direction():
    n = (0.0, 0.0, 1.0)
    for dpdu in ((0.0, 0.0, 0.0), (0.0, 0.0, 2.0), (1e-300, 0.0, 0.0)):
        t, b = sn.tangent_frame.py_func(n, dpdu, (0.0, 1.0, 0.0))
        assert np.isfinite(t).all() and np.isfinite(b).all()
        assert abs(np.dot(t, n)) < 1e-12 and abs(np.dot(b, n)) < 1e-12 and abs(np.dot(t, b)) < 1e-12
    # A tiny but valid shape keeps its own tangent.
    t, _ = sn.tangent_frame.py_func(n, (1e-30, 1e-31, 0.0), (0.0, 1e-30, 0.0))
    assert t[0] > 0.99


# --- normal maps ------------------------------------------------------------------------------


FRAME = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]))


def mapped(rgb, scale=1.0, frame=FRAME):
    t, b, n = frame
    return np.array(sn.normal_from_map.py_func(tup(n), tup(t), tup(b), tup(rgb), scale))


def test_a_flat_texel_leaves_the_normal_to_the_bit():
    rng = np.random.default_rng(SEED + 1)
    for _ in range(50):
        n = tup(unit(rng.normal(size=3)))
        t, b = sn.tangent_frame.py_func(n, tup(rng.normal(size=3)), tup(rng.normal(size=3)))
        for z in (1.0, 0.9, 0.51):
            assert sn.normal_from_map.py_func(n, t, b, (0.5, 0.5, z), 1.7) == n


@pytest.mark.parametrize("degrees", [5.0, 30.0, 60.0, 85.0])
def test_a_tilted_texel_tilts_the_normal_by_its_angle_toward_u_or_v(degrees):
    a = math.radians(degrees)
    rng = np.random.default_rng(SEED + 2)
    n = unit(rng.normal(size=3))
    t, b = (np.array(x) for x in sn.tangent_frame.py_func(tup(n), tup(rng.normal(size=3)), tup(rng.normal(size=3))))
    # +X of the map leans the normal toward +u (t), +Y toward +v (b).
    along_u = mapped((0.5 + 0.5 * math.sin(a), 0.5, 0.5 + 0.5 * math.cos(a)), frame=(t, b, n))
    along_v = mapped((0.5, 0.5 + 0.5 * math.sin(a), 0.5 + 0.5 * math.cos(a)), frame=(t, b, n))
    for m, toward in ((along_u, t), (along_v, b)):
        assert np.linalg.norm(m) == pytest.approx(1.0, abs=1e-12)
        assert math.degrees(math.acos(min(1.0, m @ n))) == pytest.approx(degrees, abs=1e-9)
        np.testing.assert_allclose(m, math.cos(a) * n + math.sin(a) * toward, atol=1e-12)


def test_normal_scale_multiplies_x_and_y_as_gltf_does():
    rgb = (0.7, 0.4, 0.9)
    x, y, z = 2 * 0.7 - 1, 2 * 0.4 - 1, 2 * 0.9 - 1
    for scale in (0.0, 0.5, 2.0):
        expected = unit((x * scale, y * scale, z))
        np.testing.assert_allclose(mapped(rgb, scale), expected, atol=1e-12)


def test_texels_and_slopes_that_are_not_finite_bend_nothing():
    """An HDR image may hold inf or NaN: the normal stays the surface's, never NaN."""
    n = (0.0, 0.0, 1.0)
    for rgb in ((math.inf, 0.5, 1.0), (math.nan, 0.5, 1.0), (0.5, -math.inf, 1.0), (0.7, 0.5, math.inf)):
        assert sn.normal_from_map.py_func(n, (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), rgb, 1.0) == n
    for dhdu, dhdv in ((math.inf, 0.0), (math.nan, 1.0), (-math.inf, math.inf)):
        assert sn.normal_from_bump.py_func(n, (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), dhdu, dhdv) == n
    for dpdu in ((math.nan, 0.0, 0.0), (math.inf, 1.0, 0.0)):
        t, b = sn.tangent_frame.py_func(n, dpdu, (0.0, 1.0, 0.0))
        assert np.isfinite(t).all() and np.isfinite(b).all()


def test_a_texel_pointing_into_the_surface_is_raised_above_it():
    """Rule 1: no valid map holds Z < 0; such a texel gives a normal on the outer side all the same."""
    for rgb in ((1.0, 0.5, 0.0), (0.0, 0.0, 0.0), (0.5, 1.0, 0.3), (1.0, 1.0, 0.5)):
        m = mapped(rgb, 3.0)
        assert np.isfinite(m).all() and np.linalg.norm(m) == pytest.approx(1.0)
        assert m[2] > 0.0


# --- bump maps --------------------------------------------------------------------------------


def ramp_texture(width=64, height=8, slope_u=1.0, slope_v=0.0):
    """Texture tables holding one image (row 0) whose first channel at texel (i, j) is the
    height slope_u u + slope_v v at the texel's centre (row 0 of the image at the top, v = 1)."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    h = slope_u * u[None, :] + slope_v * v[:, None]
    texels = np.repeat(h.reshape(-1, 1), 3, axis=1).astype(np.float32)
    tex_i = np.array([TEXTURE_I.row(kind=TEX_IMAGE, even=-1, odd=-1)], np.int32)
    tex_f = np.array([IMAGE_F.row(texels=0.0, width=float(width), height=float(height))], np.float64)
    assert tex_f.shape[1] == TEXTURE_WIDTH
    return tex_i, tex_f, texels, np.zeros((1, 3, 256), np.int32), np.zeros((1, 256, 3))


def bumped(tables, height, uv, p, dpdu, dpdv, n):
    dhdu, dhdv = sn.height_slopes.py_func(*tables, 0, height, uv[0], uv[1], tup(p), tup(dpdu), tup(dpdv))
    return np.array(sn.normal_from_bump.py_func(tup(n), tup(dpdu), tup(dpdv), dhdu, dhdv)), (dhdu, dhdv)


@pytest.mark.parametrize("bump_height", [0.05, 0.4, 3.0])
def test_a_bump_ramp_tilts_the_normal_by_the_arc_tangent_of_its_slope(bump_height):
    """A height rising by `bump_height` across a quad whose u edge is 2 long (v edge 3): the
    slope is bump_height / 2 and the normal leans back from +u by atan of it."""
    tables = ramp_texture(slope_u=1.0)
    dpdu, dpdv, n = np.array([2.0, 0.0, 0.0]), np.array([0.0, 3.0, 0.0]), np.array([0.0, 0.0, 1.0])
    for uv in ((0.5, 0.5), (0.23, 0.71), (0.9, 0.1)):
        p = uv[0] * dpdu + uv[1] * dpdv
        m, (dhdu, dhdv) = bumped(tables, bump_height, uv, p, dpdu, dpdv, n)
        assert dhdu == pytest.approx(bump_height, rel=1e-6) and dhdv == 0.0
        slope = bump_height / 2.0
        assert math.atan2(-m[0], m[2]) == pytest.approx(math.atan(slope), abs=1e-6)
        assert m[1] == 0.0 and np.linalg.norm(m) == pytest.approx(1.0, abs=1e-12)


def test_a_bump_ramp_along_v_tilts_toward_minus_v_and_a_flat_one_not_at_all():
    tables = ramp_texture(slope_u=0.0, slope_v=1.0)
    dpdu, dpdv, n = np.array([2.0, 0.0, 0.0]), np.array([0.0, 3.0, 0.0]), np.array([0.0, 0.0, 1.0])
    m, _ = bumped(tables, 0.6, (0.4, 0.5), (0.8, 1.5, 0.0), dpdu, dpdv, n)
    assert math.atan2(-m[1], m[2]) == pytest.approx(math.atan(0.6 / 3.0), abs=1e-6)
    flat = ramp_texture(slope_u=0.0, slope_v=0.0)
    m, _ = bumped(flat, 5.0, (0.4, 0.5), (0.8, 1.5, 0.0), dpdu, dpdv, n)
    assert tup(m) == (0.0, 0.0, 1.0)


def test_a_bump_normal_stays_on_the_normals_side_under_mirrored_uv():
    n = (0.0, 0.0, 1.0)
    m = sn.normal_from_bump.py_func(n, (2.0, 0.0, 0.0), (0.0, -3.0, 0.0), 1.0, 0.0)
    assert m[2] > 0 and m[0] < 0
    # Degenerate derivatives: the normal as it was.
    assert sn.normal_from_bump.py_func(n, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0, 1.0) == n
    assert sn.normal_from_bump.py_func(n, (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1e300, 1e300)[2] > 0.0


def test_bump_slopes_at_the_image_border_are_one_sided_not_halved():
    tables = ramp_texture(slope_u=1.0, slope_v=0.5)
    for u, v in ((0.0, 0.0), (0.001, 0.999), (0.999, 0.5), (1.0, 1.0), (-3.0, 7.0)):
        dhdu, dhdv = sn.height_slopes.py_func(*tables, 0, 1.0, u, v, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
        assert dhdu == pytest.approx(1.0, rel=1e-6) and dhdv == pytest.approx(0.5, rel=1e-6)
    # A one-texel image has no slope at all.
    dhdu, dhdv = sn.height_slopes.py_func(*ramp_texture(1, 1), 0, 1.0, 0.5, 0.5, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0),
                                          (0.0, 1.0, 0.0))
    assert dhdu == 0.0 and dhdv == 0.0


# --- the rules for a normal bent too far ------------------------------------------------------


def test_facing_viewer_keeps_a_good_normal_and_bends_a_bad_one_just_enough():
    """Rule 2, on random normals of a wild map (anywhere on the outer hemisphere) and viewers from
    straight above to grazing: the result is a finite unit vector on the outer side with
    wo . n >= min(VIEW_MARGIN, wo . n_surface), equal to it where the normal had to bend, and
    the normal itself where it need not."""
    rng = np.random.default_rng(SEED + 3)
    ng = np.array([0.0, 0.0, 1.0])
    bent = 0
    for k in range(4000):
        ns = unit(rng.normal(size=3))
        ns[2] = abs(ns[2]) * (1e-3 if k % 4 == 0 else 1.0)
        ns = unit(ns)
        wo = unit(rng.normal(size=3))
        wo[2] = abs(wo[2]) * (10.0 ** -rng.integers(0, 8) if k % 2 else 1.0)
        wo = unit(wo)
        m = np.array(sn.facing_viewer.py_func(tup(ns), tup(ng), tup(wo)))
        assert np.isfinite(m).all() and np.linalg.norm(m) == pytest.approx(1.0, abs=1e-12)
        assert m[2] > 0.0
        c = min(sn.VIEW_MARGIN, wo @ ng)
        a = ns @ wo
        if a >= c:
            assert tup(m) == tup(ns)
        else:
            bent += 1
            assert m @ wo == pytest.approx(c, abs=1e-9)
            # In the plane of the normal and the viewer.
            assert abs(np.linalg.det(np.stack([m, ns, wo]))) < 1e-9
    assert bent > 500
    # The surface's own normal is never bent, even at the most grazing view.
    for z in (1.0, 1e-3, 1e-12, 0.0):
        wo = unit((1.0, 0.0, z)) if z else np.array([1.0, 0.0, 0.0])
        assert sn.facing_viewer.py_func(tup(ng), tup(ng), tup(wo)) == tup(ng)


def test_same_side_refuses_a_reflection_through_the_surface():
    """Rule 3: a direction above the shading plane but below the surface (or the reverse)."""
    ng, ns = (0.0, 0.0, 1.0), tup(unit((0.8, 0.0, 0.6)))
    assert sn.same_side.py_func((0.0, 0.0, 1.0), ng, ns)
    assert sn.same_side.py_func((0.0, 0.0, -1.0), ng, ns)  # a transmission for both
    assert not sn.same_side.py_func(tup(unit((1.0, 0.0, -0.2))), ng, ns)  # reflected per the map, below the surface
    assert not sn.same_side.py_func(tup(unit((-1.0, 0.0, 0.2))), ng, ns)  # transmitted per the map, above it
    rng = np.random.default_rng(SEED + 4)
    for _ in range(100):
        w = tup(unit(rng.normal(size=3)))
        assert sn.same_side.py_func(w, ng, ng)


# --- each shape's dp/du and dp/dv against its own (u, v) ----------------------------------------


def check_first_order(p, uv, derivs, neighbours, n):
    """For each neighbour (point, (u, v)) a small step from p: dp/du du + dp/dv dv gives the step
    to first order, and dp/du, dp/dv lie in the surface's plane at p."""
    dpdu, dpdv = (np.array(x) for x in derivs)
    for x in (dpdu, dpdv):
        assert abs(x @ n) <= 1e-9 * np.linalg.norm(x)
    for q, quv in neighbours:
        step = np.asarray(q) - np.asarray(p)
        predicted = dpdu * (quv[0] - uv[0]) + dpdv * (quv[1] - uv[1])
        assert np.linalg.norm(predicted - step) <= 1e-3 * np.linalg.norm(step) + 1e-12, (predicted, step)


def sphere_data(kind, center, radius, rotation):
    row = np.zeros(16)
    row[0:3], row[3] = center, radius
    k = spheres.SPHERE_ROTATION if kind == SPHERE else spheres.MOVING_ROTATION
    row[k:k + 9] = np.asarray(rotation).ravel()
    return row[None, :]


@pytest.mark.parametrize("kind, mirror", [(SPHERE, False), (SPHERE, True), (MOVING_SPHERE, False)])
def test_a_spheres_derivatives_follow_its_uv(kind, mirror):
    rng = np.random.default_rng(SEED + 5)
    rot = random_rotation(rng, mirror)
    c, r = np.array([0.3, -1.0, 2.0]), 1.7
    data = sphere_data(kind, c, r, rot)

    def at(n):
        p, nn, u, v = spheres.sphere_surface.py_func(kind, data, 0, tup(c + r * n), 0.0, True)
        return np.array(p), np.array(nn), (u, v)

    for _ in range(100):
        n = unit(rng.normal(size=3))
        p, n, uv = at(n)
        if min(uv[0], 1 - uv[0], uv[1], 1 - uv[1]) < 0.01:
            continue  # the seam of u and the poles
        derivs = spheres.sphere_derivatives.py_func(kind, data, 0, tup(n))
        e1, e2 = sn.tangent_frame.py_func(tup(n), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
        neighbours = [at(unit(n + 1e-5 * np.asarray(e)))[0::2] for e in (e1, e2, np.add(e1, e2))]
        check_first_order(p, uv, derivs, neighbours, n)
        assert np.linalg.norm(derivs[0]) == pytest.approx(2 * math.pi * r * math.sin(math.pi * uv[1]), rel=1e-9)
        assert np.linalg.norm(derivs[1]) == pytest.approx(math.pi * r, rel=1e-9)
    # At a pole u has no direction: zero, and finite.
    pole = rot.T @ np.array([0.0, -1.0, 0.0])
    assert spheres.sphere_derivatives.py_func(kind, data, 0, tup(pole)) == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


@pytest.mark.parametrize("kind", [QUAD, TRIANGLE, DISK])
@pytest.mark.parametrize("flip", [False, True])
def test_planar_derivatives_follow_their_uv(kind, flip):
    rng = np.random.default_rng(SEED + 6)
    for _ in range(20):
        q, eu, ev = rng.normal(size=3), rng.normal(size=3) * 2, rng.normal(size=3)
        data = np.array([planar.planar_row(tup(q), tup(eu), tup(ev), flip)])
        n = data[0, planar.PLANAR_NORMAL:planar.PLANAR_NORMAL + 3]
        derivs = planar.planar_derivatives.py_func(kind, data, 0)
        np.testing.assert_allclose(derivs[0], eu * (2 if kind == DISK else 1), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(derivs[1], ev * (2 if kind == DISK else 1), rtol=1e-9, atol=1e-9)
        a, b = rng.random(2) * 0.4 + (0.0 if kind != DISK else -0.2)

        def at(alpha, beta):
            p = q + alpha * eu + beta * ev
            _, u, v = planar.planar_surface.py_func(kind, data, 0, tup(p))
            return p, (u, v)

        p, uv = at(a, b)
        check_first_order(p, uv, derivs, [at(a + 0.01, b), at(a, b + 0.01), at(a - 0.02, b + 0.01)], n)


def one_mesh(corners, uvs):
    """The mesh tables of one triangle with the given corners and texture coordinates (or None)."""
    tri_i = np.array([TRIANGLE_I.row(vertex=(0, 1, 2), mesh=0)], np.int32)
    mesh_i = np.array([MESH_I.row(first_vertex=0, normals=-1, uvs=-1 if uvs is None else 0)], np.int32)
    verts_uv = np.zeros((1, 2)) if uvs is None else np.asarray(uvs, float)
    return tri_i, mesh_i, np.asarray(corners, float), np.zeros((1, 3)), verts_uv


@pytest.mark.parametrize("uvs", [None, [(0.1, 0.2), (0.9, 0.3), (0.4, 0.8)], [(0.1, 0.2), (0.4, 0.8), (0.9, 0.3)],
                                 [(0.0, 0.0), (2.0, 0.0), (0.0, -0.5)]])
def test_mesh_derivatives_follow_its_uv(uvs):
    """With texture coordinates (turning either way) and without (barycentric (u, v))."""
    rng = np.random.default_rng(SEED + 7)
    corners = rng.normal(size=(3, 3)) * 2
    tri_i, mesh_i, verts_f, verts_n, verts_uv = one_mesh(corners, uvs)
    derivs = meshes.mesh_derivatives.py_func(tri_i, mesh_i, verts_f, verts_uv, 0)
    n = unit(np.cross(corners[1] - corners[0], corners[2] - corners[0]))
    origin = corners.mean(axis=0) + 3 * n

    def at(b1, b2):
        target = (1 - b1 - b2) * corners[0] + b1 * corners[1] + b2 * corners[2]
        p, _, u, v = meshes.mesh_surface.py_func(tri_i, mesh_i, verts_f, verts_n, verts_uv, 0, tup(origin),
                                                 tup(target - origin), True)
        return np.array(p), (u, v)

    p, uv = at(0.3, 0.3)
    check_first_order(p, uv, derivs, [at(0.35, 0.3), at(0.3, 0.36), at(0.25, 0.33)], n)


def test_mesh_derivatives_of_degenerate_uv_fall_back_to_the_barycentric_ones():
    corners = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 1, 0]])
    tri_i, mesh_i, verts_f, _, verts_uv = one_mesh(corners, [(0.5, 0.5), (0.5, 0.5), (0.5, 0.5)])
    dpdu, dpdv = meshes.mesh_derivatives.py_func(tri_i, mesh_i, verts_f, verts_uv, 0)
    assert dpdu == (1.0, 0.0, 0.0) and dpdv == (0.0, 1.0, 0.0)
