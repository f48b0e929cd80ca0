"""Image backgrounds (environment maps): resolved relative to the scene, bounded and checked as
image textures are, their values checked as radiances; and the sampling tables built from them."""

import numpy as np
import pytest

from renderer.environment import ENV_ROW_CDF, ENV_TEXEL_CDF, ENV_TEXEL_DENSITY, tables
from renderer.film import write_exr, write_pfm
from scenefmt.bounds import ENVIRONMENT_EXTRA_BYTES_PER_PIXEL, HDR_TEXTURE_BYTES_PER_PIXEL, TEXTURE_BYTES_PER_PIXEL
from scenefmt.diagnostics import SceneError
from scenefmt.effects import summarize
from scenefmt.validation import loads

IMAGE = np.array([[[0.0, 0.5, 1.0], [2.0, 1e-3, 0.25]], [[3.5, 0.0, 0.125], [0.75, 0.5, 0.0]]])


def scene_with(background: str) -> str:
    return f"background: {background}\nshapes: [{{type: sphere, center: [0, 0, 0], radius: 1, material: {{type: lambertian}}}}]\n"


def errors(text, tmp_path) -> list[str]:
    with pytest.raises(SceneError) as info:
        loads(text, base_dir=tmp_path)
    return [f"{d.line}:{d.column} {d.message}" for d in info.value.diagnostics]


@pytest.mark.parametrize("suffix, write", [(".exr", write_exr), (".pfm", write_pfm)])
def test_a_float_map_is_found_beside_the_scene_and_counted_in_memory(tmp_path, suffix, write):
    write(tmp_path / f"sky{suffix}", IMAGE)
    graph = loads(scene_with(f"{{type: image, file: sky{suffix}, rotate: 45, strength: 2}}"), base_dir=tmp_path).graph
    assert graph.environment_path == tmp_path / f"sky{suffix}"
    assert graph.background.rotate == 45 and graph.background.strength == 2
    assert graph.memory.textures == 4 * (HDR_TEXTURE_BYTES_PER_PIXEL + ENVIRONMENT_EXTRA_BYTES_PER_PIXEL)
    summary = summarize(graph)
    assert summary.background == "image"
    assert summary.effect("environment").on and not summary.effect("sky").on


def test_a_png_map_is_accepted(tmp_path):
    from PIL import Image

    Image.fromarray(np.zeros((4, 8, 3), np.uint8)).save(tmp_path / "sky.png")
    graph = loads(scene_with("{type: image, file: sky.png}"), base_dir=tmp_path).graph
    assert graph.environment_path == tmp_path / "sky.png"
    # Read as an 8-bit image texture is, plus the environment's own tables.
    assert graph.memory.textures == 32 * (TEXTURE_BYTES_PER_PIXEL + ENVIRONMENT_EXTRA_BYTES_PER_PIXEL)
    assert graph.memory.parts["textures"] == ("background", "file")


def test_unusable_maps_are_scene_errors_at_the_file(tmp_path):
    bad = IMAGE.copy()
    bad[0, 0, 0] = -0.5
    write_pfm(tmp_path / "neg.pfm", bad)
    (tmp_path / "junk.png").write_bytes(b"not an image")
    write_pfm(tmp_path / "sky.pfm", IMAGE)
    assert errors(scene_with("{type: image, file: missing.pfm}"), tmp_path)[0].startswith("1:33 image file 'missing.pfm' not found")
    assert errors(scene_with("{type: image, file: neg.pfm}"), tmp_path) == [
        "1:33 image file 'neg.pfm' holds negative values (the least is -0.5); colours must be >= 0"]
    assert errors(scene_with("{type: image, file: junk.png}"), tmp_path)[0].startswith("1:33 image file 'junk.png' is not a readable image")
    assert errors(scene_with("{type: image, file: sky.pfm, strength: 1e12}"), tmp_path) == [
        "1:52 a background radiance must be at most 1e+12 per channel, found 3.5e+12 "
        "(the image's brightest value 3.5 times strength 1e+12)"]
    assert errors(scene_with("{type: image, file: sky.pfm, strength: -1}"), tmp_path)[0].startswith("1:52 ")
    assert errors(scene_with("{type: image}"), tmp_path)[0].startswith("1:13 ")
    assert "did you mean 'image'" in errors(scene_with("{type: imag, file: sky.pfm}"), tmp_path)[0]


def test_the_tables_are_a_density_over_the_map():
    """Rows by luminance x sin(theta), texels within a row by luminance; p(u, v) integrates to 1;
    black rows and texels are never chosen."""
    rng = np.random.default_rng(3)
    rgb = rng.random((6, 10, 3))
    rgb[2] = 0.0
    rgb[4, :3] = 0.0
    rows, texels, power = tables(rgb)
    h, w = 6, 10
    lum = 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]
    f = lum * np.sin(np.pi * (np.arange(h) + 0.5) / h)[:, None]
    row_pmf = np.diff(rows[:, ENV_ROW_CDF], prepend=0.0)  # a row's probability: its step of the cdf
    np.testing.assert_allclose(row_pmf, f.sum(axis=1) / f.sum())
    assert row_pmf[2] == 0.0 and rows[-1, ENV_ROW_CDF] == 1.0
    density = texels[:, ENV_TEXEL_DENSITY].reshape(h, w)
    assert density.mean() == pytest.approx(1.0)  # each texel covers 1 / (w h) of the unit square
    np.testing.assert_allclose(density, f / f.mean())
    cdf = texels[:, ENV_TEXEL_CDF].reshape(h, w)
    assert np.all(np.diff(cdf, axis=1) >= 0) and np.all(cdf[:, -1] == 1.0)
    assert np.all(cdf[4, :3] == 0.0) and cdf[4, 3] > 0.0
    # The radiance integrated over the sphere: sum of L dOmega, dOmega = 2 pi^2 sin(theta) / (w h).
    assert power == pytest.approx(f.sum() * 2 * np.pi ** 2 / (w * h))
    assert tables(np.zeros((2, 4, 3)))[2] == 0.0
