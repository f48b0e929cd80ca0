"""Chi-square tests of every sampling routine against its density (as Mitsuba's chi2 tests do).

Each routine is run through a small @njit loop (tests/renderer/kernel_calls.py) with the
renderer's counter-based random numbers, so the draws are exactly those a render makes. Samples are mapped to coordinates in which the target density is uniform,
binned on a grid of equal-probability cells (>= 5 expected per cell, in fact ~1000), and the
chi-square statistic is compared at significance `ALPHA` = 1e-3. Seeds are fixed, so every
outcome is deterministic; the controls at the bottom show that the same check rejects the
classic wrong samplers (a normalised cube, a uniform hemisphere for lambertian, r = U on a disk).
"""

import math

import numpy as np
import pytest

from renderer.materials import DIELECTRIC, ISOTROPIC, LAMBERTIAN, fresnel_dielectric
from tests.renderer.kernel_calls import camera_rays, medium_distances, scatter_many, unit_vectors
from tests.renderer.stats import ALPHA, binomial_p_value, chi2_sf, chi2_test

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

N = 200_000
SEED = 20240607


def frame(n):
    """An orthonormal basis (t, b, n) around unit n."""
    n = np.asarray(n, float) / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t)
    return t, np.cross(n, t), n


def grid_counts(x, y, nx, ny):
    """Counts of points (x, y) in [0, 1)^2 on an nx by ny grid."""
    ix = np.clip((np.asarray(x) * nx).astype(int), 0, nx - 1)
    iy = np.clip((np.asarray(y) * ny).astype(int), 0, ny - 1)
    return np.bincount(ix * ny + iy, minlength=nx * ny)


def sphere_p_value(v, axis=(0.0, 0.0, 1.0)):
    """Uniform directions: z = cos(theta) about `axis` and the azimuth are independent and uniform."""
    t, b, n = frame(axis)
    u = unit_rows(v)
    z = u @ n
    phi = np.arctan2(u @ b, u @ t)
    return chi2_test(grid_counts((z + 1) / 2, (phi + np.pi) / (2 * np.pi), 20, 20), np.full(400, 1 / 400))[0]


def cosine_p_value(v, normal):
    """Cosine-weighted directions about `normal`: cos^2(theta) and the azimuth are independent and uniform."""
    t, b, n = frame(normal)
    u = unit_rows(v)
    c = u @ n
    phi = np.arctan2(u @ b, u @ t)
    assert (c >= 0).all(), "a lambertian direction below the surface"
    return chi2_test(grid_counts(c * c, (phi + np.pi) / (2 * np.pi), 20, 20), np.full(400, 1 / 400))[0]


def disk_p_value(x, y):
    """Uniform on the unit disk: r^2 and the angle are independent and uniform."""
    r2 = x * x + y * y
    assert (r2 <= 1 + 1e-12).all()
    phi = np.arctan2(y, x)
    return chi2_test(grid_counts(r2, (phi + np.pi) / (2 * np.pi), 10, 20), np.full(200, 1 / 200))[0]


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


# --- the chi-square machinery itself ----------------------------------------------------------


@pytest.mark.parametrize("x, dof, p", [(3.841458820694124, 1, 0.05), (18.307038053275146, 10, 0.05),
                                       (124.34211340400407, 100, 0.05), (0.0039321400000195, 1, 0.95),
                                       (50.892181311517, 30, 0.01)])
def test_chi2_tail_matches_tables(x, dof, p):
    assert chi2_sf(x, dof) == pytest.approx(p, rel=2e-3)


def test_binomial_p_value_matches_direct_sums():
    # 3 successes in 10 at p = 0.5: P(X <= 3) = 176/1024.
    assert binomial_p_value(3, 10, 0.5) == pytest.approx(2 * 176 / 1024, rel=1e-12)
    assert binomial_p_value(0, 1000, 1e-6) == 1.0
    assert binomial_p_value(3, 1000, 1e-6) < 1e-9


# --- the renderer's routines ------------------------------------------------------------------


@pytest.mark.parametrize("bounce", [0, 37])
def test_random_unit_vector_is_uniform_on_the_sphere(bounce):
    v = unit_vectors(SEED, N, bounce)
    assert np.allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-12)
    # About z and about a skew axis: the (cos, azimuth) grid depends on the axis.
    assert sphere_p_value(v) > ALPHA
    assert sphere_p_value(v, (1.0, -2.0, 0.5)) > ALPHA


def test_isotropic_phase_is_uniform_on_the_sphere():
    d = np.array([0.3, -0.2, 0.9])
    v = scatter_many(ISOTROPIC, 0.0, 1.0, d, np.array([1.0, 0.0, 0.0]), True, SEED + 1, N, 3)
    assert sphere_p_value(v) > ALPHA
    assert sphere_p_value(v, d) > ALPHA  # no memory of the incoming direction


@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.0, -1.0, 0.0), (1.0, 2.0, -0.5)])
def test_lambertian_directions_are_cosine_weighted(normal):
    n = np.array(normal) / np.linalg.norm(normal)
    v = scatter_many(LAMBERTIAN, 0.0, 1.0, -n, n, True, SEED + 2, N, 1)
    assert cosine_p_value(v, n) > ALPHA


def test_defocus_disk_is_uniform():
    cam = np.zeros(21)
    cam[3:6] = (-1.0, 1.0, -1.0)  # pixel (0, 0) on the focus plane
    cam[6:9], cam[9:12] = (0.01, 0.0, 0.0), (0.0, -0.01, 0.0)
    radius = 0.25
    cam[12:15], cam[15:18] = (radius, 0.0, 0.0), (0.0, radius, 0.0)
    cam[18] = radius
    cam[19], cam[20] = 0.0, 1.0
    o, d, _ = camera_rays(cam, SEED + 3, N)
    assert np.allclose(o[:, 2], 0.0)
    assert disk_p_value(o[:, 0] / radius, o[:, 1] / radius) > ALPHA


def test_pixel_positions_are_uniform_over_the_pixel():
    cam = np.zeros(21)
    cam[3:6] = (-1.0, 1.0, -1.0)
    cam[6:9], cam[9:12] = (0.01, 0.0, 0.0), (0.0, -0.01, 0.0)
    o, d, _ = camera_rays(cam, SEED + 4, N)
    # Pinhole at the origin: the direction ends on the focus plane z = -1 inside pixel (0, 0).
    fx = (d[:, 0] - (-1.0)) / 0.01 + 0.5
    fy = (d[:, 1] - 1.0) / -0.01 + 0.5
    assert fx.min() >= -1e-9 and fx.max() <= 1 + 1e-9 and fy.min() >= -1e-9 and fy.max() <= 1 + 1e-9
    assert chi2_test(grid_counts(fx, fy, 20, 20), np.full(400, 1 / 400))[0] > ALPHA


def test_time_is_uniform_over_the_shutter():
    cam = np.zeros(21)
    cam[3:6] = (-1.0, 1.0, -1.0)
    cam[6:9], cam[9:12] = (0.01, 0.0, 0.0), (0.0, -0.01, 0.0)
    cam[19], cam[20] = 2.0, 5.0
    _, _, t = camera_rays(cam, SEED + 5, N)
    assert t.min() >= 2.0 and t.max() < 5.0
    assert chi2_test(np.bincount(((t - 2.0) / 3.0 * 100).astype(int), minlength=100), np.full(100, 0.01))[0] > ALPHA


def test_medium_free_flight_distance_is_exponential():
    """Distance to a scattering event: density sigma e^(-sigma t), and e^(-sigma R) of paths leave."""
    from scenefmt import models as m
    from scenefmt.graph import build_graph
    from renderer.compile import compile_scene

    sigma, radius = 2.0, 1.5
    scene = m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=radius, interior=m.ConstantMedium(density=sigma))])
    flat = compile_scene(build_graph(scene))
    t = medium_distances(flat.prims_f, flat.bnd_i, flat.bnd_f, SEED + 6, N)
    escaped = np.isinf(t)
    assert (t[~escaped] >= 0).all() and (t[~escaped] <= radius * (1 + 1e-12)).all()
    # Bins of equal probability in u = 1 - e^(-sigma t) over [0, 1 - e^(-sigma R)), plus one bin for escapes.
    inside = 1.0 - math.exp(-sigma * radius)
    u = (1.0 - np.exp(-sigma * t[~escaped])) / inside
    counts = np.append(np.bincount(np.clip((u * 50).astype(int), 0, 49), minlength=50), escaped.sum())
    probs = np.append(np.full(50, inside / 50), 1.0 - inside)
    assert chi2_test(counts, probs)[0] > ALPHA


@pytest.mark.parametrize("ior, front, degrees", [(1.5, True, 0.0), (1.5, True, 60.0), (1.5, True, 85.0),
                                                 (1.5, False, 30.0), (1 / 1.33, True, 40.0), (2.4, False, 24.0)])
def test_dielectric_reflects_with_the_fresnel_probability(ior, front, degrees):
    """The reflect-or-refract choice: the number of reflections is binomial with p = the Fresnel reflectance."""
    theta = math.radians(degrees)
    n = np.array([0.0, 0.0, 1.0])
    d = np.array([math.sin(theta), 0.0, -math.cos(theta)])
    v = scatter_many(DIELECTRIC, 0.0, ior, d, n, front, SEED + 7, N, 2)
    reflected = v[:, 2] > 0
    eta = 1 / ior if front else ior
    r, _ = fresnel_dielectric(math.cos(theta), eta)
    assert 0.0 < r < 1.0
    assert binomial_p_value(int(reflected.sum()), N, r) > ALPHA


# --- controls: the same checks reject wrong samplers ------------------------------------------


def test_the_checks_accept_correct_numpy_samplers():
    rng = np.random.default_rng(7)
    g = rng.normal(size=(N, 3))
    assert sphere_p_value(g) > ALPHA
    n = np.array([1.0, 2.0, -0.5]) / math.sqrt(5.25)
    s = unit_rows(g)
    assert cosine_p_value(s + n, n) > ALPHA  # the books' n + unit vector is cosine-weighted
    r, phi = np.sqrt(rng.random(N)), rng.random(N) * 2 * np.pi
    assert disk_p_value(r * np.cos(phi), r * np.sin(phi)) > ALPHA


def test_the_checks_reject_wrong_samplers():
    rng = np.random.default_rng(8)
    cube = rng.uniform(-1, 1, (N, 3))
    assert sphere_p_value(cube) < ALPHA  # a normalised cube crowds the corners
    n = np.array([0.0, 0.0, 1.0])
    g = unit_rows(rng.normal(size=(N, 3)))
    hemisphere = np.where((g @ n)[:, None] < 0, -g, g)
    assert cosine_p_value(hemisphere, n) < ALPHA  # uniform, not cosine-weighted
    r, phi = rng.random(N), rng.random(N) * 2 * np.pi
    assert disk_p_value(r * np.cos(phi), r * np.sin(phi)) < ALPHA  # r = U crowds the centre
