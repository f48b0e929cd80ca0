"""Rendering as a whole: BVH against brute force, determinism, passes, film output."""

import os
from pathlib import Path

import numpy as np
import pytest

from renderer.compile import compile_scene, with_width
from renderer.film import Film, read_pfm, to_srgb8, write_image
from renderer.render import render
from scenefmt.validation import loads

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

# A little of everything: spheres, a moving sphere, quads, a box with fog, an instanced group,
# textures, glass and a light.
MIXED = """
camera: {look_from: [0, 2, 9], look_at: [0, 0.5, 0], vfov: 40, defocus_angle: 0.5}
image: {width: 40, aspect_ratio: 1.5, samples_per_pixel: 8, max_depth: 12, seed: 3}
background: {type: sky}
textures:
  chk: {type: checker, scale: 0.5, even: [0.2, 0.3, 0.1], odd: [0.9, 0.9, 0.9]}
  marble: {type: noise, scale: 3}
materials:
  ground: {type: lambertian, albedo: chk}
  glass: {type: dielectric, ior: 1.5}
  gold: {type: metal, albedo: [0.8, 0.6, 0.2], fuzz: 0.2}
  stone: {type: lambertian, albedo: marble}
  lamp: {type: diffuse_light, emit: [4, 4, 4]}
media:
  fog: {type: constant, density: 0.8, albedo: [0.9, 0.9, 0.9]}
groups:
  pair:
    shapes:
      - {type: sphere, center: [0, 0.3, 0], radius: 0.3, material: gold}
      - {type: box, min: [-0.2, 0, -0.2], max: [0.2, 0.4, 0.2], material: stone, transform: [{translate: [0.7, 0, 0]}]}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: ground}
  - {type: sphere, center: [-1.5, 0.6, 0], radius: 0.6, material: glass}
  - {type: moving_sphere, center0: [1.5, 0.5, 0], center1: [1.5, 0.9, 0], radius: 0.5, material: stone}
  - {type: quad, q: [-1, 2.5, -1], u: [2, 0, 0], v: [0, 0, 2], material: lamp}
  - {type: box, min: [-0.5, 0, 1], max: [0.5, 1, 2], interior: fog}
  - {type: triangle, vertices: [[-3, 0, -2], [-2, 0, -2], [-2.5, 1, -2]], material: gold}
  - {type: disk, center: [2.5, 0.01, 1.5], normal: [0, 1, 0], radius: 0.4, material: stone}
  - {type: instance, group: pair, transform: [{rotate: {axis: y, degrees: 30}}, {translate: [0, 0, 2.5]}]}
  - {type: instance, group: pair, transform: [{scale: [1, 2, 1]}, {translate: [-2, 0, 2]}]}
"""


@pytest.fixture(scope="module")
def graph():
    return loads(MIXED).graph


def test_bvh_image_equals_brute_force_image(graph):
    with_bvh = render(graph)
    brute = render(graph, flat=compile_scene(graph, use_bvh=False))
    assert with_bvh.stats.bad_samples == brute.stats.bad_samples == 0
    assert np.array_equal(with_bvh.film.total, brute.film.total)
    assert with_bvh.film.total.sum() > 0


def test_the_image_does_not_depend_on_how_samples_are_split_into_passes(graph):
    whole = render(graph, samples=6)
    first = render(graph, samples=2)
    continued = render(graph, samples=6, film=first.film)
    assert continued.film.samples == 6
    # Same samples, added in another order of passes: equal to rounding of the sums.
    assert np.allclose(whole.film.total, continued.film.total, rtol=1e-12, atol=1e-12)


def test_a_different_seed_gives_a_different_image(graph):
    a = render(graph, samples=2, seed=1).film.total
    b = render(graph, samples=2, seed=2).film.total
    assert not np.array_equal(a, b)


def test_should_stop_ends_the_render_between_passes(graph):
    # Polled between passes and between the bands of rows of a pass (tests/test_signals.py):
    # asked to stop once a pass is done, the render keeps that pass.
    passes = []
    result = render(graph, samples=1000, should_stop=lambda: len(passes) > 0, progress=passes.append)
    assert result.stats.interrupted and 0 < result.film.samples == passes[-1].samples < 1000


def test_with_width_keeps_the_aspect_ratio(graph):
    wider = with_width(graph, 120)
    assert (wider.image.width, wider.image.pixel_height) == (120, 80)
    fixed = loads("image: {width: 200, height: 50}").graph
    assert with_width(fixed, 100).image.pixel_height == 25


def test_png_follows_the_books_gamma_and_clamp():
    linear = np.array([[[0.0, 0.25, 1.0], [4.0, -1.0, 0.5625]]])
    assert to_srgb8(linear).tolist() == [[[0, 128, 255], [255, 0, 192]]]


def test_pfm_round_trip_keeps_linear_values(tmp_path):
    image = np.random.default_rng(0).uniform(0, 20, (5, 7, 3))
    write_image(tmp_path / "x.pfm", image)
    assert np.allclose(read_pfm(tmp_path / "x.pfm"), image, rtol=1e-6)
    assert [p.name for p in tmp_path.iterdir()] == ["x.pfm"]  # no temporary file left behind
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "x.pfm").stat().st_mode & 0o777 == 0o666 & ~umask  # not the temporary file's 0600


def test_a_write_that_fails_half_way_leaves_no_file(tmp_path):
    from renderer.film import _atomic_write

    def half_then_fail(fh):
        fh.write(b"PF\n2 2\n")
        raise OSError("disk full")

    with pytest.raises(OSError):
        _atomic_write(tmp_path / "x.pfm", half_then_fail)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError):
        write_image(tmp_path / "x.pfm", np.zeros((2, 2, 2)))  # neither an RGB image nor a grey pass
    assert list(tmp_path.iterdir()) == []


def test_film_mean_divides_by_samples():
    film = Film.empty(2, 1)
    film.total[:] = 6.0
    film.samples = 3
    assert film.mean().tolist() == [[[2.0] * 3, [2.0] * 3]]


def test_only_materials_whose_texture_reads_uv_get_surface_coordinates():
    # The kernels skip a hit's (u, v) (an arc cosine and an arc tangent on a sphere) unless the
    # material's texture reads it: an image, or a checker with an image among its squares.
    earth = Path(__file__).resolve().parents[2] / "scenes" / "earthmap.png"
    flat = compile_scene(loads(f"""
camera: {{look_from: [0, 0, 5], look_at: [0, 0, 0]}}
textures:
  map: {{type: image, file: {earth}}}
  over_map: {{type: checker, scale: 1, even: [1, 1, 1], odd: map}}
  plain: {{type: checker, scale: 1, even: [1, 1, 1], odd: [0, 0, 0]}}
  noise: {{type: noise, scale: 2}}
materials:
  solid: {{type: lambertian, albedo: [0.5, 0.5, 0.5]}}
  mapped: {{type: lambertian, albedo: map}}
  checked_map: {{type: metal, albedo: over_map}}
  checked: {{type: lambertian, albedo: plain}}
  noisy: {{type: lambertian, albedo: noise}}
  glass: {{type: dielectric, ior: 1.5}}
  lamp: {{type: diffuse_light, emit: map}}
shapes:
  - {{type: sphere, center: [-3, 0, 0], radius: 0.4, material: solid}}
  - {{type: sphere, center: [-2, 0, 0], radius: 0.4, material: mapped}}
  - {{type: sphere, center: [-1, 0, 0], radius: 0.4, material: checked_map}}
  - {{type: sphere, center: [0, 0, 0], radius: 0.4, material: checked}}
  - {{type: sphere, center: [1, 0, 0], radius: 0.4, material: noisy}}
  - {{type: sphere, center: [2, 0, 0], radius: 0.4, material: glass}}
  - {{type: sphere, center: [3, 0, 0], radius: 0.4, material: lamp}}
""").graph)
    reads_uv = {round(float(flat.prims_f[p, 0])): int(flat.mat_i[flat.prims_i[p, 1], 2])
                for p in range(len(flat.prims_i))}
    assert reads_uv == {-3: 0, -2: 1, -1: 1, 0: 0, 1: 0, 2: 0, 3: 1}
