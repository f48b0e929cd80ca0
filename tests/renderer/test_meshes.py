"""Triangle meshes in the kernels: the watertight test, the reference, trees, instancing, images."""

import math

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.tracing.probe import probe_rays
from renderer.render import render
from renderer.shapes import MESH_TRIANGLE
from renderer.variants import GENERAL
from scenefmt import meshgen
from scenefmt import models as m
from scenefmt.graph import build_graph
from tests import naive
from tests.renderer.stats import block_z, z_limit

pytestmark = pytest.mark.slow

MAT = m.Lambertian(albedo=(0.5, 0.5, 0.5))


def flat_of(*shapes, use_bvh=True, groups=None):
    scene = m.Scene(camera=m.Camera(look_from=(0, 0, 10), look_at=(0, 0, 0)), shapes=list(shapes), groups=groups or {})
    return compile_scene(build_graph(scene), use_bvh=use_bvh)


def probe(flat, origins, dirs, brute=False):
    return probe_rays(flat, np.ascontiguousarray(origins, np.float64), np.ascontiguousarray(dirs, np.float64), 0.0, 0.0, brute)


def test_rays_from_inside_a_closed_mesh_all_hit_it_even_through_its_vertices_and_edges():
    v, f = meshgen.icosphere(6)  # 720 triangles
    flat = flat_of(m.Mesh(vertices=v, faces=f, material=MAT))
    rng = np.random.default_rng(3)
    # Aimed exactly at every vertex and every edge's midpoint (where a non-watertight test
    # leaks), then at random points, from origins scattered inside.
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    targets = np.concatenate([v, 0.5 * (v[edges[:, 0]] + v[edges[:, 1]]), rng.normal(size=(4000, 3))])
    origins = rng.uniform(-0.3, 0.3, (len(targets), 3))
    origins[: len(v)] = 0.0  # from the centre, through the vertices themselves
    t, prim, *_ = probe(flat, origins, targets - origins)
    assert (prim >= 0).all(), f"{(prim < 0).sum()} of {len(prim)} rays leaked out"
    assert np.isfinite(t).all()


def _naive_mesh_hit(v, f, o, d):
    """(t, unit normal, (b1, b2), margin) of the nearest triangle, by naive.quad(shape='triangle')."""
    best = None
    for a, b, c in f:
        hit = naive.quad(tuple(v[a]), tuple(v[b] - v[a]), tuple(v[c] - v[a]), o, d, shape="triangle")
        if hit is not None and (best is None or hit[0] < best[0]):
            best = hit
    return best


def test_mesh_hits_agree_with_the_reference_on_random_rays():
    v, f = meshgen.torus_knot(segments=24, sides=6)  # 288 triangles
    transform = [m.RotateStep(rotate=m.Rotation(axis=(1, 2, 0), degrees=30)), m.TranslateStep(translate=(0.1, 0, 0))]
    flat = flat_of(m.Mesh(vertices=v, faces=f, material=MAT, transform=transform))
    from scenefmt import affine
    world = affine.from_steps(transform)
    vw = np.array([naive.apply(world, tuple(p)) for p in v])
    rng = np.random.default_rng(11)
    n = 600
    origins = rng.uniform(-4, 4, (n, 3))
    dirs = (rng.uniform(-1.2, 1.2, (n, 3)) - origins) * rng.uniform(0.3, 2.0, (n, 1))
    t, prim, _, p, nrm, uv = probe(flat, origins, dirs)
    hits = 0
    for k in range(n):
        ref = _naive_mesh_hit(vw, f, tuple(origins[k]), tuple(dirs[k]))
        if ref is None:
            assert prim[k] < 0
            continue
        if ref[3] < 1e-9:
            continue  # on an edge: either neighbour is right
        hits += 1
        assert t[k] == pytest.approx(ref[0], rel=1e-9, abs=1e-12)
        assert nrm[k] == pytest.approx(ref[1], abs=1e-9)
        assert uv[k] == pytest.approx(ref[2], abs=1e-7)  # barycentric (b1, b2) without file uvs
        assert p[k] == pytest.approx(origins[k] + ref[0] * dirs[k], abs=1e-9)
    assert hits > n // 5


def test_a_tree_of_shapes_and_a_mesh_and_its_instances_agree_with_brute_force():
    v, f = meshgen.terrain(12, size=4.0, height=0.4)
    mesh = m.Mesh(vertices=v, faces=f, material=MAT)
    group = m.Group(shapes=[mesh, m.Sphere(center=(0, 1, 0), radius=0.5, material=MAT)])
    shapes = [m.Sphere(center=(1, -1, 0), radius=0.7, material=MAT), mesh,
              m.Instance(group="g", transform=[m.RotateStep(rotate=m.Rotation(axis="x", degrees=70))]),
              m.Instance(group="g", transform=[m.TranslateStep(translate=(0.5, 0.3, -1.0))])]
    flat = flat_of(*shapes, groups={"g": group})
    # The group's mesh is flattened once, whatever the number of instances.
    assert len(flat.mesh_i) == 2 and len(flat.tri_i) == 2 * len(f)
    assert (flat.prims_i[len(flat.prims_f):, 0] == MESH_TRIANGLE).all()
    rng = np.random.default_rng(5)
    o = rng.uniform(-5, 5, (3000, 3))
    d = rng.uniform(-1.5, 1.5, (3000, 3)) - o
    t1, p1, i1, *_ = probe(flat, o, d)
    t2, p2, i2, *_ = probe(flat, o, d, brute=True)
    assert (p1 >= len(flat.prims_f)).sum() > 300 and (p1 >= 0).sum() > 1000
    assert np.array_equal(p1, p2) and np.array_equal(i1, i2) and np.array_equal(t1, t2)
    t3, p3, i3, *_ = probe(flat_of(*shapes, use_bvh=False, groups={"g": group}), o, d)
    assert np.array_equal(t1, t3)


def test_normals_and_texture_coordinates_are_interpolated_as_computed_by_hand(tmp_path):
    # One triangle in z = 0 with a normal and a (u, v) per corner.
    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 2 0 0\nv 0 2 0\nvt 0.1 0.2\nvt 0.9 0.2\nvt 0.1 0.6\n"
                   "vn 0 0 1\nvn 1 0 1\nvn 0 1 1\nf 1/1/1 2/2/2 3/3/3\n")
    scene = m.Scene(camera=m.Camera(look_from=(0, 0, 10), look_at=(0, 0, 0)),
                    shapes=[m.Mesh(file=str(obj), smooth=True, material=MAT)])
    flat = compile_scene(build_graph(scene))
    # The point (0.5, 0.5): barycentric weights (0.5, 0.25, 0.25).
    t, prim, _, p, n, uv = probe(flat, np.array([[0.5, 0.5, 3.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert t[0] == pytest.approx(3.0) and p[0] == pytest.approx((0.5, 0.5, 0.0))
    assert uv[0] == pytest.approx((0.5 * 0.1 + 0.25 * 0.9 + 0.25 * 0.1, 0.5 * 0.2 + 0.25 * 0.2 + 0.25 * 0.6))
    blend = 0.5 * np.array([0, 0, 1.0]) + 0.25 * np.array([1, 0, 1]) / math.sqrt(2) + 0.25 * np.array([0, 1, 1]) / math.sqrt(2)
    assert n[0] == pytest.approx(blend / np.linalg.norm(blend), abs=1e-12)
    # Flat shading: the geometric normal.
    scene = scene.model_copy(update={"shapes": [m.Mesh(file=str(obj), material=MAT)]})
    *_, n_flat, _ = probe(compile_scene(build_graph(scene)), np.array([[0.5, 0.5, 3.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert n_flat[0] == pytest.approx((0, 0, 1))


def _mesh_scene(mesh, seed=1, samples=16, width=20):
    return m.Scene(
        camera=m.Camera(look_from=(0, 0.5, 4), look_at=(0, 0, 0), vfov=35),
        image=m.Image(width=width, height=width, samples_per_pixel=samples, max_depth=6, seed=seed),
        background=m.SolidBackground(color=(0.8, 0.9, 1.0)),
        materials={"white": m.Lambertian(albedo=(0.6, 0.5, 0.4))},
        shapes=[mesh, m.Quad(q=(-3, -1, -3), u=(6, 0, 0), v=(0, 0, 6), material="white")],
    )


def test_a_ply_and_an_obj_of_the_same_mesh_give_the_same_image_bit_for_bit_and_renders_repeat(tmp_path):
    v, f = meshgen.torus_knot(segments=64, sides=8)
    obj = meshgen.write_obj(tmp_path / "knot.obj", v, f)
    ply = meshgen.write_ply(tmp_path / "knot.ply", v, f)
    images = []
    for path in (obj, ply, ply):
        mesh = m.Mesh(file=str(path), smooth=True, material="white")
        result = render(build_graph(_mesh_scene(mesh)), features=GENERAL)
        assert result.stats.bad_samples == 0
        images.append(result.film.total.copy())
    assert np.isfinite(images[0]).all() and images[0].max() > 0
    assert np.array_equal(images[0], images[1]) and np.array_equal(images[1], images[2])


def test_a_finely_cut_icosphere_renders_within_noise_of_the_sphere_it_approximates():
    v, f = meshgen.icosphere(224)  # 1,003,520 triangles
    mesh = render(build_graph(_mesh_scene(m.Mesh(vertices=v, faces=f, smooth=True, material="white"), seed=1, samples=32)),
                  features=GENERAL)
    sphere = render(build_graph(_mesh_scene(m.Sphere(center=(0, 0, 0), radius=1, material="white"), seed=2, samples=32)),
                    features=GENERAL)
    z = block_z(mesh.film, sphere.film, block=4)
    assert np.abs(z).max() < z_limit(z.size)
    # The test can fail: a sphere 10% larger is told apart.
    bigger = render(build_graph(_mesh_scene(m.Sphere(center=(0, 0, 0), radius=1.1, material="white"), seed=2, samples=32)),
                    features=GENERAL)
    assert np.abs(block_z(mesh.film, bigger.film, block=4)).max() > z_limit(z.size)


def test_meshes_with_degenerate_triangles_and_glass_render_no_nan():
    v, f = meshgen.icosphere(4)
    v = v.copy()
    f = np.concatenate([f, [[0, 0, 1], [2, 2, 2]]])  # zero-area triangles, dropped
    glass = m.Dielectric(ior=1.5)
    scene = _mesh_scene(m.Mesh(vertices=v, faces=f, smooth=True, material=glass), samples=8, width=16)
    graph = build_graph(scene)
    assert any("zero area" in w.message for w in graph.warnings)
    result = render(graph, features=GENERAL)
    assert result.stats.bad_samples == 0 and np.isfinite(result.film.total).all()


def test_a_mesh_render_resumes_exactly_and_does_not_depend_on_the_number_of_threads(tmp_path):
    import numba

    from renderer.state import RenderKey, load_state, save_state

    v, f = meshgen.torus_knot(segments=48, sides=8)
    ply = meshgen.write_ply(tmp_path / "knot.ply", v, f)
    graph = build_graph(_mesh_scene(m.Mesh(file=str(ply), smooth=True, material=m.Dielectric(ior=1.5)), samples=7, width=16))
    key = RenderKey("knot", 16, 16, graph.image.max_depth, graph.image.seed)
    whole = render(graph, samples=7, features=GENERAL).film
    save_state(tmp_path / "state.npz", render(graph, samples=3, features=GENERAL).film, key)
    resumed = render(graph, samples=7, film=load_state(tmp_path / "state.npz", key), features=GENERAL).film
    assert resumed.samples == 7 and whole.total.max() > 0 and np.isfinite(whole.total).all()
    assert np.array_equal(resumed.total, whole.total) and np.array_equal(resumed.total_sq, whole.total_sq)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = render(graph, samples=7, features=GENERAL).film
    finally:
        numba.set_num_threads(threads)
    assert np.array_equal(one.total, whole.total) and np.array_equal(one.total_sq, whole.total_sq)
