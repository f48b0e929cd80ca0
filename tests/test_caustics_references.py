"""The caustics benchmark's second references and second set of pixels (benchmarks/caustics.py,
issue 34): where a reference made by another integrator is kept, how two references' agreement
is judged, which one a scene is measured against, and the `matte` pixels."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import caustics  # noqa: E402
from matte_pixels import camera_rays, density_materials, matte_pixels  # noqa: E402
from reference_agreement import agreement  # noqa: E402
from tests.renderer.converged import CONVERGED_DIR, Reference, reference_path, scene_file, small_graph  # noqa: E402


def noisy_reference(truth: np.ndarray, sigma: float, rng: np.random.Generator, bias: float = 0.0) -> Reference:
    """A reference as converged.py makes it: two renders of per-value noise `sigma` around `truth` (times 1 + bias)."""
    a = truth * (1.0 + bias) + sigma * rng.standard_normal(truth.shape)
    b = truth * (1.0 + bias) + sigma * rng.standard_normal(truth.shape)
    return Reference((a + b) / 2, np.full(truth.shape, sigma**2 / 2), a - b, 1)


def test_a_reference_of_another_integrator_is_kept_beside_the_scenes_own():
    assert reference_path("caustic_glass") == CONVERGED_DIR / "caustic_glass.npz"
    assert reference_path("caustic_glass", "caustics") == CONVERGED_DIR / "caustic_glass.caustics.npz"


def test_two_unbiased_references_agree_as_their_own_errors_predict_and_a_bias_shows():
    rng = np.random.default_rng(7)
    truth = rng.uniform(0.2, 1.0, (40, 50, 3))
    a, b = noisy_reference(truth, 0.05, rng), noisy_reference(truth, 0.02, rng)
    fair = agreement(a, b)
    # 6,000 values: the measured RMS is within a few percent of the predicted one.
    assert fair.rms / fair.expected_rms == pytest.approx(1.0, abs=0.05)
    expected = math.sqrt((0.05**2 + 0.02**2) / 2 * truth.size / np.sum(b.mean**2))
    assert fair.expected_rms == pytest.approx(expected, rel=0.05)
    assert abs(fair.z) < 4.0
    # 1% too bright: the image means differ by 1%, hundreds of standard errors (the noise of the
    # mean of 6,000 values of noise 0.04 is 0.0005, against a difference of 0.006).
    biased = agreement(noisy_reference(truth, 0.05, rng, bias=0.01), b)
    assert biased.relative_mean_difference == pytest.approx(0.01, abs=0.002)
    assert biased.z > 8.0


def test_the_scene_is_measured_against_the_reference_with_the_lower_own_error_on_the_kept_pixels():
    rng = np.random.default_rng(8)
    truth = rng.uniform(0.2, 1.0, (10, 10, 3))
    good_left = noisy_reference(truth, 0.01, rng)
    good_right = noisy_reference(truth, 0.01, rng)
    good_left.difference[:, 5:] *= 30.0  # noisy on the right half
    good_right.difference[:, :5] *= 30.0  # noisy on the left half
    refs = {"mis": good_left, "caustics": good_right}
    left = np.zeros((10, 10), bool)
    left[:, :5] = True
    assert caustics.best_reference(refs, left)[0] == "mis"
    name, truth_kept = caustics.best_reference(refs, ~left)
    assert name == "caustics" and truth_kept.mean.shape == (50, 3)


def test_only_lambertian_isotropic_and_plastic_rows_have_a_density():
    from renderer.materials.table import (CONDUCTOR, DIELECTRIC, DIFFUSE_LIGHT, ISOTROPIC, LAMBERTIAN, MAT_KIND, METAL,
                                          PLASTIC, PRINCIPLED)

    kinds = [LAMBERTIAN, METAL, DIELECTRIC, DIFFUSE_LIGHT, ISOTROPIC, CONDUCTOR, PLASTIC, PRINCIPLED]
    mat_i = np.zeros((len(kinds), MAT_KIND + 1), np.int64)
    mat_i[:, MAT_KIND] = kinds
    assert density_materials(mat_i).tolist() == [True, False, False, False, True, False, True, False]


def test_the_matte_masks_camera_rays_pass_through_their_own_pixel():
    from renderer.camera import CAM_DU, CAM_DV, CAM_PIXEL00, camera_row

    cam = np.asarray(camera_row(small_graph(scene_file("cornell_box"))), np.float64)
    width, height, rays = 4, 3, 5
    origins, dirs = camera_rays(cam, width, height, rays, seed=1)
    du, dv = cam[CAM_DU:CAM_DU + 3], cam[CAM_DV:CAM_DV + 3]
    # The aim point less pixel00 in pixel units: pixel (j, i) is [i - 0.5, i + 0.5) x [j - 0.5, j + 0.5).
    offset = origins + dirs - cam[CAM_PIXEL00:CAM_PIXEL00 + 3]
    coords = np.linalg.lstsq(np.stack([du, dv], axis=1), offset.T, rcond=None)[0].T
    j, i = np.divmod(np.arange(width * height).repeat(rays), width)
    assert np.all(np.abs(coords[:, 0] - i) <= 0.5) and np.all(np.abs(coords[:, 1] - j) <= 0.5)


@pytest.mark.slow
def test_matte_pixels_leave_out_the_sky_and_the_spheres_of_glass_and_steel():
    # sky_spheres at 48 x 27: the sky fills the top rows, the ground the bottom ones; the matte
    # pixels are the ground and the clay sphere, none of the steel or glass sphere's.
    graph = small_graph(scene_file("sky_spheres"))
    matte = matte_pixels(graph)
    assert matte.shape == (27, 48)
    assert not matte[:3].any() and matte[-4:].all()
    assert 0.4 < matte.mean() < 0.7
    # Rows 10 to 15 cross the three spheres: the steel one in the middle is left out, the
    # clay one on the left kept.
    assert not matte[10:16, 24].any() and matte[10:16, 5].all()


def test_the_table_names_each_scenes_reference_and_its_ratio_is_over_caustics():
    keep = np.ones((2, 2), bool)
    truth = Reference(np.ones((4, 3)), np.zeros((4, 3)), np.full((4, 3), 0.1), 1)
    rows = [caustics.Measurement("s", "mis", 1.0, 2.0, 2.0, 0.0, 10, 0.2, keep),
            caustics.Measurement("s", "caustics", 1.0, 2.0, 2.0, 0.0, 5, 0.05, keep)]
    text = caustics.table([(rows, truth)], 0.02, "caustics", ["caustics"])
    mis_row = next(line for line in text.splitlines() if "| mis |" in line)
    # One render's own error: sqrt(12 x 0.01 / 2 / 12) = 0.0707.
    assert mis_row.startswith("| s (100%, caustics 0.0707) |")
    assert mis_row.split("|")[-2].strip() == "16.00"  # (0.2 / 0.05)^2
