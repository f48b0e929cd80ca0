"""The auxiliary passes (renderer/tracing/aux_passes.py) against closed forms on simple scenes.

Each pixel of a pass is the mean of `samples` jittered camera rays, so where the exact value
varies across a pixel the expected pass is that value's mean over the pixel's footprint, here
by quadrature on a sub x sub grid (tests/renderer/scenes.pixel_rays), and the tolerance is
four standard errors of the mean (the spread of the quadrature points over sqrt(samples)).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.tracing.aux_passes import AUX_PASSES, render_aux
from scenefmt import models as m
from scenefmt.graph import build_graph

from .scenes import pixel_rays, scene

BLACK = (0.0, 0.0, 0.0)
# A field of view whose half-height at distance 5 is exactly 1 (tan = 0.2).
VFOV_HALF_HEIGHT_1 = math.degrees(2.0 * math.atan(0.2))


def passes_of(shapes, *, width=16, height=16, samples=16, seed=3, **camera):
    sc = scene(shapes, background=BLACK, width=width, height=height, **camera)
    out = render_aux(compile_scene(build_graph(sc)), width, height, samples=samples, seed=seed)
    for name, value in out.items():
        assert value.dtype == np.float32, name
        assert np.isfinite(value).all(), name
    assert out["albedo"].shape == (height, width, 3) and out["normal"].shape == (height, width, 3)
    assert out["depth"].shape == (height, width)
    return sc, out


def wall(z, material, half=50.0, facing=1.0):
    """A square in the plane at height z, seen from +z (facing=1) or from -z (facing=-1)."""
    u = (2 * half, 0.0, 0.0) if facing > 0 else (0.0, 2 * half, 0.0)
    v = (0.0, 2 * half, 0.0) if facing > 0 else (2 * half, 0.0, 0.0)
    return m.Quad(q=(-half, -half, z), u=u, v=v, material=material)


def test_the_passes_are_named_as_the_front_ends_list_them():
    assert AUX_PASSES == ("albedo", "normal", "depth")


@pytest.mark.parametrize("width, height, samples, seed", [(0, 4, 1, 0), (4, 0, 1, 0), (4, 4, 0, 0), (4, 4, 1, -1)])
def test_bad_sizes_are_refused_before_any_kernel_runs(width, height, samples, seed):
    with pytest.raises(ValueError, match="passes"):
        render_aux(None, width, height, samples=samples, seed=seed)


@pytest.mark.slow
def test_a_lambertian_plane_facing_the_camera_is_its_albedo_its_normal_and_its_distance():
    albedo = (0.3, 0.5, 0.7)
    _, out = passes_of([wall(0.0, m.Lambertian(albedo=albedo))], look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30)
    np.testing.assert_allclose(out["albedo"], np.broadcast_to(albedo, out["albedo"].shape), atol=1e-6)
    np.testing.assert_allclose(out["normal"], np.broadcast_to((0, 0, 1), out["normal"].shape), atol=1e-6)
    # The view axis is -z: every point of the plane lies 5 along it, whatever the pixel.
    np.testing.assert_allclose(out["depth"], 5.0, rtol=1e-6)


@pytest.mark.slow
def test_a_checkered_plane_averages_to_the_mean_of_its_colours():
    # Cells of 0.25 over the visible square [-1, 1]^2, 32 pixels: four pixels a cell, none
    # straddling two, so each pixel is exactly its cell's colour and the image their mean.
    even, odd = (0.1, 0.2, 0.3), (0.9, 0.6, 0.5)
    tex = m.CheckerTexture(scale=0.25, even=even, odd=odd)
    z = 0.125  # mid-cell in z: floor(z / scale) is 0 for every hit
    _, out = passes_of([wall(z, m.Lambertian(albedo=tex))], width=32, height=32, look_from=(0, 0, 5 + z),
                       look_at=(0, 0, z), vfov=VFOV_HALF_HEIGHT_1)
    # Pixel centres: x = -1 + (i + 0.5) / 16 to the right, y = 1 - (j + 0.5) / 16 downwards.
    centres = (np.arange(32) + 0.5) / 16.0
    x, y = -1.0 + centres[None, :], 1.0 - centres[:, None]
    parity = (np.floor(x / 0.25) + np.floor(y / 0.25)) % 2
    expected = np.where(parity[..., None] == 0, even, odd)
    np.testing.assert_allclose(out["albedo"], expected, atol=1e-6)
    np.testing.assert_allclose(out["albedo"].astype(np.float64).mean(axis=(0, 1)), (np.array(even) + odd) / 2, atol=1e-6)


def sphere_hits(origin, dirs, centre, radius):
    """Distance along each unit direction from `origin` to a sphere (nan on a miss)."""
    oc = np.asarray(origin) - centre
    b = dirs @ oc
    disc = b * b - (oc @ oc - radius * radius)
    with np.errstate(invalid="ignore"):
        return -b - np.sqrt(disc)


@pytest.mark.slow
def test_the_normals_of_a_sphere_are_its_radial_directions():
    samples = 64
    centre, radius = np.array([0.0, 0.0, 0.0]), 1.0
    sc, out = passes_of([m.Sphere(center=tuple(centre), radius=radius, material=m.Lambertian())], width=24, height=24,
                        samples=samples, look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30)
    origin, dirs = pixel_rays(sc, sub=8)
    t = sphere_hits(origin, dirs, centre, radius)
    # Pixels the sphere covers whole, or misses whole: judged on a grid from edge to edge.
    _, edge_dirs = pixel_rays(sc, sub=8, corners=True)
    t_edges = sphere_hits(origin, edge_dirs, centre, radius)
    inside = np.isfinite(t_edges).all(axis=-1)
    assert inside.sum() > 100
    normals = (origin + t[..., None] * dirs - centre) / radius
    mean = normals.mean(axis=2)
    spread = normals.std(axis=2).max(axis=-1)
    got = out["normal"].astype(np.float64)
    error = np.abs(got - mean).max(axis=-1)
    assert (error[inside] <= 4.0 * spread[inside] / math.sqrt(samples) + 1e-4).all()
    # Against the pixel's centre ray: within the normal's change across the pixel.
    _, centre_dirs = pixel_rays(sc, sub=1)
    tc = sphere_hits(origin, centre_dirs, centre, radius)
    at_centre = (origin + tc[..., None] * centre_dirs - centre)[:, :, 0] / radius
    across = np.abs(normals - at_centre[:, :, None]).max(axis=(2, 3))
    assert (np.abs(got - at_centre).max(axis=-1)[inside] <= across[inside]).all()
    # Means of unit normals: as long as the exact mean over the pixel (1 less the normals'
    # spread across it, most along the silhouette); none where the pixel is all background.
    lengths = np.linalg.norm(got, axis=-1)
    assert (np.abs(lengths - np.linalg.norm(mean, axis=-1))[inside] <= 4.0 * spread[inside] / math.sqrt(samples) + 1e-4).all()
    assert (lengths[inside] <= 1.0 + 1e-6).all()
    missed = np.isnan(t_edges).all(axis=-1)
    assert missed.sum() > 100
    assert (got[missed] == 0.0).all() and (out["albedo"][missed] == 0.0).all() and (out["depth"][missed] == 0.0).all()


@pytest.mark.slow
def test_the_depth_of_a_tilted_plane_is_its_distance_along_the_view_axis():
    samples = 32
    tilt = math.radians(40.0)
    # A plane through the origin, its normal tilted from +z towards +y.
    n = np.array([0.0, math.sin(tilt), math.cos(tilt)])
    u = (100.0, 0.0, 0.0)
    v = tuple(100.0 * np.array([0.0, math.cos(tilt), -math.sin(tilt)]))
    q = tuple(-0.5 * np.array(u) - 0.5 * np.array(v))
    sc, out = passes_of([m.Quad(q=q, u=u, v=v, material=m.Lambertian())], width=16, height=16, samples=samples,
                        look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30)
    origin, dirs = pixel_rays(sc, sub=8)
    t = -(np.asarray(origin) @ n) / (dirs @ n)
    depth = t * dirs[..., 2] * -1.0  # along the view axis, -z
    expected = depth.mean(axis=2)
    spread = depth.std(axis=2)
    error = np.abs(out["depth"] - expected)
    assert (error <= 4.0 * spread / math.sqrt(samples) + 1e-5 * expected).all()
    # The plane recedes upwards: depth grows from the bottom row to the top one, and a plane's
    # 1 / depth is linear in the row (a perspective view), which the pixels' means follow closely.
    rows = out["depth"].mean(axis=1)
    assert (np.diff(rows) < 0).all()
    fit = np.polyfit(np.arange(16), 1.0 / rows, 1)
    assert np.abs(np.polyval(fit, np.arange(16)) - 1.0 / rows).max() < 1e-3 * (1.0 / rows).mean()
    np.testing.assert_allclose(out["normal"], np.broadcast_to(n, out["normal"].shape), atol=1e-6)


def fresnel(cos_i, eta):
    """Unpolarised Fresnel reflectance of a smooth dielectric, eta = n_outside / n_inside."""
    sin_t2 = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = np.sqrt(1.0 - sin_t2)
    rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return 0.5 * (rs * rs + rp * rp)


@pytest.mark.slow
def test_glass_in_front_of_a_lambertian_shows_its_albedo_times_the_fresnel_transmittance():
    samples = 64
    a = np.array([0.5, 0.6, 0.7])
    sc, out = passes_of([wall(1.0, m.Dielectric(ior=1.5)), wall(0.0, m.Lambertian(albedo=tuple(a)))], samples=samples,
                        look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=20)
    # A sample refracts with probability 1 - R and then meets the lambertian; else it is
    # reflected back into the black background (albedo 0).
    origin, dirs = pixel_rays(sc, sub=4)
    transmitted = 1.0 - fresnel(-dirs[..., 2], 1.0 / 1.5)
    expected = transmitted.mean() * a
    n = out["albedo"].shape[0] * out["albedo"].shape[1] * samples
    sigma = math.sqrt(0.04 * 0.96 / n)
    np.testing.assert_allclose(out["albedo"].mean(axis=(0, 1)), expected, atol=4.0 * sigma)
    # Each sample's albedo is the lambertian's or 0: a pixel's mean lies between.
    assert (out["albedo"] <= a + 1e-6).all()
    # The normal is the lambertian's, on the samples that reach it; the depth is the glass's.
    np.testing.assert_allclose(out["normal"][..., 2].mean(), transmitted.mean(), atol=4.0 * sigma)
    np.testing.assert_allclose(out["depth"], 4.0, rtol=1e-6)


@pytest.mark.slow
def test_a_mirror_shows_what_it_reflects_times_its_tint():
    a, tint = np.array([0.5, 0.6, 0.7]), np.array([0.8, 0.7, 0.6])
    # The mirror faces the camera; the lambertian behind the camera faces the mirror.
    _, out = passes_of([wall(0.0, m.Metal(albedo=tuple(tint))), wall(10.0, m.Lambertian(albedo=tuple(a)), facing=-1.0)],
                       look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30)
    np.testing.assert_allclose(out["albedo"], np.broadcast_to(a * tint, out["albedo"].shape), atol=1e-6)
    # The lambertian's normal on the side the reflected ray arrives from, and the mirror's depth.
    np.testing.assert_allclose(out["normal"], np.broadcast_to((0, 0, -1), out["normal"].shape), atol=1e-6)
    np.testing.assert_allclose(out["depth"], 5.0, rtol=1e-6)


@pytest.mark.slow
def test_a_light_shows_its_radiance_clamped_and_nothing_hit_shows_zeros():
    _, out = passes_of([wall(0.0, m.DiffuseLight(emit=(15.0, 0.5, 0.0)))], look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30)
    np.testing.assert_allclose(out["albedo"], np.broadcast_to((1.0, 0.5, 0.0), out["albedo"].shape), atol=1e-6)
    # Only a sphere behind the camera: every ray escapes.
    _, out = passes_of([m.Sphere(center=(0, 0, 9), radius=1.0, material=m.Lambertian())], look_from=(0, 0, 5),
                       look_at=(0, 0, 0), vfov=30)
    for name in AUX_PASSES:
        assert (out[name] == 0.0).all(), name


@pytest.mark.slow
def test_the_passes_repeat_with_their_seed_and_change_with_another():
    shapes = [m.Sphere(center=(0, 0, 0), radius=1.0, material=m.Lambertian(albedo=(0.2, 0.4, 0.8))),
              wall(-1.0, m.Lambertian(albedo=(0.9, 0.9, 0.9)))]
    _, one = passes_of(shapes, look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30, seed=5)
    _, again = passes_of(shapes, look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30, seed=5)
    _, other = passes_of(shapes, look_from=(0, 0, 5), look_at=(0, 0, 0), vfov=30, seed=6)
    for name in AUX_PASSES:
        assert np.array_equal(one[name], again[name]), name
    assert not np.array_equal(one["normal"], other["normal"])
