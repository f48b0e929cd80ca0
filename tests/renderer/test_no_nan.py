"""Property tests: random scenes render without a single NaN or Inf, and intersection routines
return finite distances and unit normals on random rays.

Scenes come from a seeded generator (every shape kind, random transforms including mirrors
and shears, every material with extreme parameters, media, textures, nested instances, sizes
from 1e-4 to 1e3, coincident shapes, a camera that may sit inside anything), so each run sees
the same scenes; rays come from Hypothesis (derandomised, so CI is deterministic) with signed
zeros, axis-parallel directions and lengths from 1e-6 to 1e6. The kernels count non-finite
samples (RenderStats.bad_samples) instead of adding them to the image: it must stay 0.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from renderer.variants import GENERAL
from renderer.compile import compile_scene
from renderer.tracing.probe import probe_rays
from renderer.render import render
from scenefmt import models as m
from scenefmt.graph import build_graph

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

SCENES = 128


def rvec(rng, lo, hi):
    return tuple(float(x) for x in rng.uniform(lo, hi, 3))


def random_transform(rng):
    steps = []
    for _ in range(int(rng.integers(0, 4))):
        k = rng.integers(0, 4)
        if k == 0:
            steps.append(m.TranslateStep(translate=rvec(rng, -2, 2)))
        elif k == 1:
            steps.append(m.RotateStep(rotate=m.Rotation(axis=rvec(rng, -1, 1), degrees=float(rng.choice([90.0, 180.0, 360.0, rng.uniform(-720, 720)])))))
        elif k == 2:
            steps.append(m.ScaleStep(scale=tuple(float(s) for s in rng.choice([-1, 1], 3) * 10 ** rng.uniform(-1.5, 1, 3))))
        else:
            a = rng.normal(size=(3, 4))
            a[:, :3] += 2 * np.eye(3)  # a shear
            while abs(np.linalg.det(a[:, :3])) < 0.1:  # kept well invertible
                a[:, :3] += np.eye(3)
            steps.append(m.MatrixStep(matrix=a.tolist()))
    return steps


def random_texture(rng):
    k = rng.integers(0, 3)
    if k == 0:
        return rvec(rng, 0, 1)
    if k == 1:
        return m.CheckerTexture(scale=float(10 ** rng.uniform(-3, 1)), even=rvec(rng, 0, 1), odd=rvec(rng, 0, 1))
    return m.NoiseTexture(scale=float(10 ** rng.uniform(-1, 1.5)), form=str(rng.choice(["plain", "turbulence", "marble"])),
                          seed=int(rng.integers(0, 100)))


def random_material(rng):
    k = rng.integers(0, 5)
    if k == 0:
        return m.Lambertian(albedo=random_texture(rng))
    if k == 1:
        return m.Metal(albedo=random_texture(rng), fuzz=float(rng.choice([0.0, 1.0, rng.uniform()])))
    if k == 2:
        return m.Dielectric(ior=float(rng.choice([1.0, 1.5, 1 / 1.5, 2.4, 100.0, 0.01, rng.uniform(0.2, 5)])))
    if k == 3:
        return m.DiffuseLight(emit=rvec(rng, 0, 20))
    return m.Lambertian(albedo=(1.0, 1.0, 1.0))


def random_medium(rng):
    return m.ConstantMedium(density=float(10 ** rng.uniform(-6, 3)), albedo=random_texture(rng))


def random_shape(rng, depth=0):
    k = int(rng.integers(0, 9 if depth < 2 else 7))
    c = rvec(rng, -2, 2)
    size = float(10 ** rng.uniform(-4, 0.5))
    mat = random_material(rng)
    tf = random_transform(rng) if rng.random() < 0.5 else []
    medium = random_medium(rng) if rng.random() < 0.25 else None
    closed = dict(material=None if medium is not None and rng.random() < 0.5 else mat, interior=medium, transform=tf)
    if k == 0:
        return m.Sphere(center=c, radius=size, **closed)
    if k == 1:
        return m.MovingSphere(center0=c, center1=rvec(rng, -2, 2), radius=size, **closed)
    if k == 2:
        return m.Quad(q=c, u=rvec(rng, -2, 2), v=rvec(rng, -2, 2), material=mat, transform=tf)
    if k == 3:
        # Often a sliver: the third vertex close to the line of the first two.
        a, b = np.array(c), np.array(rvec(rng, -2, 2))
        third = a + rng.uniform(0, 1) * (b - a) + 10 ** rng.uniform(-9, 0) * rng.normal(size=3)
        return m.Triangle(vertices=(c, tuple(b), tuple(float(x) for x in third)), material=mat, transform=tf)
    if k == 4:
        return m.Disk(center=c, normal=rvec(rng, -1, 1), radius=size, material=mat, transform=tf)
    if k in (5, 6):
        lo = np.array(c)
        hi = lo + 10 ** rng.uniform(-4, 0.5, 3)
        return m.Box(min=tuple(lo), max=tuple(float(x) for x in hi), **closed)
    if k == 7:
        # Two copies of one shape in the same place: ties everywhere.
        twin = random_shape(rng, 2)
        return m.Instance(group=m.Group(shapes=[twin, twin]), transform=random_transform(rng))
    group = m.Group(shapes=[random_shape(rng, depth + 1) for _ in range(int(rng.integers(1, 4)))])
    return m.Instance(group=group, transform=random_transform(rng))


def random_scene(seed):
    rng = np.random.default_rng(seed)
    shapes = [random_shape(rng) for _ in range(int(rng.integers(3, 14)))]
    if rng.random() < 0.3:
        shapes.append(m.Sphere(center=(0, -1000, 0), radius=1000, material=random_material(rng)))  # the books' ground
    look_from = rvec(rng, -6, 6) if rng.random() < 0.8 else rvec(rng, -0.5, 0.5)  # often inside something
    cam = m.Camera(look_from=look_from, look_at=rvec(rng, -1, 1), vfov=float(rng.uniform(5, 170)),
                   defocus_angle=float(rng.choice([0.0, rng.uniform(0, 10)])))
    bg = m.SkyBackground() if rng.random() < 0.5 else m.SolidBackground(color=rvec(rng, 0, 2))
    shutter = m.Shutter(open=0.0, close=float(rng.choice([0.0, 1.0, 0.5])))
    return m.Scene(camera=cam, image=m.Image(width=10, height=10, samples_per_pixel=16, max_depth=40, seed=seed),
                   background=bg, shutter=shutter, shapes=shapes)


@pytest.mark.parametrize("chunk", range(4))
def test_random_scenes_render_without_nan_or_inf(chunk):
    kinds = set()
    for seed in range(chunk * SCENES // 4, (chunk + 1) * SCENES // 4):
        scene = random_scene(seed)
        kinds.update(type(s).__name__ for s in scene.shapes)
        result = render(build_graph(scene), features=GENERAL)
        assert result.stats.bad_samples == 0, f"scene {seed}: {result.stats.bad_samples} non-finite samples"
        assert np.isfinite(result.film.total).all() and np.isfinite(result.film.total_sq).all(), seed
        assert (result.film.total >= 0).all(), seed
    assert len(kinds) >= 5


@pytest.fixture(scope="module")
def flats():
    """Compiled random scenes (with and without BVHs) for the ray properties."""
    out = []
    for seed in range(8):
        graph = build_graph(random_scene(1000 + seed))
        out.append((compile_scene(graph), compile_scene(graph, use_bvh=False)))
    return out


def check_rays(flat, brute, o, d):
    t, prim, inst, p, n, uv = probe_rays(flat, o, d, 0.0, 0.0, False)
    assert not np.isnan(t).any() and (t > 0).all()
    hit = prim >= 0
    surface = hit & (n != 0).any(axis=1)  # a medium's scattering event has no normal
    assert np.isfinite(t[hit]).all() and np.isinf(t[~hit]).all()
    assert np.isfinite(p[hit]).all() and np.isfinite(uv[hit]).all()
    assert np.allclose(np.linalg.norm(n[surface], axis=1), 1.0, rtol=0, atol=1e-12)
    tb, primb, *_ = probe_rays(brute, o, d, 0.0, 0.0, True)
    assert np.array_equal(t, tb)  # the BVH finds the same distance as testing everything
    return hit.sum()


def test_random_rays_against_random_scenes(flats):
    rng = np.random.default_rng(31)
    hits = 0
    for flat, brute in flats:
        o = rng.uniform(-6, 6, (3000, 3))
        d = rng.normal(size=(3000, 3))
        d[rng.random((3000, 3)) < 0.2] = 0.0  # axis-parallel rays
        d[rng.random((3000, 3)) < 0.1] = -0.0
        d[(d == 0).all(axis=1)] = (0.0, -1.0, 0.0)
        d *= 10 ** rng.uniform(-6, 6, (3000, 1))
        hits += check_rays(flat, brute, o, d)
    assert hits > 2000


coordinate = st.one_of(st.floats(-20, 20, allow_nan=False), st.sampled_from([0.0, -0.0, 1.0, -1.0, 2.0, 0.5]))
component = st.one_of(st.floats(-1, 1, allow_nan=False), st.sampled_from([0.0, -0.0]))


@settings(max_examples=400, derandomize=True, deadline=None)
@given(o=st.tuples(coordinate, coordinate, coordinate), d=st.tuples(component, component, component),
       length=st.floats(1e-6, 1e6), which=st.integers(0, 7))
def test_any_ray_gives_a_finite_answer(flats, o, d, length, which):
    if all(x == 0.0 for x in d):
        d = (0.0, 0.0, 1.0)
    flat, brute = flats[which]
    check_rays(flat, brute, np.array([o], float), np.array([d], float) * length / max(math.hypot(*d), 1e-300))


def test_an_empty_scene_renders_its_background():
    """No shapes at all (an empty tree, the books' empty bounding box): every ray escapes."""
    scene = m.Scene(camera=m.Camera(look_from=(0, 0, 0), look_at=(0, 0, -1)), background=m.SolidBackground(color=(0.25, 0.5, 1.0)),
                    image=m.Image(width=4, height=4, samples_per_pixel=2, max_depth=5))
    result = render(build_graph(scene), features=GENERAL)
    assert result.stats.bad_samples == 0
    assert np.array_equal(result.film.mean(), np.broadcast_to([0.25, 0.5, 1.0], (4, 4, 3)))
