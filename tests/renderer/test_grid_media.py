"""Media whose density varies (grid and noise media) and the Henyey-Greenstein phase: their
fields against a numpy reference, delta and ratio tracking against the closed-form transmittance
(with a tight and a loose majorant), no NaN at the grid's edges or in empty cells, the phase
function's sampler against its density, and renders: a constant grid like the constant medium it
equals, and the same image on one thread and on two."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.grid_media import F_BLOCKS, F_MAJORANTS, FIELD_F, ROW, grid_majorants
from renderer.media import MEDIUM_FIELD
from renderer.shapes import MEDIUM, PRIM_KIND
from scenefmt.validation import load
from tests.renderer.stats import ALPHA, binomial_p_value, block_z, chi2_test, z_limit

# Runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

TRANSFORM = "[{scale: [2, 1, 1.5]}, {rotate: {axis: y, degrees: 20}}, {translate: [0.3, -0.2, 0.1]}]"


def grid_scene(folder: Path, grid: np.ndarray, interpolation: str, density: float, name: str = "cloud.npy") -> Path:
    """A scene of one box (no surface) holding a grid medium over its whole inside, placed by TRANSFORM."""
    np.save(folder / name, grid)
    path = folder / "scene.yaml"
    path.write_text(f"""
camera: {{look_from: [0, 0, 6], look_at: [0, 0, 0], vfov: 40}}
image: {{width: 8, height: 8, samples_per_pixel: 1, max_depth: 4}}
media:
  cloud: {{type: grid, file: {name}, bounds: [[0, 0, 0], [1, 1, 1]], interpolation: {interpolation}, density: {density}}}
shapes:
  - {{type: box, min: [0, 0, 0], max: [1, 1, 1], interior: cloud, transform: {TRANSFORM}}}
""")
    return path


def world_map():
    """(3x4 world_from_medium, 3x4 medium_from_world) of TRANSFORM."""
    from scenefmt.validation import loads

    graph = loads(f"camera: {{look_from: [0, 0, 6], look_at: [0, 0, 0]}}\nshapes:\n"
                  f"  - {{type: box, min: [0, 0, 0], max: [1, 1, 1], material: {{type: lambertian}}, transform: {TRANSFORM}}}\n").graph
    m = np.asarray(graph.root.members[0].transform, np.float64).reshape(3, 4)
    full = np.eye(4)
    full[:3] = m
    return m, np.linalg.inv(full)[:3]


def reference_density(grid, interpolation, scale, p):
    """The grid's density at points p (N, 3) of the medium's space [0, 1]^3, in numpy."""
    n = np.array(grid.shape)
    g = p * n
    inside = np.all((g >= 0) & (g <= n), axis=1)
    if interpolation == "nearest":
        idx = np.clip(np.floor(g).astype(int), 0, n - 1)
        value = grid[idx[:, 0], idx[:, 1], idx[:, 2]]
    else:
        f = g - 0.5
        i0 = np.floor(f).astype(int)
        t = f - i0
        value = np.zeros(len(p))
        for corner in range(8):
            c = np.array([(corner >> 2) & 1, (corner >> 1) & 1, corner & 1])
            idx = np.clip(i0 + c, 0, n - 1)
            w = np.prod(np.where(c == 1, t, 1.0 - t), axis=1)
            value += w * grid[idx[:, 0], idx[:, 1], idx[:, 2]]
    return np.where(inside, scale * value, 0.0)


def optical_depth(grid, interpolation, scale, o, d, t0, t1, steps=400_000):
    """The integral of the density along the world ray o + t d over (t0, t1), per unit world length."""
    _, inv = world_map()
    t = t0 + (np.arange(steps) + 0.5) * (t1 - t0) / steps
    world = o[None, :] + t[:, None] * d[None, :]
    local = world @ inv[:, :3].T + inv[:, 3]
    return float(reference_density(grid, interpolation, scale, local).sum() * (t1 - t0) / steps * np.linalg.norm(d))


def field_header(flat) -> int:
    rows = np.nonzero(flat.prims_i[: len(flat.prims_f), PRIM_KIND] == MEDIUM)[0]
    return int(flat.prims_f[rows[0], MEDIUM_FIELD]) - 1


def loosen(flat, factor: float) -> None:
    """Multiply every majorant cell of the flat scene's one field by `factor`."""
    h = field_header(flat)
    header = flat.bnd_f[h:h + FIELD_F.width // ROW].ravel()
    count = int(np.prod(header[F_BLOCKS:F_BLOCKS + 3]))
    first = int(header[F_MAJORANTS])
    values = flat.bnd_f[first:].ravel()
    values[:count] *= factor
    flat.bnd_f[first:] = values.reshape(-1, ROW)


RNG = np.random.default_rng(11)
GRID = RNG.random((6, 5, 4)) * (RNG.random((6, 5, 4)) > 0.3)  # with empty cells
# A ray through the placed box, not along any axis.
O = np.array([-3.0, 0.15, 1.0])
D = np.array([1.0, 0.05, -0.2])


def test_the_majorant_cells_bound_every_value_within_one_cell_of_them():
    values = RNG.random((19, 9, 17))
    m = grid_majorants(values, block=4)
    assert m.shape == (5, 3, 5)
    for i, j, k in np.ndindex(*m.shape):
        block = values[max(0, 4 * i - 1):4 * i + 5, max(0, 4 * j - 1):4 * j + 5, max(0, 4 * k - 1):4 * k + 5]
        assert m[i, j, k] == pytest.approx(block.max())


@pytest.mark.parametrize("interpolation", ["nearest", "trilinear"])
def test_the_field_is_the_grid_interpolated_and_zero_outside_its_box(tmp_path, interpolation):
    from tests.renderer.grid_media_calls import densities

    flat = compile_scene(load(grid_scene(tmp_path, GRID, interpolation, 2.5)).graph)
    # Inside, on the box's faces and corners, and outside it.
    points = np.concatenate([RNG.random((2000, 3)), RNG.random((200, 3)) * 1.4 - 0.2,
                             np.array([[0, 0, 0], [1, 1, 1], [1, 0, 0.5], [0.5, 1, 1], [1 + 1e-12, 0.5, 0.5]])])
    got = densities(flat.bnd_f, field_header(flat), points)
    assert np.allclose(got, reference_density(GRID, interpolation, 2.5, points), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("interpolation,loose", [("nearest", 1.0), ("trilinear", 1.0), ("trilinear", 4.0)])
def test_ratio_tracking_averages_to_the_transmittance(tmp_path, interpolation, loose):
    """Unbiased where the majorant is tight (each cell's largest value) and where it is 4 times that."""
    from tests.renderer.grid_media_calls import shadow_estimates

    flat = compile_scene(load(grid_scene(tmp_path, GRID, interpolation, 1.5)).graph)
    if loose != 1.0:
        before = shadow_estimates(flat, O, D, 10.0, 3, 50)
        loosen(flat, loose)
        assert not np.array_equal(before, shadow_estimates(flat, O, D, 10.0, 3, 50))
    n = 40_000
    est = shadow_estimates(flat, O, D, 10.0, 3, n)
    assert np.all(np.isfinite(est)) and est.min() >= 0.0 and est.max() <= 1.0
    expected = math.exp(-optical_depth(GRID, interpolation, 1.5, O, D, 0.0, 10.0))
    assert 0.05 < expected < 0.95
    z = (est.mean() - expected) / (est.std() / math.sqrt(n))
    assert abs(z) < z_limit(4), (est.mean(), expected, z)
    # A segment that stops inside the medium attenuates less.
    part = shadow_estimates(flat, O, D, 4.2, 5, n)
    expected_part = math.exp(-optical_depth(GRID, interpolation, 1.5, O, D, 0.0, 4.2))
    assert abs(part.mean() - expected_part) < z_limit(4) * part.std() / math.sqrt(n)


@pytest.mark.parametrize("loose", [1.0, 4.0])
def test_delta_tracking_scatters_by_the_free_flight_distribution(tmp_path, loose):
    from tests.renderer.grid_media_calls import free_flights

    flat = compile_scene(load(grid_scene(tmp_path, GRID, "trilinear", 1.5)).graph)
    loosen(flat, loose)
    n = 40_000
    t = free_flights(flat, O, D, 9, n)
    # P(t < s) = 1 - exp(-depth(0, s)) at a few s, and the share that passes through.
    cuts = (3.4, 4.0, 4.5, 10.0)
    assert not np.any(t < 2.8)  # before the box
    for s in cuts:
        p = 1.0 - math.exp(-optical_depth(GRID, "trilinear", 1.5, O, D, 0.0, s))
        k = int(np.sum(t < s))
        assert binomial_p_value(k, n, p) > ALPHA / len(cuts), (s, k / n, p)


def test_no_nan_at_the_grid_s_faces_edges_and_in_empty_cells(tmp_path):
    """Rays along the box's faces and edges, through its corners, parallel to its axes, starting
    on its boundary and inside, through a grid that is empty but for one cell: every estimate is
    finite and in [0, 1], every free flight finite or inf."""
    from tests.renderer.grid_media_calls import free_flights, shadow_estimates

    sparse = np.zeros((4, 4, 4))
    sparse[1, 2, 3] = 5.0
    for interpolation in ("nearest", "trilinear"):
        path = tmp_path / interpolation
        path.mkdir()
        flat = compile_scene(load(grid_scene(path, sparse, interpolation, 1.0)).graph)
        m, _ = world_map()

        def world(p):
            return m[:, :3] @ np.asarray(p, float) + m[:, 3]

        rays = []
        for a, b in [((0, 0, 0), (1, 1, 1)), ((0, 0, 0), (1, 0, 0)), ((0, 0.5, 0), (1, 0.5, 0)), ((0, 1, 1), (1, 1, 1)),
                     ((0.5, 0.5, 0.5), (0.5, 0.5, 1)), ((0.25, 0.625, 0.875), (0.25, 0.625, 0.0)), ((1, 1, 1), (0, 0, 0))]:
            start, end = world(a), world(b)
            rays.append((start, end - start))
            rays.append((start - (end - start), 3.0 * (end - start)))  # from outside, through it
        for o, d in rays:
            est = shadow_estimates(flat, o, d, 1.0, 1, 200)
            assert np.all(np.isfinite(est)) and est.min() >= 0.0 and est.max() <= 1.0
            t = free_flights(flat, o, d, 2, 200)
            assert not np.any(np.isnan(t))


def test_henyey_greenstein_sampling_follows_its_density():
    from tests.renderer.grid_media_calls import hg_draws

    n = 200_000
    for g in (-0.7, 0.3, 0.9):
        w = np.array([0.3, -0.5, 0.8])
        w /= np.linalg.norm(w)
        out = hg_draws(g, w, 7, n)
        d = out[:, :3]
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
        assert np.allclose(out[:, 3], out[:, 4], rtol=1e-12)
        cos = d @ w
        # The cdf of cos theta: (1 - g^2) / (2 g) (1 / sqrt(1 + g^2 - 2 g c) - 1 / (1 + g)).
        edges = np.linspace(-1, 1, 41)
        cdf = (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * edges) - 1 / (1 + g))
        counts, _ = np.histogram(cos, edges)
        p_value, _ = chi2_test(counts, np.diff(cdf))
        assert p_value > ALPHA, (g, p_value)
        # The azimuth about w is uniform.
        s = np.cross(w, [1.0, 0, 0])
        s /= np.linalg.norm(s)
        t = np.cross(w, s)
        phi = np.arctan2(d @ t, d @ s)
        counts, _ = np.histogram(phi, np.linspace(-np.pi, np.pi, 17))
        assert chi2_test(counts, np.full(16, 1 / 16))[0] > ALPHA
        # And the density integrates to 1 over the sphere (a midpoint rule in cos theta).
        c = np.linspace(-1, 1, 200_001)
        mid = 0.5 * (c[1:] + c[:-1])
        value = (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * mid) ** 1.5)
        assert 2 * np.pi * np.sum(value * np.diff(c)) == pytest.approx(1.0, rel=1e-6)


ROOM = """
camera: {{look_from: [0, 1, 4.5], look_at: [0, 1, 0], vfov: 40}}
image: {{width: 24, height: 24, samples_per_pixel: {spp}, max_depth: 8}}
background: [0, 0, 0]
materials:
  white: {{type: lambertian, albedo: [0.7, 0.7, 0.7]}}
  lamp: {{type: diffuse_light, emit: [6, 6, 6]}}
media:
  fog: {medium}
shapes:
  - {{type: quad, q: [-2, 0, -2], u: [4, 0, 0], v: [0, 0, 4], material: white}}
  - {{type: quad, q: [-2, 0, -2], u: [0, 3, 0], v: [4, 0, 0], material: white}}
  - {{type: quad, q: [-0.5, 2.9, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp}}
  - {{type: box, min: [-0.8, 0.2, -0.8], max: [0.8, 1.8, 0.8], interior: fog, transform: [{{rotate: {{axis: y, degrees: 30}}}}]}}
"""


def room(folder: Path, medium: str, spp: int, name: str) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(ROOM.format(medium=medium, spp=spp))
    return path


def test_a_constant_grid_renders_like_the_constant_medium_it_equals(tmp_path):
    import rt

    np.save(tmp_path / "ones.npy", np.ones((3, 4, 5)))
    constant = room(tmp_path, "{type: constant, density: 1.2, albedo: [0.8, 0.6, 0.4]}", 64, "constant")
    grid = room(tmp_path, "{type: grid, file: ones.npy, bounds: [[-0.8, 0.2, -0.8], [0.8, 1.8, 0.8]], "
                "interpolation: trilinear, density: 1.2, albedo: [0.8, 0.6, 0.4]}", 64, "grid")
    a = rt.render(str(constant), seed=1, kernel="general", adaptive=False)
    b = rt.render(str(grid), seed=2, kernel="general", adaptive=False)
    assert a.stats.bad_samples == 0 and b.stats.bad_samples == 0
    z = block_z(a.film, b.film, block=4)
    assert np.abs(z).max() < z_limit(z.size), np.abs(z).max()
    whole = block_z(a.film, b.film, block=24)
    assert np.abs(whole).max() < z_limit(3)
    # The two are different estimators, not the same numbers.
    assert not np.array_equal(a.film.total, b.film.total)


def test_a_forward_scattering_constant_medium_renders_like_its_grid_with_threads_one_and_two_alike(tmp_path):
    """Henyey-Greenstein in both (light sampling weighs its density too); and the grid's image on
    one thread is its image on two, bit for bit."""
    import rt

    np.save(tmp_path / "ones.npy", np.ones((2, 2, 2)))
    haze = "phase: {type: henyey_greenstein, g: 0.6}, albedo: [0.9, 0.9, 0.9]"
    constant = room(tmp_path, f"{{type: constant, density: 0.8, {haze}}}", 64, "constant")
    grid = room(tmp_path, "{type: grid, file: ones.npy, bounds: [[-0.8, 0.2, -0.8], [0.8, 1.8, 0.8]], "
                f"interpolation: nearest, density: 0.8, {haze}}}", 64, "grid")
    a = rt.render(str(constant), seed=3, kernel="general", adaptive=False)
    b = rt.render(str(grid), seed=4, kernel="general", adaptive=False, threads=1)
    c = rt.render(str(grid), seed=4, kernel="general", adaptive=False, threads=2)
    assert np.array_equal(b.film.total, c.film.total) and np.array_equal(b.film.total_sq, c.film.total_sq)
    z = block_z(a.film, b.film, block=4)
    assert np.abs(z).max() < z_limit(z.size), np.abs(z).max()


def test_a_noise_medium_renders_finite_and_the_same_on_one_thread_and_two(tmp_path):
    import rt

    puff = room(tmp_path, "{type: noise, scale: 3, form: turbulence, octaves: 3, density: 4, albedo: [0.9, 0.8, 0.7]}", 8, "puff")
    one = rt.render(str(puff), seed=5, kernel="general", adaptive=False, threads=1)
    two = rt.render(str(puff), seed=5, kernel="general", adaptive=False, threads=2)
    assert one.stats.bad_samples == 0 and one.film.total.sum() > 0
    assert np.array_equal(one.film.total, two.film.total)


def test_rt_validate_names_the_medium_that_switches_the_varying_path_on(tmp_path):
    import subprocess

    path = grid_scene(tmp_path, GRID, "nearest", 1.0)
    out = subprocess.run([sys.executable, "-m", "rt", "validate", str(path)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "media of varying density: on (shapes[0] holds cloud, a grid medium)" in out.stdout
    assert "Henyey-Greenstein phase: off" in out.stdout


def test_the_noise_field_uses_the_noise_texture_s_form_codes_and_lattice(tmp_path):
    """grid_media keeps its own copy of the three form codes and reads the texture's lattice: both
    must stay the texture's, or a noise medium would not be the noise texture's field."""
    from renderer import grid_media
    from renderer.textures import NOISE_FORMS, perlin_tables
    from tests.renderer.grid_media_calls import densities

    assert (grid_media.NOISE_PLAIN, grid_media.NOISE_TURBULENCE, grid_media.NOISE_MARBLE) == (
        NOISE_FORMS["plain"], NOISE_FORMS["turbulence"], NOISE_FORMS["marble"])
    path = tmp_path / "s.yaml"
    path.write_text("camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\nmedia:\n"
                    "  puff: {type: noise, scale: 3, form: plain, density: 2, seed: 4}\n"
                    "shapes:\n  - {type: box, min: [0, 0, 0], max: [1, 1, 1], interior: puff}\n")
    flat = compile_scene(load(path).graph)
    points = RNG.random((500, 3)) * 4 - 2
    got = densities(flat.bnd_f, field_header(flat), points)
    # The texture's plain form, 0.5 (1 + perlin(scale p)), from its own lattice, in numpy.
    perm, vec = perlin_tables(4)

    def perlin(p):
        f = np.floor(p)
        u = p - f
        i = f.astype(int)
        s = u * u * (3 - 2 * u)
        total = 0.0
        for di in range(2):
            for dj in range(2):
                for dk in range(2):
                    h = perm[0, (i[0] + di) & 255] ^ perm[1, (i[1] + dj) & 255] ^ perm[2, (i[2] + dk) & 255]
                    w = ((s[0] if di else 1 - s[0]) * (s[1] if dj else 1 - s[1]) * (s[2] if dk else 1 - s[2]))
                    total += w * vec[h] @ (u - np.array([di, dj, dk]))
        return total

    expected = np.array([2.0 * 0.5 * (1.0 + perlin(3.0 * p)) for p in points])
    assert np.allclose(got, np.maximum(expected, 0.0), rtol=1e-12, atol=1e-12)
