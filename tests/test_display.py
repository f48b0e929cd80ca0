"""Display transforms (renderer/display.py): the books' gamma 2 kept bit for bit, the sRGB curve at
its known values, the filmic curves bounded, monotonic and total, and the PNG naming its transform."""

from __future__ import annotations

import io
import math
import subprocess
import sys
import typing
from pathlib import Path

import numpy as np
import pytest
from PIL import Image as PILImage

from renderer import display
from renderer.film import Film, png_bytes, read_pfm, to_srgb8, write_image

ROOT = Path(__file__).resolve().parents[1]


def books_gamma2(linear):
    """The books' output, written out again: sqrt, clamp to [0, 0.999], x256, truncate."""
    return (256.0 * np.clip(np.sqrt(np.clip(linear, 0.0, None)), 0.0, 0.999)).astype(np.uint8)


def srgb_by_the_standard(x: float) -> int:
    """IEC 61966-2-1's encoding of one clamped value, rounded to the nearest code, by plain math."""
    x = min(max(x, 0.0), 1.0)
    v = 12.92 * x if x <= 0.0031308 else 1.055 * math.pow(x, 1 / 2.4) - 0.055
    return int(math.floor(255 * v + 0.5))


def decoded(data: bytes):
    image = PILImage.open(io.BytesIO(data))
    return np.asarray(image.convert("RGB")), dict(image.text)


# --- gamma2: the books' PNG, bit for bit


def test_gamma2_is_the_books_output_bit_for_bit_on_random_radiance():
    rng = np.random.default_rng(35)
    # Dark, mid and very bright values, negatives, exact zeros and the clamp's edge (0.999^2).
    linear = np.concatenate([
        rng.exponential(0.3, (64, 64, 3)), rng.uniform(-1, 4, (64, 64, 3)), np.full((1, 64, 3), 0.999**2),
        np.zeros((1, 64, 3)), 10.0 ** rng.uniform(-8, 8, (32, 64, 3)),
    ])
    expected = books_gamma2(linear)
    assert np.array_equal(display.gamma2(linear), expected)
    assert np.array_equal(display.to_display8(linear, "gamma2"), expected)
    assert np.array_equal(to_srgb8(linear), expected)  # the film's own name for it
    assert display.DEFAULT_DISPLAY == "gamma2"


def test_gamma2_png_pixels_are_to_srgb8_and_the_default():
    linear = np.random.default_rng(1).exponential(0.4, (9, 7, 3))
    pixels, text = decoded(png_bytes(linear))
    assert np.array_equal(pixels, to_srgb8(linear))
    assert text["rt:display"] == "gamma2"


# --- srgb: the standard's curve


@pytest.mark.parametrize("linear, code", [(0.0, 0), (0.0031308, 10), (0.18, 118), (0.5, 188), (1.0, 255), (2.0, 255),
                                          (-1.0, 0), (0.001, 3), (0.05, 63)])
def test_srgb_at_known_values(linear, code):
    assert display.srgb(np.full((1, 1, 3), linear))[0, 0].tolist() == [code] * 3
    assert srgb_by_the_standard(linear) == code


def test_srgb_pieces_meet_at_the_knee_and_match_the_standard_everywhere():
    knee = display.SRGB_KNEE
    below, above = display.srgb_encode(np.array([knee])), display.srgb_encode(np.array([np.nextafter(knee, 1.0)]))
    assert abs(float(below[0]) - 12.92 * knee) < 1e-15
    assert abs(float(above[0]) - float(below[0])) < 1e-6  # continuous: the standard's constants agree to 1e-7
    values = np.random.default_rng(2).uniform(-0.1, 1.2, 4000)
    codes = display.srgb(values.reshape(-1, 1, 1).repeat(3, axis=2))[:, 0, 0]
    assert codes.tolist() == [srgb_by_the_standard(float(v)) for v in values]


# --- the filmic curves


FILMIC = ("agx", "aces")
ALL = display.DISPLAYS


@pytest.mark.parametrize("name", ALL)
def test_every_transform_is_total_bounded_and_black_for_nothing(name):
    nasty = np.array([[[np.nan, np.inf, -np.inf], [-5.0, 0.0, 1e300], [np.inf] * 3, [np.nan] * 3, [0.0] * 3]])
    with np.errstate(all="raise"):  # no invalid operation, no overflow on the way
        out = display.to_display8(nasty, name)
    assert out.dtype == np.uint8 and out.shape == nasty.shape
    assert out[0, 3].tolist() == [0, 0, 0] and out[0, 4].tolist() == [0, 0, 0]  # NaN and zero are black
    assert out[0, 2].tolist() == display.to_display8(np.full((1, 1, 3), 1e30), name)[0, 0].tolist()  # inf: the top


@pytest.mark.parametrize("name", FILMIC)
def test_filmic_curves_rise_along_grey_and_along_each_primary(name):
    grey = np.geomspace(1e-6, 1e6, 2001)
    encode = getattr(display, f"{name}_encode")
    values = encode(np.repeat(grey[:, None], 3, axis=1))
    assert np.all(np.isfinite(values)) and values.min() >= 0 and values.max() <= 1
    assert np.all(np.diff(values[:, 0]) >= -1e-12)  # never darker for more light
    assert values[-1, 0] - values[0, 0] > 0.95  # from black to (nearly) white
    # Along a primary the luminance of what is shown rises too.
    luma = np.array([0.2126, 0.7152, 0.0722])
    for channel in range(3):
        ramp = np.zeros((grey.size, 3))
        ramp[:, channel] = grey
        shown = encode(ramp) @ luma
        assert np.all(np.diff(shown) >= -1e-9), channel


def test_filmic_mid_grey_and_highlights_as_their_sources_state():
    mid = np.full((1, 1, 3), 0.18)
    # AgX puts mid grey near the middle of the display range; ACES (RRT + sRGB ODT) shows it near 10% of white.
    assert 0.45 < float(display.agx_encode(mid)[0, 0, 0]) < 0.55
    aces_light = float((display.aces_tone(mid @ display.ACES_IN.T) @ display.ACES_OUT.T)[0, 0, 0])
    assert 0.09 < aces_light < 0.12
    assert display.aces(mid)[0, 0].tolist() == [91] * 3 and display.agx(mid)[0, 0].tolist() == [128] * 3
    # AgX's inset: a saturated red grows toward white as it brightens instead of staying pure red.
    dim, bright = display.agx(np.array([[[1.0, 0, 0], [1000.0, 0, 0]]]))[0]
    assert dim[1] < 100 and bright[1] > 200 and bright[0] == 255
    # gamma2 and srgb clip that red at once; the filmic curves keep detail above 1 (4 and 8 differ).
    for name in FILMIC:
        four, eight = display.to_display8(np.array([[[4.0] * 3, [8.0] * 3]]), name)[0]
        assert four[0] < eight[0] < 255


def test_agx_matrices_are_inverse_and_keep_grey():
    assert np.allclose(display.AGX_OUTSET @ display.AGX_INSET, np.eye(3), atol=1e-9)
    assert np.allclose(display.AGX_INSET.sum(axis=1), 1.0, atol=2e-4)
    assert np.allclose(display.ACES_IN.sum(axis=1), 1.0, atol=1e-4)
    assert np.allclose(display.ACES_OUT.sum(axis=1), 1.0, atol=1e-4)


# --- names, errors and the format


def test_the_scene_format_and_the_renderer_know_the_same_names():
    from scenefmt.scene import DisplayName, Image

    assert typing.get_args(DisplayName) == display.DISPLAYS == tuple(display.TRANSFORMS) == tuple(display.DESCRIPTIONS)
    assert Image().display == display.DEFAULT_DISPLAY


def test_an_unknown_name_is_one_sentence_with_the_nearest_one():
    with pytest.raises(ValueError) as error:
        display.to_display8(np.zeros((1, 1, 3)), "sgrb")
    assert str(error.value) == "unknown display transform 'sgrb': expected gamma2, srgb, agx or aces; did you mean 'srgb'?"
    assert "did you mean" not in display.unknown_display("filmic")
    assert "\x1b" not in display.unknown_display("\x1b[2J")  # a name from a user is never echoed raw


def test_a_scene_file_with_an_unknown_display_says_where_and_the_nearest_name(tmp_path):
    import rt

    scene = tmp_path / "s.yaml"
    scene.write_text("version: 1\nimage: {width: 8, display: agc}\nshapes: []\n")
    result = rt.validate(scene)
    assert not result.ok and len(result.errors) == 1
    message = str(result.errors[0])
    assert message.endswith("s.yaml:2:28: error: image.display: expected 'gamma2', 'srgb', 'agx' or 'aces', found 'agc'; "
                            "did you mean 'agx'?")
    scene.write_text("version: 1\nimage: {width: 8, display: aces}\nshapes: []\n")
    assert rt.validate(scene).ok and rt.load(scene).scene.image.display == "aces"


# --- the PNG says which transform made it


@pytest.mark.parametrize("name", ALL)
def test_the_png_metadata_names_the_transform_and_the_pixels_are_its_own(name):
    linear = np.random.default_rng(3).exponential(0.5, (6, 5, 3))
    pixels, text = decoded(png_bytes(linear, name, {"rt:exposure": "1"}))
    assert text["rt:display"] == name
    assert text["Software"].startswith("rt")
    assert text["rt:exposure"] == "1"
    assert name in text["Comment"]
    assert np.array_equal(pixels, display.to_display8(linear, name))


def test_linear_files_ignore_the_transform_and_maps_say_what_they_record(tmp_path):
    linear = np.random.default_rng(4).exponential(0.5, (4, 3, 3))
    write_image(tmp_path / "a.pfm", linear, "agx")
    assert np.allclose(read_pfm(tmp_path / "a.pfm"), linear, rtol=1e-6)  # linear, as rendered

    from renderer.film import NOISE_MAP_CONTENT, PNG_CONTENT_KEY
    from rt.outputs import write_outputs
    from rt.render_job import RenderOptions

    film = Film(linear * 4, linear * linear * 8 + 0.01, 4)
    opts = RenderOptions(scene=Path("s.yaml"), output=tmp_path / "a.png", noise_map=tmp_path / "n.png",
                         samples_map=tmp_path / "c.png", hdr=tmp_path / "h.pfm", exposure=1.0)
    write_outputs(opts, film, None, RuntimeError, display="aces")
    pixels, text = decoded((tmp_path / "a.png").read_bytes())
    assert text["rt:display"] == "aces" and text["rt:exposure"] == "1"
    assert np.array_equal(pixels, display.aces(film.mean() * 2.0))  # exposure first, then the transform
    assert np.array_equal(read_pfm(tmp_path / "h.pfm"), film.mean().astype(np.float32))  # --hdr untouched
    _, noise_text = decoded((tmp_path / "n.png").read_bytes())
    assert noise_text["rt:display"] == "gamma2" and noise_text[PNG_CONTENT_KEY] == NOISE_MAP_CONTENT
    _, count_text = decoded((tmp_path / "c.png").read_bytes())
    assert count_text["rt:display"] == "gamma2" and count_text[PNG_CONTENT_KEY].startswith("samples map")


def test_the_api_image_saves_with_its_display_or_another(tmp_path):
    import rt

    linear = np.random.default_rng(5).exponential(0.5, (4, 3, 3))
    image = rt.Image(Film(linear * 2, linear * linear * 2, 2), None, display="srgb")
    pixels, text = decoded(image.png_bytes())
    assert text["rt:display"] == "srgb" and np.array_equal(pixels, display.srgb(linear))
    assert text["rt:display"] == decoded(image._repr_png_())[1]["rt:display"]
    image.save(tmp_path / "x.png", display="agx")
    pixels, text = decoded((tmp_path / "x.png").read_bytes())
    assert text["rt:display"] == "agx" and np.array_equal(pixels, display.agx(linear))
    with pytest.raises(ValueError, match="display applies to a PNG only"):
        image.save(tmp_path / "x.pfm", display="agx")
    with pytest.raises(ValueError, match="did you mean 'aces'"):
        image.png_bytes(display="acs")


# --- what the user runs


def run_rt(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, capture_output=True, text=True)


SMALL = """version: 1
camera: {look_from: [0, 1, 3], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 12, height: 8, samples_per_pixel: 4, max_depth: 4, seed: 3}
background: [0.6, 0.7, 1.0]
materials: {m: {type: lambertian, albedo: [0.7, 0.3, 0.2]}, l: {type: diffuse_light, emit: [8, 8, 8]}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: l}
"""


@pytest.mark.slow
def test_rt_render_display_srgb_writes_the_transform_of_the_hdr_image(tmp_path):
    (tmp_path / "s.yaml").write_text(SMALL)
    done = run_rt("render", "s.yaml", "--display", "srgb", "--exposure", "0.5", "--kernel", "general", "-o", "s.png",
                  "--hdr", "s.pfm", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    pixels, text = decoded((tmp_path / "s.png").read_bytes())
    assert text["rt:display"] == "srgb" and text["rt:exposure"] == "0.5"
    hdr = read_pfm(tmp_path / "s.pfm")  # float32: a code may round the other way at a boundary
    assert hdr.max() > 1.5  # the lamp: values the transform must clamp
    expected = display.srgb(hdr * 2.0**0.5)
    difference = np.abs(pixels.astype(int) - expected.astype(int))
    assert difference.max() <= 1 and (difference == 0).mean() > 0.98


@pytest.mark.slow
def test_rt_render_refuses_an_unknown_display_in_one_sentence(tmp_path):
    (tmp_path / "s.yaml").write_text(SMALL)
    done = run_rt("render", "s.yaml", "--display", "agz", cwd=tmp_path)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        "error: --display: unknown display transform 'agz': expected gamma2, srgb, agx or aces; did you mean 'agx'?"]
    assert not (tmp_path / "s.png").exists()
    (tmp_path / "t.yaml").write_text(SMALL.replace("seed: 3}", "seed: 3, display: srgbb}"))
    done = run_rt("render", "t.yaml", cwd=tmp_path)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "image.display: expected 'gamma2', 'srgb', 'agx' or 'aces', found 'srgbb'; did you mean 'srgb'?" in done.stderr


@pytest.mark.slow
def test_rt_render_takes_the_scene_display_and_the_api_overrides_it(tmp_path):
    import rt

    data = {"version": 1, "image": {"width": 8, "height": 6, "samples_per_pixel": 2, "seed": 1, "display": "agx"},
            "background": [2.0, 1.0, 0.5], "shapes": []}
    image = rt.render(data, kernel="general")
    assert image.display == "agx"
    pixels, text = decoded(image.png_bytes())
    assert text["rt:display"] == "agx" and np.array_equal(pixels, display.agx(image.film.mean()))
    assert rt.render(data, kernel="general", display="gamma2").display == "gamma2"
    with pytest.raises(ValueError, match="did you mean 'aces'"):
        rt.render(data, kernel="general", display="ace")


def test_a_saved_state_resumes_under_another_display(tmp_path):
    import rt
    from renderer.state import scene_fingerprint
    from rt.render_job import samples_fingerprint
    from scenefmt.writing import dumps

    base = {"version": 1, "image": {"width": 8, "aspect_ratio": "16:9", "seed": 2}, "background": [1, 1, 1], "shapes": []}
    plain = rt.load(base).scene
    assert samples_fingerprint(plain) == scene_fingerprint(dumps(plain, "json"))  # older states still resume
    shown = rt.load({**base, "image": {**base["image"], "display": "agx"}}).scene
    assert samples_fingerprint(shown) == samples_fingerprint(plain)
    assert shown.image.display == "agx"  # the scene itself is not changed
    wider = rt.load({**base, "image": {**base["image"], "width": 9, "display": "agx"}}).scene
    assert samples_fingerprint(wider) != samples_fingerprint(plain)


def test_rt_validate_names_a_display_other_than_the_books():
    from typer.testing import CliRunner

    from rt.cli import app

    scene = "version: 1\nimage: {width: 8, display: srgb}\nshapes: []\n"
    done = CliRunner().invoke(app, ["validate", "-"], input=scene)
    assert done.exit_code == 0
    assert "seed 0, integrator mis, display srgb; background sky" in done.output
    done = CliRunner().invoke(app, ["validate", "-"], input=scene.replace(", display: srgb", ""))
    assert "integrator mis; background sky" in done.output


@pytest.mark.slow
def test_rt_render_denoise_makes_the_denoised_png_with_the_same_display(tmp_path):
    pytest.importorskip("pyoidn")
    (tmp_path / "s.yaml").write_text(SMALL)
    done = run_rt("render", "s.yaml", "--display", "agx", "--denoise", "--kernel", "general", "-o", "s.png", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    raw, raw_text = decoded((tmp_path / "s.png").read_bytes())
    denoised, text = decoded((tmp_path / "s.denoised.png").read_bytes())
    assert raw_text["rt:display"] == text["rt:display"] == "agx"
    assert denoised.shape == raw.shape and denoised.max() > 0
