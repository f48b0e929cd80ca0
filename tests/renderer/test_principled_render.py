"""The principled material in renders: an emitting principled surface is an area light (light
sampling and MIS), and one that emits and scatters renders the same under both estimators.

Small scenes, fixed seeds; images compared block by block with two-sample z-scores
(tests/renderer/stats.py) at a family-wise level, and each comparison has a control that the
same check tells a wrong image apart.
"""

from __future__ import annotations

import numpy as np
import pytest

from renderer.render import render
from renderer.variants import GENERAL
from scenefmt import models as m
from scenefmt.graph import build_graph
from scenefmt.materials import Principled
from tests.renderer.stats import block_z, z_limit

pytestmark = pytest.mark.slow

LAMP = (4.0, 3.0, 2.0)


def lamp_scene(lamp, floor, *, integrator="mis", seed=1, samples=64):
    """A floor under a small square lamp, black background, seen from above at an angle."""
    return m.Scene(
        camera=m.Camera(look_from=(0.0, 3.0, 4.0), look_at=(0.0, 0.0, 0.0), vfov=45.0),
        image=m.Image(width=24, height=24, samples_per_pixel=samples, max_depth=8, seed=seed, integrator=integrator),
        background=m.SolidBackground(color=(0.0, 0.0, 0.0)),
        shapes=[
            m.Quad(q=(-3, 0, -3), u=(6, 0, 0), v=(0, 0, 6), material=floor),
            m.Quad(q=(-0.5, 1.5, -0.5), u=(1, 0, 0), v=(0, 0, 1), material=lamp),
        ],
    )


def film(scene):
    result = render(build_graph(scene), features=GENERAL)
    assert result.stats.bad_samples == 0
    return result.film


def max_z(a, b):
    z = block_z(a, b, block=4)
    return np.abs(z).max(), z_limit(z.size)


def test_a_black_principled_emitter_lights_as_a_diffuse_light():
    """A principled lamp that reflects nothing (black base, no specular layer) and emits LAMP
    lights the floor as the books' diffuse light of that colour does: it is found by the light
    table and sampled, with its radiance."""
    floor = m.Lambertian(albedo=(0.7, 0.7, 0.7))
    books = film(lamp_scene(m.DiffuseLight(emit=LAMP), floor, seed=1))
    principled = film(lamp_scene(Principled(base_color=(0, 0, 0), specular=0.0, emission=LAMP), floor, seed=2))
    z, limit = max_z(books, principled)
    assert z < limit
    assert books.total.sum() > 0
    # Control: a lamp 20% brighter is told apart.
    brighter = film(lamp_scene(Principled(base_color=(0, 0, 0), specular=0.0, emission=LAMP, emission_strength=1.2),
                               floor, seed=3))
    assert max_z(books, brighter)[0] > limit


def test_an_emitter_that_scatters_renders_alike_with_and_without_light_sampling():
    """A glossy principled floor that also glows, under a principled lamp that also reflects:
    paths go on from both emitters, and MIS (light sampling from them, weights when a path hits
    them) gives the image the books' estimator gives."""
    floor = Principled(base_color=(0.6, 0.5, 0.4), roughness=0.5, emission=(0.05, 0.1, 0.2))
    lamp = Principled(base_color=(0.5, 0.5, 0.5), roughness=0.3, emission=LAMP)
    mis = film(lamp_scene(lamp, floor, integrator="mis", seed=4, samples=128))
    path = film(lamp_scene(lamp, floor, integrator="path", seed=5, samples=512))
    z, limit = max_z(mis, path)
    assert z < limit
    # Control: without the floor's glow the image is told apart.
    dark = Principled(base_color=(0.6, 0.5, 0.4), roughness=0.5)
    assert max_z(mis, film(lamp_scene(lamp, dark, integrator="path", seed=6, samples=512)))[0] > limit


def glass_scene(glass, seed):
    """A sphere of `glass` over a lit floor, so that refraction moves and focuses the light."""
    scene = lamp_scene(m.DiffuseLight(emit=LAMP), m.Lambertian(albedo=(0.7, 0.7, 0.7)), seed=seed, samples=256)
    scene.shapes.append(m.Sphere(center=(0.0, 0.7, 0.2), radius=0.7, material=glass))
    return scene


def test_volumetric_principled_glass_is_the_rough_dielectric():
    """transmission 1, metallic 0, white base, not thin-walled: the rough dielectric of the same
    index and roughness, image for image; thin-walled it is not (no refraction offset)."""
    from scenefmt.materials import RoughDielectric

    glass = film(glass_scene(Principled(base_color=(1, 1, 1), transmission=1.0, roughness=0.3, ior=1.5), seed=7))
    rough = film(glass_scene(RoughDielectric(ior=1.5, roughness=0.3), seed=8))
    z, limit = max_z(glass, rough)
    assert z < limit
    thin = film(glass_scene(Principled(base_color=(1, 1, 1), transmission=1.0, roughness=0.3, ior=1.5, thin_walled=True),
                            seed=9))
    assert max_z(glass, thin)[0] > limit
