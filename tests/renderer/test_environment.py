"""The environment map: its mapping, its sampler against its density, and the integrator that uses it.

Directions drawn by `environment.sample_environment` are binned on a grid of (cos theta, phi)
about +y over the whole sphere, and the counts are tested (chi-square, as test_lights.py does for
area lights) against the probabilities found by integrating `environment_radiance`'s density
over each cell with 32 x 32 directions. The grid is the world's, not the map's: a wrong sin(theta)
or 2 pi^2, a wrong turn, or a wrong texel would all show.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from renderer.compile import compile_scene, with_integrator
from renderer.film import write_pfm
from renderer.lights import map_choice
from renderer.render import render
from scenefmt.validation import loads
from tests.renderer.kernel_calls import environment_lookup, environment_samples, ray_transmittance
from tests.renderer.stats import ALPHA, block_z, chi2_test, film_mean_and_se, z_limit

# Runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

N = 100_000
CELLS = 20
SUB = 32


def a_map(tmp_path) -> Path:
    """24 x 12 texels: a smooth gradient, a sun of 2 x 2 texels 100 times brighter, a row of zeros
    (never to be sampled) and a black patch."""
    h, w = 12, 24
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    rgb = np.stack([0.3 + 0.2 * np.cos(2 * np.pi * u), 0.4 + 0.3 * v, 0.5 + 0.1 * np.sin(6 * u)], axis=-1)
    rgb[3:5, 17:19] = [60.0, 50.0, 40.0]
    rgb[7] = 0.0
    rgb[9:11, 2:6] = 0.0
    write_pfm(tmp_path / "map.pfm", rgb)
    return tmp_path / "map.pfm"


def scene(background: str, shapes: str = "", image: str = "width: 8, aspect_ratio: 1") -> str:
    return (f"camera: {{look_from: [0, 0, 5], look_at: [0, 0, 0], vfov: 40}}\nimage: {{{image}}}\n"
            f"background: {background}\n"
            "materials: {white: {type: lambertian, albedo: [0.8, 0.8, 0.8]}, one: {type: lambertian, albedo: [1, 1, 1]}}\n"
            f"shapes: [{shapes}]\n")


def flat_of(map_path: Path, rotate: float = 0.0, strength: float = 1.0):
    return compile_scene(loads(scene(f"{{type: image, file: '{map_path}', rotate: {rotate}, strength: {strength}}}"),
                               allow_paths=[map_path.parent]).graph)


def sphere_grid():
    """CELLS x CELLS x SUB x SUB directions uniform in (cos theta, phi) about +y, each one's cell
    and solid angle."""
    k = CELLS * SUB
    s = (np.arange(k) + 0.5) / k
    cos_t, phi = np.meshgrid(1.0 - 2.0 * s, 2.0 * np.pi * s, indexing="ij")
    sin_t = np.sqrt(1.0 - cos_t ** 2)
    dirs = np.stack([sin_t * np.cos(phi), cos_t, sin_t * np.sin(phi)], axis=-1).reshape(-1, 3)
    cell = ((np.arange(k)[:, None] // SUB) * CELLS + np.arange(k)[None, :] // SUB).ravel()
    return dirs, cell, (2.0 / k) * (2.0 * np.pi / k)


def cell_of(d):
    i = np.clip(((1.0 - d[:, 1]) / 2.0 * CELLS).astype(int), 0, CELLS - 1)
    phi = np.mod(np.arctan2(d[:, 2], d[:, 0]), 2.0 * np.pi)
    j = np.clip((phi / (2.0 * np.pi) * CELLS).astype(int), 0, CELLS - 1)
    return i * CELLS + j


def cell_test(draws, density, cell, d_omega):
    probs = np.bincount(cell, weights=density * d_omega, minlength=CELLS * CELLS)
    counts = np.bincount(cell_of(draws), minlength=CELLS * CELLS)
    return chi2_test(counts, probs / probs.sum())


@pytest.mark.parametrize("rotate", [0.0, 130.0])
def test_sampled_directions_follow_the_map_density(tmp_path, rotate):
    flat = flat_of(a_map(tmp_path), rotate)
    draws = environment_samples(flat, 11, N)
    ok = draws[:, 0] == 1.0
    assert ok.all(), f"{(~ok).sum()} draws refused"
    d, pdf = draws[:, 1:4], draws[:, 4]
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.all(np.isfinite(pdf)) and np.all(pdf > 0)
    # The density the sampler reports is the one the lookup gives the same direction (the weight
    # of a BSDF ray that escapes there), and so is the radiance: the texel is the same.
    agree = np.abs(draws[:, 8] - pdf) <= 1e-9 * pdf
    assert agree.mean() > 0.999, f"{(~agree).sum()} densities differ"
    assert (np.abs(draws[:, 9] - draws[:, 5]) <= 1e-6 * draws[:, 5]).mean() > 0.999
    # Never a black texel (zero radiance, zero density).
    assert np.all(draws[:, 5:8].sum(axis=1) > 0)
    dirs, cell, d_omega = sphere_grid()
    density = environment_lookup(flat, dirs)[:, 3]
    assert np.sum(density * d_omega) == pytest.approx(1.0, abs=0.01), "the density does not integrate to 1 over the sphere"
    p_value, dof = cell_test(d, density, cell, d_omega)
    assert dof > 100 and p_value > ALPHA, f"chi-square p = {p_value:.2e} with {dof} degrees of freedom"


def test_a_wrong_density_is_caught(tmp_path):
    """Control: the same check rejects a density off by a smooth factor (sin theta left out of the
    weights would be such a factor), and one turned by a few degrees."""
    flat = flat_of(a_map(tmp_path))
    d = environment_samples(flat, 11, N)[:, 1:4]
    dirs, cell, d_omega = sphere_grid()
    density = environment_lookup(flat, dirs)[:, 3]
    off = density * (1.0 + 0.3 * np.abs(dirs[:, 1]))
    assert cell_test(d, off / np.sum(off * d_omega), cell, d_omega)[0] < ALPHA
    turned = environment_lookup(flat_of(a_map(tmp_path), 8.0), dirs)[:, 3]
    assert cell_test(d, turned, cell, d_omega)[0] < ALPHA


def test_the_mapping_is_the_documented_one(tmp_path):
    """The top row is +y, u = 1/2 is -z, u = 3/4 is +x, u = 0 is +z; rotate 90 turns -z to -x."""
    h, w = 4, 8
    rgb = np.zeros((h, w, 3))
    rgb[0] = [1, 0, 0]  # the top row
    rgb[h - 1] = [0, 0, 1]  # the bottom row
    rgb[1:3, 3:5] = [0, 1, 0]  # about u = 1/2
    rgb[1:3, 5:7] = [0, 2, 0]  # about u = 3/4
    rgb[1:3, [0, 7]] = [0, 3, 0]  # about u = 0
    path = tmp_path / "compass.pfm"
    write_pfm(path, rgb)
    dirs = np.array([[0, 1, 0], [0, -1, 0], [0, 0, -1], [1, 0, 0], [0, 0, 1.0]])
    plain = environment_lookup(flat_of(path), dirs)[:, :3]
    np.testing.assert_array_equal(plain, [[1, 0, 0], [0, 0, 1], [0, 1, 0], [0, 2, 0], [0, 3, 0]])
    turned = environment_lookup(flat_of(path, 90.0), np.array([[-1, 0, 0], [0, 0, -1.0]]))[:, :3]
    np.testing.assert_array_equal(turned, [[0, 1, 0], [0, 2, 0]])
    stronger = environment_lookup(flat_of(path, 0.0, 2.5), dirs[:1])[:, :3]
    np.testing.assert_array_equal(stronger, [[2.5, 0, 0]])


def test_a_png_map_is_read_as_srgb(tmp_path):
    from PIL import Image

    Image.fromarray(np.full((2, 4, 3), 188, np.uint8)).save(tmp_path / "grey.png")
    value = environment_lookup(flat_of(tmp_path / "grey.png"), np.array([[0, 0, -1.0]]))[0, 0]
    assert value == pytest.approx(((188 / 255 + 0.055) / 1.055) ** 2.4, rel=1e-6)


def test_a_shadow_ray_to_infinity_is_blocked_or_attenuated(tmp_path):
    """tmax = inf: a surface blocks, a medium the ray leaves attenuates by exp(-density x length
    inside), a camera inside a closed medium counts from where it starts."""
    text = scene("{type: image, file: '%s'}" % a_map(tmp_path),
                 "{type: sphere, center: [0, 0, 0], radius: 2, interior: {type: constant, density: 0.5, albedo: [1, 1, 1]}},"
                 " {type: quad, q: [5, -1, -1], u: [0, 2, 0], v: [0, 0, 2], material: white}")
    flat = compile_scene(loads(text, allow_paths=[tmp_path]).graph)
    inf = math.inf
    assert ray_transmittance(flat, np.array([0.0, 0, 0]), np.array([0.0, 1, 0]), inf, 0.0) == pytest.approx(math.exp(-1.0), rel=1e-9)
    assert ray_transmittance(flat, np.array([0.0, 0, -3]), np.array([0.0, 0, 1]), inf, 0.0) == pytest.approx(math.exp(-2.0), rel=1e-9)
    assert ray_transmittance(flat, np.array([3.0, 0, 0]), np.array([1.0, 0, 0]), inf, 0.0) == 0.0
    assert ray_transmittance(flat, np.array([3.0, 0, 0]), np.array([-1.0, 0, 0.0]), inf, 0.0) == pytest.approx(math.exp(-2.0), rel=1e-9)
    # Grazing the medium's boundary: finite and in [0, 1].
    t = ray_transmittance(flat, np.array([-5.0, 2, 0]), np.array([1.0, 0, 0]), inf, 0.0)
    assert 0.0 <= t <= 1.0


def test_a_white_sphere_under_a_uniform_environment_of_radiance_one_is_one(tmp_path):
    """The furnace with the map sampled as a light: every pixel's expected value is 1."""
    uniform = tmp_path / "one.pfm"
    write_pfm(uniform, np.ones((8, 16, 3)))
    text = scene(f"{{type: image, file: '{uniform}'}}", "{type: sphere, center: [0, 0, 0], radius: 1.5, material: one}",
                 "width: 16, aspect_ratio: 1, samples_per_pixel: 64, max_depth: 50")
    graph = loads(text, allow_paths=[tmp_path]).graph
    exact = render(with_integrator(graph, "path")).film.mean()
    assert np.all(np.abs(exact - 1.0) <= 1e-12)
    film = render(graph).film
    assert np.all(np.isfinite(film.total))
    mean, se = film_mean_and_se(film)
    assert np.all(se > 0), "light sampling never ran"
    assert np.all(np.abs(mean - 1.0) <= z_limit(3) * se), f"mean {mean} differs from 1 by {np.abs(mean - 1) / se} standard errors"


LIT_BY_THE_SKY = (
    "{type: quad, q: [-3, -1, -3], u: [6, 0, 0], v: [0, 0, 6], material: white},"
    " {type: sphere, center: [-0.6, -0.2, 0], radius: 0.8, material: white},"
    " {type: box, min: [0.4, -1, -0.5], max: [1.4, 0.6, 0.5], material: white},"
    " {type: sphere, center: [0.9, 1.0, 0.3], radius: 0.4, material: {type: metal, albedo: [0.9, 0.9, 0.9], fuzz: 0.2}},"
    " {type: sphere, center: [-0.2, 1.0, 1.0], radius: 0.4, interior: {type: constant, density: 1.5, albedo: [0.8, 0.8, 0.8]}},"
    " {type: quad, q: [-2.5, 0.5, -2], u: [0.6, 0, 0], v: [0, 0.6, 0], material: {type: diffuse_light, emit: [6, 6, 6]}}"
)


def test_light_sampling_converges_to_the_books_estimator_under_a_map(tmp_path):
    """A map with a sun, an area light, fog and a metal: the MIS image and the books' estimator
    agree within noise, block by block. (The sun is broad, 30 degrees: under the project's sky,
    whose sun is 5 degrees across, the books' estimator finds it a few times a block at this
    size, too rarely for its noise estimate to hold; there the two agreed, |z| < 1.4, only with
    100,000 paths a pixel.)"""
    text = scene(f"{{type: image, file: '{a_map(tmp_path)}', rotate: 40}}", LIT_BY_THE_SKY,
                 "width: 24, aspect_ratio: 1, samples_per_pixel: 256, max_depth: 12")
    graph = loads(text, allow_paths=[tmp_path]).graph
    flat = compile_scene(graph)
    assert 0.1 <= map_choice(flat) <= 0.9, "the map and the area light share the light samples"
    mis = render(graph, seed=1).film
    path = render(with_integrator(graph, "path"), seed=2).film
    z = block_z(mis, path, 4)
    assert np.all(np.isfinite(mis.total)) and np.all(np.isfinite(path.total))
    assert np.all(np.abs(z) <= z_limit(z.size)), f"largest |z| {np.abs(z).max():.2f}"


@pytest.mark.parametrize("case", ["sun", "black", "zero rows", "strength zero"])
def test_hard_maps_give_finite_pixels(tmp_path, case):
    h, w = 16, 32
    rgb = np.full((h, w, 3), 0.2)
    if case == "sun":
        rgb[:] = 0.01
        rgb[2, 5] = 1e6  # one texel near the pole, and one at it
        rgb[0, 9] = 1e5
    elif case == "black":
        rgb[:] = 0.0
    elif case == "zero rows":
        rgb[:6] = 0.0
        rgb[-3:] = 0.0
        rgb[8, 4] = 50.0
    path = tmp_path / "hard.pfm"
    write_pfm(path, rgb)
    strength = 0.0 if case == "strength zero" else 1.0
    text = scene(f"{{type: image, file: '{path}', strength: {strength}}}",
                 "{type: sphere, center: [0, 0, 0], radius: 1, material: white},"
                 " {type: sphere, center: [0, 0.8, 0.9], radius: 0.3, interior: {type: constant, density: 2, albedo: [0.9, 0.9, 0.9]}}",
                 "width: 12, aspect_ratio: 1, samples_per_pixel: 16, max_depth: 8")
    result = render(loads(text, allow_paths=[tmp_path]).graph)
    assert result.stats.bad_samples == 0
    assert np.all(np.isfinite(result.film.total)) and np.all(np.isfinite(result.film.total_sq))
    if case in ("black", "strength zero"):
        assert result.film.total.max() == 0.0
