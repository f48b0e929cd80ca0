"""integrator caustics: light tracing of the caustic paths a camera sees on matte surfaces
(caustic_targets.py, light_emission.py, tracing/caustics.py, the split in tracing/integrator.py).

Its samplers are checked against their own densities (chi-square), the camera's projection
against the camera's own rays, and the whole estimator against mis's converged references by
region z-tests: the split must give every path to exactly one of the two halves.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import rt
from renderer.caustic_targets import CAUSTIC_F

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stats import chi2_test, z_limit  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CAUSTIC = ROOT / "benchmarks" / "scenes" / "caustic_glass.yaml"

TWO_SPHERES = CAUSTIC_F.array(2, center=np.array([[0.0, 0.5, 0.0], [0.8, 0.3, 0.2]]), radius=np.array([0.5, 0.3]))


def _flat_of(text, integrator="caustics"):
    import yaml
    from renderer.session import flatten_loaded

    return flatten_loaded(rt.load(yaml.safe_load(text)), None, integrator)[1]


TARGETS = """
camera: {look_from: [0, 2, 6], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 8, height: 6, samples_per_pixel: 1, max_depth: 8, integrator: caustics}
background: [0, 0, 0]
materials:
  glass: {type: dielectric, ior: 1.5}
  steel: {type: metal, albedo: [0.8, 0.8, 0.8], fuzz: 0.1}
  clay: {type: lambertian, albedo: [0.5, 0.5, 0.5]}
  lamp: {type: diffuse_light, emit: [4, 4, 4]}
groups:
  ball:
    shapes:
      - {type: sphere, center: [0, 0, 0], radius: 1, material: glass}
shapes:
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: glass}
  - {type: sphere, center: [1.5, 0.5, 0], radius: 0.5, material: steel}
  - {type: sphere, center: [-1.5, 0.5, 0], radius: 0.5, material: clay}
  - {type: quad, q: [-1, 3, -1], u: [2, 0, 0], v: [0, 0, 2], material: lamp}
  - {type: instance, group: ball, transform: [{scale: 0.25}, {translate: [0, 0.25, 2]}]}
"""


def test_targets_are_the_specular_spheres_in_every_placement():
    from renderer.caustic_targets import CT_CENTER, CT_RADIUS

    flat = _flat_of(TARGETS)
    rows = sorted((tuple(np.round(r[CT_CENTER:CT_CENTER + 3], 9)), round(r[CT_RADIUS], 9)) for r in flat.caustic_f)
    assert rows == [((0.0, 0.25, 2.0), 0.25), ((0.0, 0.5, 0.0), 0.5), ((1.5, 0.5, 0.0), 0.5)]
    assert flat.caustic_prim.sum() == 3  # the glass, the steel and the instanced ball's glass
    assert len(flat.caustic_lf) == 1 and flat.caustic_lf[0, 2] == 1.0  # the lamp sends every photon


def test_a_non_uniform_scale_keeps_the_sphere_with_the_path_tracer():
    flat = _flat_of(TARGETS.replace("{scale: 0.25}", "{scale: [0.25, 0.5, 0.25]}"))
    assert len(flat.caustic_f) == 2 and flat.caustic_prim.sum() == 2


def test_other_integrators_build_no_targets():
    flat = _flat_of(TARGETS, "mis")
    assert len(flat.caustic_f) == 0 and flat.caustic_prim.sum() == 0 and len(flat.caustic_lf) == 0


def _sphere_bins(dirs, nz=8, nphi=16):
    """Equal-area bins of the sphere: (cos theta, phi) on a grid."""
    z = np.clip(((dirs[:, 2] + 1) / 2 * nz).astype(int), 0, nz - 1)
    phi = np.clip(((np.arctan2(dirs[:, 1], dirs[:, 0]) + np.pi) / (2 * np.pi) * nphi).astype(int), 0, nphi - 1)
    return z * nphi + phi


@pytest.mark.slow
@pytest.mark.parametrize("x", [(0.0, 2.5, 0.3), (0.1, 0.6, 0.0)], ids=["outside", "inside the first"])
def test_directions_toward_targets_follow_their_density(x):
    from caustic_calls import toward_densities, toward_samples

    x = np.array(x)
    dirs, pdf, again = toward_samples(TWO_SPHERES, x, 200_000, 5)
    assert np.all(pdf > 0) and np.allclose(pdf, again, rtol=1e-12)
    # Expected counts per bin: the density integrated over the bin, by uniform directions.
    rng = np.random.default_rng(1)
    u = rng.normal(size=(2_000_000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    dens = toward_densities(TWO_SPHERES, x, u)
    bins = _sphere_bins(u)
    probs = np.bincount(bins, weights=dens, minlength=128) * (4 * np.pi / len(u))
    assert probs.sum() == pytest.approx(1.0, abs=0.01)
    counts = np.bincount(_sphere_bins(dirs), minlength=128)
    stat, dof = chi2_test(counts, probs / probs.sum())
    from stats import chi2_sf
    assert chi2_sf(stat, dof) > 1e-4


@pytest.mark.slow
def test_points_across_targets_follow_their_density():
    from caustic_calls import across_samples

    w = np.array([0.3, 0.9, 0.1])
    w /= np.linalg.norm(w)
    pts, pdf, again = across_samples(TWO_SPHERES, w, 200_000, 7)
    assert np.all(pdf > 0) and np.allclose(pdf, again, rtol=1e-12)
    assert np.allclose(pts @ w, 0.0, atol=1e-9)  # on the plane through the origin
    # In the plane's frame, a grid of cells; expected counts from the density at cell points.
    a = np.cross(w, [1.0, 0, 0]); a /= np.linalg.norm(a)
    b = np.cross(w, a)
    pa, pb = pts @ a, pts @ b
    lo_a, hi_a, lo_b, hi_b = pa.min(), pa.max(), pb.min(), pb.max()
    n = 12
    ia = np.clip(((pa - lo_a) / (hi_a - lo_a) * n).astype(int), 0, n - 1)
    ib = np.clip(((pb - lo_b) / (hi_b - lo_b) * n).astype(int), 0, n - 1)
    counts = np.bincount(ia * n + ib, minlength=n * n)
    fine = 400
    ga, gb = np.meshgrid(lo_a + (np.arange(fine) + 0.5) * (hi_a - lo_a) / fine, lo_b + (np.arange(fine) + 0.5) * (hi_b - lo_b) / fine,
                         indexing="ij")
    grid = ga.reshape(-1, 1) * a + gb.reshape(-1, 1) * b
    dens = _density_across(w, grid)
    cell = (hi_a - lo_a) * (hi_b - lo_b) / fine ** 2
    cells = (np.arange(fine)[:, None] * n // fine) * n + (np.arange(fine)[None, :] * n // fine)
    probs = np.bincount(cells.ravel(), weights=dens * cell, minlength=n * n)
    assert probs.sum() == pytest.approx(1.0, abs=0.01)
    stat, dof = chi2_test(counts, probs / probs.sum())
    from stats import chi2_sf
    assert chi2_sf(stat, dof) > 1e-4


def _density_across(w, points):
    """pdf_across_targets in numpy, from its definition (for the chi-square's expected counts)."""
    r = TWO_SPHERES[:, 3]
    c = TWO_SPHERES[:, :3]
    proj = c - (c @ w)[:, None] * w
    inside = np.linalg.norm(points[:, None, :] - proj[None, :, :], axis=2) <= r[None, :]
    return inside.sum(axis=1) / (np.pi * (r * r).sum())


@pytest.mark.slow
@pytest.mark.parametrize("lens", [0.0, 0.3], ids=["pinhole", "lens"])
def test_the_camera_projection_finds_the_pixel_of_its_own_rays(lens):
    from caustic_calls import project_camera_rays
    from renderer.camera import camera_row
    from scenefmt.validation import loads

    text = TARGETS.replace("vfov: 40}", f"vfov: 40, aperture: {2 * lens}, focus_distance: 5}}") if lens else TARGETS
    graph = loads(text).graph
    cam = np.array(camera_row(graph), np.float64)
    out = project_camera_rays(cam, 8, 6, 5000, 3, 4.0)
    assert np.all(out[:, 2] == 1.0)
    assert np.array_equal(out[:, 0], out[:, 3]) and np.array_equal(out[:, 1], out[:, 4])
    assert np.all(out[:, 6] < 1e-12)  # the same lens point
    # K turns solid angle at the lens into pixels: a pixel's rays span 1 / K steradians, so K is
    # D^2 / (|du| |dv|) on the axis and grows off it (the end-to-end tests below check its use).
    assert np.all(out[:, 5] > 0)


def _converges_to_reference(stem, scene, spp, seed, block=6):
    """Block z-tests of an integrator-caustics render against mis's converged reference: each
    block's sum over the render's own noise and the reference's (the larger of its samples'
    spread and the difference of its two halves), Bonferroni over the blocks and the image."""
    sys.path.insert(0, str(ROOT / "tests" / "renderer"))
    from converged import load_reference

    ref = load_reference(stem)
    film = rt.render(scene, spp=spp, width=48, seed=seed, integrator="caustics", kernel="general").film
    mean = film.total / film.samples
    var = np.maximum(film.total_sq / film.samples - mean * mean, 0.0) / (film.samples - 1)
    h, w = (mean.shape[0] // block) * block, (mean.shape[1] // block) * block

    def blocks(a):
        return a[:h, :w].reshape(h // block, block, w // block, block, 3).sum(axis=(1, 3))

    ref_var = np.maximum(blocks(ref.var), blocks(ref.difference) ** 2 / 4)
    z = blocks(mean - ref.mean) / np.sqrt(blocks(var) + ref_var + 1e-30)
    total = (mean - ref.mean).sum(axis=(0, 1)) / np.sqrt(var.sum(axis=(0, 1)) + np.maximum(
        ref.var.sum(axis=(0, 1)), ref.difference.sum(axis=(0, 1)) ** 2 / 4))
    return z, total


@pytest.mark.slow
def test_caustics_converges_to_mis_on_the_caustic_scene():
    z, total = _converges_to_reference("caustic_glass", CAUSTIC, 1024, 41)
    assert np.abs(z).max() < z_limit(z.size)
    assert np.all(np.abs(total) < z_limit(3))


@pytest.mark.slow
def test_caustics_converges_to_mis_under_the_sky_with_a_glass_and_a_steel_sphere():
    z, total = _converges_to_reference("sky_spheres", ROOT / "scenes" / "sky_spheres.yaml", 256, 43)
    assert np.abs(z).max() < z_limit(z.size)
    assert np.all(np.abs(total) < z_limit(3))


@pytest.mark.slow
def test_caustics_converges_to_mis_with_the_lamp_inside_a_glass_ball():
    """Photons that only leave the glass: the radiance convention of our glass (unscaled by n^2)
    must hold for them too (a first version rendered this floor at 1 / 1.5^2 of mis's)."""
    # Blocks of 12 x 12: the floor's paths through the clay ball to the lamp stay mis's, rare at
    # 512 spp, so a small block's spread can miss them (a 6 x 6 block once reached |z| 5.8 with the
    # image mean at -0.5); the bug this guards against (the floor at 0.45 of its brightness) is far past the bound.
    z, total = _converges_to_reference("glass_lamp", ROOT / "benchmarks" / "scenes" / "glass_lamp.yaml", 512, 45, block=12)
    assert np.abs(z).max() < z_limit(z.size)
    assert np.all(np.abs(total) < z_limit(3))


@pytest.mark.slow
def test_caustics_is_the_same_on_any_thread_count_and_finite():
    one = rt.render(CAUSTIC, spp=4, width=24, seed=4, integrator="caustics", kernel="general", threads=1)
    two = rt.render(CAUSTIC, spp=4, width=24, seed=4, integrator="caustics", kernel="general", threads=2)
    assert np.array_equal(one.film.total, two.film.total) and np.array_equal(one.film.total_sq, two.film.total_sq)
    assert np.all(np.isfinite(one.film.total))


@pytest.mark.slow
def test_caustics_refuses_the_cluster_in_one_sentence():
    with pytest.raises(Exception, match="integrator caustics renders in one process"):
        rt.render(CAUSTIC, spp=2, width=8, integrator="caustics", kernel="general", cluster="local")


def test_photons_are_added_in_order_and_divided_by_their_count():
    from renderer.tracing.caustics import splat_photons

    pixel = np.array([2, -1, 2, 0, 1, 1], np.int64)
    rgb = np.arange(18, dtype=np.float64).reshape(6, 3)
    out = splat_photons(pixel, rgb, 2, 3, 4)  # 2 samples of 3 photons over 4 pixels
    assert out.shape == (2, 4, 3)
    assert np.allclose(out[0, 2], (rgb[0] + rgb[2]) / 3) and np.allclose(out[0, [0, 1, 3]], 0)
    assert np.allclose(out[1, 0], rgb[3] / 3) and np.allclose(out[1, 1], (rgb[4] + rgb[5]) / 3)


def test_the_memory_estimate_covers_a_pass_of_photons():
    from renderer.local_passes import SPLAT_BYTES
    from scenefmt.bounds import CAUSTIC_PASS_BYTES, estimate_memory
    from scenefmt.validation import loads

    # A pass's shares (n x pixels x 3 doubles) and its photons' values (n x pixels x (1 + 3) words).
    assert CAUSTIC_PASS_BYTES >= SPLAT_BYTES + SPLAT_BYTES * 32 // 24
    assert estimate_memory(loads(TARGETS).graph).guide == CAUSTIC_PASS_BYTES
    assert estimate_memory(loads(TARGETS.replace("integrator: caustics", "integrator: mis")).graph).guide == 0


@pytest.mark.slow
def test_rt_validate_and_render_with_integrator_caustics_as_a_user_types_them(tmp_path):
    """In fresh processes: validate names the effect, render writes a finite image whose mean
    matches mis's converged reference of the caustic scene."""
    import subprocess

    sys.path.insert(0, str(ROOT / "tests" / "renderer"))
    from converged import load_reference
    from renderer.film import read_pfm

    def rt_cmd(*args):
        out = subprocess.run([sys.executable, "-m", "rt", *args], cwd=tmp_path, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        return out

    listed = rt_cmd("validate", str(CAUSTIC), "--set", "image.integrator=caustics").stdout
    assert "light-traced caustics: on" in listed
    hint = rt_cmd("validate", str(CAUSTIC)).stdout
    assert "image.integrator caustics traces it from the lights" in hint
    rt_cmd("render", str(CAUSTIC), "--integrator", "caustics", "--kernel", "general", "--width", "48", "--spp", "256",
           "--seed", "8", "--hdr", "c.pfm", "-o", "c.png")
    image = read_pfm(tmp_path / "c.pfm")
    ref = load_reference("caustic_glass")
    assert image.shape == ref.mean.shape and np.all(np.isfinite(image))
    # The image's mean, against the reference's: within 5 standard errors of a 256-spp render of the
    # caustic (the image mean's standard error, measured at 16,384 spp and scaled: about 0.85% at 256 spp).
    assert image.mean() == pytest.approx(ref.mean.mean(), rel=0.045)


@pytest.mark.slow
def test_without_targets_caustics_renders_mis_image_bit_for_bit():
    box = ROOT / "scenes" / "cornell_box.yaml"
    caustics = rt.render(box, spp=2, width=16, seed=3, integrator="caustics", kernel="general").film
    mis = rt.render(box, spp=2, width=16, seed=3, integrator="mis", kernel="general").film
    assert np.array_equal(caustics.total, mis.total)
