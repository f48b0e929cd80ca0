"""Ray-primitive intersection against the slow references in tests/naive.py, on thousands of rays."""

import math
import random

import numpy as np
import pytest

from tests import naive
from scenefmt import models as m
from scenefmt.graph import build_graph
from renderer.compile import compile_scene
from renderer.tracing.probe import probe_rays

N_RAYS = 4000
MAT = m.Lambertian(albedo=(0.5, 0.5, 0.5))


def flat_of(*shapes, use_bvh=True):
    scene = m.Scene(camera=m.Camera(look_from=(0, 0, 10), look_at=(0, 0, 0)), shapes=list(shapes))
    return compile_scene(build_graph(scene), use_bvh=use_bvh)


def random_rays(rng, n, spread=4.0):
    """Rays from points around the origin aimed at points near it (so most hit)."""
    origins = rng.uniform(-spread, spread, (n, 3)) + rng.choice([-8.0, 8.0], (n, 3)) * (rng.random((n, 1)) < 0.5)
    targets = rng.uniform(-1.5, 1.5, (n, 3))
    dirs = (targets - origins) * rng.uniform(0.2, 3.0, (n, 1))  # not unit length, as the books allow
    return origins, dirs


def probe(flat, origins, dirs, brute=False):
    return probe_rays(flat, origins, dirs, 0.0, 0.0, brute)


def test_sphere_agrees_with_the_reference():
    rng = np.random.default_rng(1)
    c, r = (0.3, -0.2, 0.5), 1.1
    flat = flat_of(m.Sphere(center=c, radius=r, material=MAT))
    o, d = random_rays(rng, N_RAYS)
    t, prim, _, p, n, uv = probe(flat, o, d)
    hits = 0
    for k in range(N_RAYS):
        ref = naive.sphere(c, r, tuple(o[k]), tuple(d[k]))
        if ref is None:
            assert prim[k] < 0
            continue
        hits += 1
        assert t[k] == pytest.approx(ref[0], rel=1e-9, abs=1e-12)
        assert n[k] == pytest.approx(ref[1], abs=1e-9)
        # u wraps at the seam: compare on the circle.
        assert math.cos(2 * math.pi * uv[k, 0]) == pytest.approx(math.cos(2 * math.pi * ref[2][0]), abs=1e-7)
        assert uv[k, 1] == pytest.approx(ref[2][1], abs=1e-7)
    assert hits > N_RAYS // 4


@pytest.mark.parametrize("shape", ["quad", "triangle", "disk"])
def test_planar_shapes_agree_with_the_reference(shape):
    rng = np.random.default_rng({"quad": 2, "triangle": 3, "disk": 4}[shape])
    q = (-0.7, 0.2, 0.1)
    u, v = (1.6, 0.3, -0.4), (0.2, 1.2, 0.9)
    if shape == "quad":
        model = m.Quad(q=q, u=u, v=v, material=MAT)
    elif shape == "triangle":
        model = m.Triangle(vertices=(q, naive.add(q, u), naive.add(q, v)), material=MAT)
    else:
        normal = naive.unit(naive.cross(u, v))
        model = m.Disk(center=q, normal=normal, radius=1.3, material=MAT)
    flat = flat_of(model)
    if shape == "disk":
        # The disk's in-plane axes are the kernel's choice: read them back from its table row.
        row = flat.prims_f[0]
        w_axes = np.linalg.inv(np.array([row[7:10], row[10:13], row[3:6]]))
        u, v = tuple(w_axes[:, 0]), tuple(w_axes[:, 1])
    o, d = random_rays(rng, N_RAYS)
    t, prim, _, p, n, uv = probe(flat, o, d)
    hits = 0
    for k in range(N_RAYS):
        ref = naive.quad(q, u, v, tuple(o[k]), tuple(d[k]), shape=shape)
        if ref is not None and ref[3] < 1e-9:
            continue  # on the boundary: either answer is right
        if ref is None:
            assert prim[k] < 0, k
            continue
        hits += 1
        assert t[k] == pytest.approx(ref[0], rel=1e-9, abs=1e-12)
        assert n[k] == pytest.approx(ref[1], abs=1e-9)
        assert uv[k] == pytest.approx(ref[2], abs=1e-8)
    assert hits > N_RAYS // 20


BOX_TRANSFORMS = {
    # A transform that keeps the box axis-aligned makes one BOX row (a mirror and a scale
    # included); a rotation makes six quads.
    "plain": ([], 1),
    "mirrored and scaled": ([m.ScaleStep(scale=(-1.5, 0.7, 2.0)), m.TranslateStep(translate=(0.3, -0.2, 0.1))], 1),
    "rotated": ([m.RotateStep(rotate=m.Rotation(axis=(1, 2, 0), degrees=30))], 6),
}


@pytest.mark.parametrize("name", list(BOX_TRANSFORMS))
def test_box_agrees_with_the_reference(name):
    from scenefmt import affine
    from renderer import shapes as L

    steps, rows = BOX_TRANSFORMS[name]
    rng = np.random.default_rng(5)
    lo, hi = (-1.0, -0.5, -0.8), (0.9, 1.2, 0.7)
    flat = flat_of(m.Box(min=lo, max=hi, material=MAT, transform=steps))
    assert len(flat.prims_i) == rows and set(flat.prims_i[:, 0]) == {L.BOX if rows == 1 else L.QUAD}
    world = affine.from_steps(steps) if steps else affine.IDENTITY
    inv = naive.inverse(world)
    o, d = random_rays(rng, N_RAYS)
    t, prim, _, p, n, _ = probe(flat, o, d)
    hits = inside = 0
    for k in range(N_RAYS):
        ref = naive.box(lo, hi, naive.apply(inv, tuple(o[k])), naive.apply_linear(inv, tuple(d[k])))
        if ref is None:
            assert prim[k] < 0
            continue
        hits += 1
        inside += all(lo[a] < naive.apply(inv, tuple(o[k]))[a] < hi[a] for a in range(3))
        assert t[k] == pytest.approx(ref[0], rel=1e-9, abs=1e-12)
        assert n[k] == pytest.approx(naive.transform_normal(world, ref[1]), abs=1e-9)
        assert p[k] == pytest.approx(np.array(o[k]) + ref[0] * np.array(d[k]), abs=1e-9)
    assert hits > N_RAYS // 4 and inside > 20  # rays from inside meet the box where they leave it


def test_a_box_whose_material_reads_uv_or_that_bounds_a_medium_keeps_its_quads(tmp_path):
    """An image texture needs each face's (u, v), and a medium's boundary is tested as planes:
    both stay six quads. A box with both a surface and a medium has a box row and six quads."""
    from PIL import Image
    from renderer import shapes as L

    Image.fromarray(np.zeros((2, 2, 3), np.uint8), "RGB").save(tmp_path / "tex.png")
    textured = m.Lambertian(albedo=m.ImageTexture(file=str(tmp_path / "tex.png")))
    flat = flat_of(m.Box(min=(0, 0, 0), max=(1, 1, 1), material=textured))
    assert list(flat.prims_i[:, 0]) == [L.QUAD] * 6
    fog = m.ConstantMedium(density=0.5)
    flat = flat_of(m.Box(min=(0, 0, 0), max=(1, 1, 1), material=MAT, interior=fog))
    assert sorted(flat.prims_i[:, 0]) == sorted([L.BOX, L.MEDIUM])
    assert list(flat.bnd_i) == [L.QUAD] * 6


def test_instances_agree_with_the_reference():
    """A group placed twice, once under a non-uniform scale (an ellipsoid and a sheared box)."""
    rng = np.random.default_rng(6)
    sphere = m.Sphere(center=(0.2, 0, 0), radius=0.8, material=MAT)
    box = m.Box(min=(-0.5, -0.5, -0.5), max=(0.5, 0.4, 0.3), material=MAT)
    steps = [m.ScaleStep(scale=(1.5, 0.6, 1.0)), m.RotateStep(rotate=m.Rotation(axis=(1, 1, 0), degrees=33)),
             m.TranslateStep(translate=(0.4, -0.3, 0.2))]
    group = m.Group(shapes=[sphere, box])
    flat = flat_of(m.Instance(group=group, transform=steps))
    from scenefmt import affine
    world = affine.from_steps(steps)
    inv = naive.inverse(world)
    o, d = random_rays(rng, N_RAYS)
    t, prim, inst, p, n, _ = probe(flat, o, d)
    hits = 0
    for k in range(N_RAYS):
        oo = naive.apply(inv, tuple(o[k]))
        dd = naive.apply_linear(inv, tuple(d[k]))
        cands = []
        hs = naive.sphere((0.2, 0, 0), 0.8, oo, dd)
        if hs:
            cands.append((hs[0], hs[1]))
        hb = naive.box((-0.5, -0.5, -0.5), (0.5, 0.4, 0.3), oo, dd)
        if hb:
            cands.append(hb)
        if not cands:
            assert prim[k] < 0
            continue
        ref_t, ref_n = min(cands)
        hits += 1
        assert t[k] == pytest.approx(ref_t, rel=1e-9, abs=1e-12)
        assert n[k] == pytest.approx(naive.transform_normal(world, ref_n), abs=1e-9)
        assert p[k] == pytest.approx(np.array(o[k]) + ref_t * np.array(d[k]), abs=1e-9)
    assert hits > N_RAYS // 5


def test_bvh_finds_the_same_hits_as_brute_force_on_many_primitives():
    rng = random.Random(7)
    shapes = []
    for _ in range(300):
        c = tuple(rng.uniform(-3, 3) for _ in range(3))
        if rng.random() < 0.5:
            shapes.append(m.Sphere(center=c, radius=rng.uniform(0.05, 0.3), material=MAT))
        else:
            u = tuple(rng.uniform(-0.5, 0.5) for _ in range(3))
            v = tuple(rng.uniform(-0.5, 0.5) for _ in range(3))
            shapes.append(m.Quad(q=c, u=u, v=v, material=MAT))
    group = m.Group(shapes=shapes[:50])
    shapes.append(m.Instance(group=group, transform=[m.RotateStep(rotate=m.Rotation(axis="z", degrees=40))]))
    shapes.append(m.Instance(group=group, transform=[m.TranslateStep(translate=(0.5, 0.1, -0.2))]))
    flat = flat_of(*shapes)
    o, d = random_rays(np.random.default_rng(8), N_RAYS)
    t1, p1, i1, *_ = probe(flat, o, d, brute=False)
    t2, p2, i2, *_ = probe(flat, o, d, brute=True)
    assert (p1 >= 0).sum() > N_RAYS // 2
    assert np.array_equal(p1, p2) and np.array_equal(i1, i2)
    assert np.array_equal(t1, t2)


@pytest.mark.parametrize("point, uv", [
    ((1, 0, 0), (0.50, 0.50)), ((-1, 0, 0), (0.00, 0.50)), ((0, 1, 0), (0.50, 1.00)),
    ((0, -1, 0), (0.50, 0.00)), ((0, 0, 1), (0.25, 0.50)), ((0, 0, -1), (0.75, 0.50)),
])
def test_sphere_uv_matches_the_books_test_vectors(point, uv):
    flat = flat_of(m.Sphere(center=(0, 0, 0), radius=1, material=MAT))
    origin = np.array([point], float) * 3.0
    t, prim, _, p, n, got = probe(flat, origin, -origin)
    assert prim[0] >= 0
    # At the poles u is undefined; the books' vectors give 0.5 there, as atan2(0, 0) does.
    assert got[0] == pytest.approx(uv, abs=1e-12) or (abs(point[1]) == 1 and got[0, 1] == pytest.approx(uv[1]))


def test_quad_plane_coordinates_of_the_books_example():
    q, u, v = (0, 0, 0), (0, 0, 2), (0, 1, 0)
    flat = flat_of(m.Quad(q=q, u=u, v=v, material=MAT))
    target = np.array([0.0, 0.5, 2.0])  # Q + 1 u + 1/2 v, on the boundary: a hit with closed intervals
    origin = target + np.array([3.0, 0.0, 0.0])
    t, prim, _, p, n, uv = probe(flat, origin[None], (target - origin)[None])
    assert prim[0] >= 0 and uv[0] == pytest.approx((1.0, 0.5), abs=1e-12)
