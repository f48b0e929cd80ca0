"""The Mitsuba side-by-side harness (benchmarks/mitsuba_materials.py, mitsuba_scene.py) and the glossy
light-sampling benchmark: their scenes stay valid as the format moves, the conversion says what it
cannot convert, and the within-noise verdict both passes equal renders and fails different ones."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import glossy_light_sampling  # noqa: E402
import mitsuba_materials  # noqa: E402
import mitsuba_scene  # noqa: E402


@pytest.mark.parametrize("name", list(mitsuba_materials.CASES))
def test_every_comparison_case_loads_in_mitsubas_conventions(name):
    graph = mitsuba_materials.load_case(name, 16)
    lamp = graph.root.members[2].model
    assert lamp.q[1] == pytest.approx(554.999)  # flush with the ceiling: our two-sided lamp lights as Mitsuba's
    for member in graph.root.members:
        model = member.material.model
        if getattr(model, "alpha", None):
            assert model.shadowing == "separable", name  # Mitsuba's Smith term


def test_the_glossy_benchmark_scene_loads_with_a_small_bright_lamp():
    graph = glossy_light_sampling.load_graph("{type: lambertian, albedo: [0.5, 0.5, 0.5]}", 16, "path")
    assert graph.image.integrator == "path"
    lamp = graph.root.members[2]
    assert lamp.material.model.type == "diffuse_light"
    area = abs(np.cross(lamp.model.u, lamp.model.v)[1])
    # The same power as the shipped lamp: radiance times area.
    assert lamp.material.model.emit[0] * area == pytest.approx(15 * 130 * 105)


def noisy(truth, sd, seed):
    rng = np.random.default_rng(seed)
    return truth + rng.normal(0.0, sd, truth.shape), np.full(truth.shape, sd * sd)


def test_compare_passes_two_renders_of_one_image_and_fails_a_shifted_one():
    truth = np.random.default_rng(1).uniform(0.1, 1.0, (64, 64, 3))
    a, b = noisy(truth, 0.02, 2), noisy(truth, 0.02, 3)
    same = mitsuba_materials.compare(a, b, block=8)
    assert same["ok"] and np.all(np.abs(same["z_image"]) < same["limit_image"])
    assert same["blocks"] == 8 * 8 * 3
    shifted = mitsuba_materials.compare(a, (b[0] * 1.01, b[1]), block=8)  # 1% brighter: far outside the noise
    assert not shifted["ok"] and np.all(shifted["z_image"] < -shifted["limit_image"])
    # A difference confined to one block is found by the blocks, not by the image mean.
    local = b[0].copy()
    local[:8, :8] += 0.05
    one_block = mitsuba_materials.compare(a, (local, b[1]), block=8)
    assert not one_block["ok"] and np.all(np.abs(one_block["z_image"]) < one_block["limit_image"])
    assert one_block["worst_block"][:2] == (0, 0)


def test_block_means_average_pixels_and_their_variances():
    image = np.arange(4 * 4 * 3, dtype=float).reshape(4, 4, 3)
    var = np.ones((4, 4, 3))
    means, variances = mitsuba_materials.block_means(image, var, 2)
    assert means.shape == (2, 2, 3)
    assert means[0, 0, 0] == pytest.approx(np.mean(image[:2, :2, 0]))
    assert np.allclose(variances, 4 / 16)  # four unit variances, mean of four: 1/4


def test_the_conversion_maps_widths_and_refuses_what_mitsuba_renders_otherwise():
    from scenefmt.materials import Conductor, DiffuseLight, Isotropic, Lambertian, Plastic, RoughDielectric, ThinDielectric

    assert mitsuba_scene._alpha(Conductor(alpha=0.3)) == (0.3, 0.3)
    assert mitsuba_scene._alpha(Conductor(roughness=0.5, roughness_v=0.2)) == pytest.approx((0.25, 0.04))
    with pytest.raises(ValueError, match="separable"):
        mitsuba_scene.bsdf(Conductor(alpha=0.1))  # the format's default: height-correlated
    _, gold = mitsuba_scene.bsdf(Conductor(metal="gold", alpha=0.1, shadowing="separable"))
    assert gold["bsdf"]["type"] == "roughconductor" and gold["bsdf"]["alpha_u"] == 0.1
    assert gold["bsdf"]["eta"]["value"] == pytest.approx(Conductor(metal="gold").index()[0])
    _, glass = mitsuba_scene.bsdf(RoughDielectric(ior=1.5, alpha=0.2, shadowing="separable"))
    assert glass["type"] == "roughdielectric" and glass["int_ior"] == 1.5  # two-sided in Mitsuba already
    _, coat = mitsuba_scene.bsdf(Plastic(albedo=(0.1, 0.2, 0.3)))
    assert coat["bsdf"]["type"] == "plastic"  # smooth by default in both
    with pytest.raises(ValueError, match="constant"):
        mitsuba_scene.bsdf(Lambertian(albedo="checker"))  # a texture by name
    _, sheet = mitsuba_scene.bsdf(ThinDielectric(ior=1.33, tint=(1, 0.5, 0.5)))
    assert sheet["type"] == "thindielectric" and sheet["specular_transmittance"]["value"] == [1, 0.5, 0.5]
    with pytest.raises(ValueError, match="no equal"):
        mitsuba_scene.bsdf(Isotropic())
    kind, lamp = mitsuba_scene.bsdf(DiffuseLight(emit=(15, 15, 15)))
    assert kind == "emitter" and lamp["radiance"]["value"] == [15.0, 15.0, 15.0]
    kind, white = mitsuba_scene.bsdf(Lambertian(albedo=(0.73, 0.73, 0.73)))
    assert white["type"] == "twosided" and white["bsdf"]["type"] == "diffuse"


def test_passes_estimate_the_variance_of_each_pixels_mean():
    passes = mitsuba_scene.Passes(spp=4)
    for value in (1.0, 3.0):
        passes.add(np.full((2, 2, 4), value))  # an RGBA image: alpha is dropped
    assert passes.samples == 8
    assert np.allclose(passes.mean(), 2.0)
    assert np.allclose(passes.mean_variance(), 1.0)  # unbiased variance 2 of two passes, over 2
