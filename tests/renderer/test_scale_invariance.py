"""A scene scaled by 1e-3 or 1e3, or moved 1e5 away, renders to the same image.

Nothing in the renderer has an absolute length: rays are cast with t_min = 0 and leave
surfaces through `spawn_origin`, which pushes them off by SPAWN_OFFSET (1e-9) times the
magnitude of the coordinates; parallel-ray and BVH padding thresholds are relative too
(docs/robustness.md). A fixed t_min = 0.001, as in the books, would fail here: at scale 1e-3
it is the size of the whole scene (every contact and crevice lost), and at 1e5 it is below
the rounding error of a hit point there (1e-11 is fine, but the books' float32 would not be).

The test scene has every kind of surface, a medium (its density scaled by 1/s), a checker
(its cell scaled by s), a moving sphere, defocus blur and the sky. The images are compared by
the mean of each 4x4 block, per channel, as independent renders (different seeds): every
two-sample z-score must stay within the Bonferroni bound for all blocks at family-wise
significance 1e-3. As a control, the 1e-3 scene with its checker cells left at the original
size (a change that a scale-dependent renderer would make to the image) must fail it.
"""

import numpy as np
import pytest

from renderer.variants import GENERAL
from renderer.render import render
from scenefmt import models as m
from scenefmt.graph import build_graph
from tests.renderer.stats import block_z, z_limit

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

SAMPLES = 1024


def scaled_scene(s=1.0, shift=(0.0, 0.0, 0.0), checker_cell=None, seed=1):
    shift = np.asarray(shift, float)

    def P(*p):  # a point
        return tuple(float(x) for x in np.asarray(p, float) * s + shift)

    def V(*v):  # a vector or a length
        return tuple(float(x) * s for x in v)

    cell = checker_cell if checker_cell is not None else 0.5 * s
    checker = m.CheckerTexture(scale=cell, even=(0.2, 0.3, 0.1), odd=(0.9, 0.9, 0.9))
    fog = m.ConstantMedium(density=3.0 / s, albedo=(0.8, 0.8, 0.8))
    shapes = [
        m.Sphere(center=P(0, -1000, 0), radius=1000 * s, material=m.Lambertian(albedo=checker)),
        m.Sphere(center=P(-1.2, 0.5, 0), radius=0.5 * s, material=m.Dielectric(ior=1.5)),
        m.Sphere(center=P(-1.2, 0.5, 0), radius=0.4 * s, material=m.Dielectric(ior=1 / 1.5)),
        m.Sphere(center=P(0, 0.5, 0), radius=0.5 * s, material=m.Metal(albedo=(0.8, 0.6, 0.2), fuzz=0.3)),
        m.Box(min=P(0.8, 0, -0.5), max=P(1.6, 0.8, 0.3), material=m.Lambertian(albedo=(0.7, 0.2, 0.1)),
              transform=[m.TranslateStep(translate=tuple(-shift)), m.RotateStep(rotate=m.Rotation(axis="y", degrees=20)),
                         m.TranslateStep(translate=tuple(shift))]),
        m.Quad(q=P(-2, 0, -1.5), u=V(4, 0, 0), v=V(0, 2, 0), material=m.Metal(albedo=(0.9, 0.9, 0.9), fuzz=0.0)),
        m.Sphere(center=P(0.3, 0.45, 1.3), radius=0.45 * s, interior=fog),
        m.MovingSphere(center0=P(1.0, 0.2, 1.2), center1=P(1.0, 0.5, 1.2), radius=0.2 * s,
                       material=m.Lambertian(albedo=(0.1, 0.4, 0.8))),
        m.Instance(group=m.Group(shapes=[m.Disk(center=(0, 0, 0), normal=(0, 1, 0), radius=1.0,
                                                material=m.Lambertian(albedo=(0.9, 0.8, 0.1)))]),
                   transform=[m.ScaleStep(scale=(0.4 * s, s, 0.2 * s)), m.TranslateStep(translate=P(-0.6, 0.01, 1.4))]),
    ]
    return m.Scene(
        camera=m.Camera(look_from=P(0, 1.2, 5), look_at=P(0, 0.4, 0), vfov=42, defocus_angle=0.5),
        image=m.Image(width=24, height=16, samples_per_pixel=SAMPLES, max_depth=16, seed=seed),
        background=m.SkyBackground(),
        shapes=shapes,
    )


def render_of(scene_model):
    result = render(build_graph(scene_model), features=GENERAL)
    assert result.stats.bad_samples == 0
    return result.film


@pytest.fixture(scope="module")
def original():
    return render_of(scaled_scene(seed=1))


def same_image(film, reference):
    z = block_z(film, reference)
    return bool(np.all(np.abs(z) <= z_limit(z.size))), float(np.abs(z).max())


@pytest.mark.parametrize("s, shift", [(1e-3, (0, 0, 0)), (1e3, (0, 0, 0)), (1.0, (1e5, -1e5, 1e5)), (1.0, (0, 0, 1e5))],
                         ids=["scaled_1e-3", "scaled_1e3", "moved_1e5", "moved_1e5_along_z"])
def test_scaled_or_moved_scene_renders_the_same_image(original, s, shift):
    same, worst = same_image(render_of(scaled_scene(s, shift, seed=2)), original)
    assert same, f"max |z| {worst:.1f}"


def test_the_comparison_sees_a_real_change(original):
    # The 1e-3 scene with its checker cells left at the original size: the ground turns one colour.
    same, worst = same_image(render_of(scaled_scene(1e-3, checker_cell=0.5, seed=2)), original)
    assert not same, f"max |z| {worst:.1f}"
    # And the unscaled scene with another seed passes, as the noise allows.
    assert same_image(render_of(scaled_scene(seed=3)), original)[0]
