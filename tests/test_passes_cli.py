"""Render passes from the front ends: `rt render --passes` (a fresh process), `rt.render(passes=...)`,
and the pieces between (rt/passes.py, the EXR layers and grey PFM writers)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from renderer.film import read_pfm, write_exr_layers, write_pfm
from rt.passes import CHANNELS, PASS_NAMES, compute_passes, exr_layers, layout_of, parse_passes, pass_files

ALBEDO = (0.3, 0.5, 0.7)
# A lambertian plane filling the view, facing the camera 5 away: its albedo, normal (0, 0, 1)
# and depth 5 at every pixel, whatever the samples.
PLANE = {
    "camera": {"look_from": [0, 0, 5], "look_at": [0, 0, 0], "vfov": 30},
    "image": {"width": 12, "aspect_ratio": 1.0, "samples_per_pixel": 4, "seed": 3},
    "background": [0.2, 0.2, 0.2],
    "shapes": [
        {"type": "quad", "q": [-50, -50, 0], "u": [100, 0, 0], "v": [0, 100, 0],
         "material": {"type": "lambertian", "albedo": list(ALBEDO)}},
        {"type": "sphere", "center": [0, 0, 9], "radius": 1, "material": {"type": "diffuse_light", "emit": [4, 4, 4]}},
    ],
}


def rt(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, capture_output=True, text=True, timeout=900)


def exr_channels(path) -> dict:
    import OpenEXR

    return {name: channel.pixels for name, channel in OpenEXR.File(str(path), separate_channels=True).channels().items()}


# --- the names, the layout and the files ---------------------------------------------------------

def test_passes_are_listed_once_each_in_a_fixed_order():
    assert parse_passes("depth,albedo, depth") == ("albedo", "depth")
    assert parse_passes(["error", "samples"]) == ("samples", "error")
    assert parse_passes(PASS_NAMES) == PASS_NAMES


@pytest.mark.parametrize("text, said", [("albdo", "unknown pass 'albdo' (the passes are albedo, normal, depth, samples "
                                                  "and error); did you mean 'albedo'?"),
                                        ("normals", "did you mean 'normal'?"),
                                        ("albedo,,depth", "an empty pass name"),
                                        ("zz", "unknown pass 'zz' (the passes are albedo, normal, depth, samples and error)")])
def test_an_unknown_pass_is_one_sentence_with_a_guess(text, said):
    with pytest.raises(ValueError) as caught:
        parse_passes(text)
    assert said in str(caught.value) and "\n" not in str(caught.value)


def test_the_layout_is_layers_with_an_exr_and_files_otherwise():
    assert layout_of(None, Path("x.exr")) == "layers"
    assert layout_of(None, Path("x.PFM")) == "files"
    assert layout_of(None, None) == "files"
    assert layout_of("files", Path("x.exr")) == "files"
    with pytest.raises(ValueError, match="give --hdr NAME.exr"):
        layout_of("layers", Path("x.pfm"))
    with pytest.raises(ValueError, match="did you mean 'layers'"):
        layout_of("layer", Path("x.exr"))


def test_pass_files_lie_beside_the_image_named_after_it():
    assert pass_files(Path("out/img.png"), ("albedo", "depth"), None) == [
        ("albedo", Path("out/img.albedo.pfm")), ("depth", Path("out/img.depth.pfm"))]
    assert pass_files(Path("img.png"), ("normal",), Path("elsewhere/hdr.exr")) == [("normal", Path("img.normal.exr"))]


def test_each_pass_has_its_exr_channels():
    passes = {"albedo": np.zeros((2, 3, 3), np.float32), "normal": np.ones((2, 3, 3), np.float32),
              "depth": np.full((2, 3), 5.0, np.float32)}
    layers = exr_layers(passes)
    assert sorted(layers) == ["albedo.B", "albedo.G", "albedo.R", "depth.Z", "normal.X", "normal.Y", "normal.Z"]
    assert all(layers[name].shape == (2, 3) for name in layers)
    assert set(CHANNELS) == set(PASS_NAMES)


def test_a_grey_pfm_reads_back(tmp_path):
    depth = np.arange(12, dtype=np.float32).reshape(3, 4)
    write_pfm(tmp_path / "d.pfm", depth)
    assert (tmp_path / "d.pfm").read_bytes().startswith(b"Pf\n4 3\n")
    assert np.array_equal(read_pfm(tmp_path / "d.pfm"), depth)


def test_a_multi_layer_exr_reads_back_with_its_channel_names(tmp_path):
    rng = np.random.default_rng(1)
    image = rng.random((3, 4, 3)).astype(np.float32)
    layers = {"albedo.R": rng.random((3, 4)).astype(np.float32), "depth.Z": np.full((3, 4), 7.5, np.float32)}
    write_exr_layers(tmp_path / "x.exr", image, layers)
    channels = exr_channels(tmp_path / "x.exr")
    assert sorted(channels) == ["B", "G", "R", "albedo.R", "depth.Z"]
    assert np.array_equal(np.stack([channels[c] for c in "RGB"], axis=-1), image)
    assert np.array_equal(channels["albedo.R"], layers["albedo.R"]) and (channels["depth.Z"] == 7.5).all()
    # Our own image textures still read the image from R, G and B.
    from scenefmt.hdr_files import read_hdr

    assert np.allclose(read_hdr(tmp_path / "x.exr", 1000), image)


def test_the_film_passes_need_no_kernel():
    from renderer.film import Film

    film = Film(np.ones((2, 3, 3)), np.ones((2, 3, 3)), 1)
    out = compute_passes(["samples", "error"], None, film)
    assert out["samples"].dtype == np.float32 and (out["samples"] == 1.0).all()
    # One sample a pixel: no error estimate, the largest float32 and never inf.
    assert np.isfinite(out["error"]).all() and (out["error"] == np.finfo(np.float32).max).all()


# --- the command line: refused before rendering --------------------------------------------------

def test_the_command_refuses_an_unknown_pass_in_one_line_before_rendering(tmp_path):
    scene = tmp_path / "plane.json"
    scene.write_text(json.dumps(PLANE))
    out = rt("render", str(scene), "-o", "img.png", "--passes", "albedo,albdo", cwd=tmp_path)
    assert out.returncode == 1
    assert out.stderr == ("error: --passes: unknown pass 'albdo' (the passes are albedo, normal, depth, samples and "
                          "error); did you mean 'albedo'?\n")
    assert not (tmp_path / "img.png").exists()


def refusal(tmp_path, capsys, scene_name="plane.json", **options) -> str:
    """What `rt render`'s checks say of these options, which must refuse them before rendering."""
    from rt.render_job import RenderOptions, Stop, prepare

    scene = tmp_path / scene_name
    scene.write_text(json.dumps(PLANE))
    with pytest.raises(Stop):
        prepare(RenderOptions(scene=scene, output=tmp_path / "img.png", syntax="json", **options))
    return capsys.readouterr().err


def test_layers_need_an_exr_and_a_layout_needs_passes(tmp_path, capsys):
    said = refusal(tmp_path, capsys, passes=("albedo",), passes_as="layers", hdr=tmp_path / "x.pfm")
    assert said.startswith("error: --passes: --passes-as layers writes the passes into the --hdr OpenEXR image")
    said = refusal(tmp_path, capsys, passes_as="files")
    assert said.startswith("error: --passes-as says how the passes are written: name them with --passes too")


def test_a_pass_file_that_cannot_be_written_is_refused_before_rendering(tmp_path, capsys):
    (tmp_path / "img.depth.pfm").mkdir()
    said = refusal(tmp_path, capsys, passes=("depth",))
    assert said.startswith(f"error: {tmp_path / 'img.depth.pfm'}: it is a")
    assert not (tmp_path / "img.png").exists()


def test_a_pass_file_may_not_replace_the_scene(tmp_path, capsys):
    said = refusal(tmp_path, capsys, scene_name="img.albedo.pfm", passes=("albedo",))
    assert "the scene file" in said
    assert json.loads((tmp_path / "img.albedo.pfm").read_text()) == PLANE


# --- the command line and the API: rendered ------------------------------------------------------

@pytest.mark.slow
def test_the_command_writes_every_pass_as_layers_of_the_exr_and_the_image_is_unchanged(tmp_path):
    scene = tmp_path / "plane.json"
    scene.write_text(json.dumps(PLANE))
    plain = rt("render", str(scene), "-o", "plain.png", "--hdr", "plain.exr", "--kernel", "general", cwd=tmp_path)
    assert plain.returncode == 0, plain.stderr
    out = rt("render", str(scene), "-o", "img.png", "--hdr", "img.exr", "--kernel", "general", "--passes",
             "albedo,normal,depth,samples,error", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "img.exr (with the layers albedo, normal, depth, samples, error)" in out.stdout
    channels = exr_channels(tmp_path / "img.exr")
    assert sorted(channels) == sorted(["R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y",
                                       "normal.Z", "depth.Z", "samples.Y", "error.Y"])
    before = exr_channels(tmp_path / "plain.exr")
    for c in "RGB":  # the beauty, bit for bit as without passes
        assert np.array_equal(channels[c], before[c]), c
    assert (tmp_path / "img.png").read_bytes() == (tmp_path / "plain.png").read_bytes()
    for k, c in enumerate("RGB"):
        np.testing.assert_allclose(channels[f"albedo.{c}"], ALBEDO[k], atol=1e-6)
    np.testing.assert_allclose(channels["normal.Z"], 1.0, atol=1e-6)
    np.testing.assert_allclose(channels["normal.X"], 0.0, atol=1e-6)
    np.testing.assert_allclose(channels["depth.Z"], 5.0, rtol=1e-6)
    assert (channels["samples.Y"] == 4.0).all()
    error = channels["error.Y"]
    assert np.isfinite(error).all() and (error >= 0).all() and error.max() > 0
    # The error pass is the noise estimate's per-pixel standard error: the spread of 4 samples
    # of the lit plane, far below its brightness.
    image = np.stack([channels[c] for c in "RGB"], axis=-1)
    assert error.mean() < image.mean()


@pytest.mark.slow
def test_the_command_writes_passes_as_files_beside_the_image(tmp_path):
    scene = tmp_path / "plane.json"
    scene.write_text(json.dumps(PLANE))
    out = rt("render", str(scene), "-o", "img.png", "--kernel", "general", "--passes", "depth,albedo", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "img.albedo.pfm" in out.stdout and "img.depth.pfm" in out.stdout
    albedo = read_pfm(tmp_path / "img.albedo.pfm")
    depth = read_pfm(tmp_path / "img.depth.pfm")
    assert albedo.shape == (12, 12, 3) and depth.shape == (12, 12)
    np.testing.assert_allclose(albedo, np.broadcast_to(ALBEDO, albedo.shape), atol=1e-6)
    np.testing.assert_allclose(depth, 5.0, rtol=1e-6)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["img.albedo.pfm", "img.depth.pfm", "img.png", "plane.json"]


@pytest.mark.slow
def test_the_api_returns_the_passes_as_arrays_and_the_same_image():
    import rt as api

    plain = api.render(PLANE, kernel="general")
    image = api.render(PLANE, kernel="general", passes=("normal", "samples", "error"))
    assert np.array_equal(image.array, plain.array)
    assert plain.passes == {}
    assert sorted(image.passes) == ["error", "normal", "samples"]
    # The error pass is the noise map, as float32.
    assert np.array_equal(image.passes["error"], image.noise_map.astype(np.float32))
    assert image.passes["normal"].shape == (12, 12, 3) and image.passes["normal"].dtype == np.float32
    np.testing.assert_allclose(image.passes["normal"], np.broadcast_to((0, 0, 1), (12, 12, 3)), atol=1e-6)
    assert (image.passes["samples"] == 4).all()
    with pytest.raises(ValueError, match="did you mean 'depth'"):
        api.render(PLANE, kernel="general", passes=["dpeth"])


@pytest.mark.slow
def test_passes_of_a_cluster_render_are_traced_here_and_match_a_local_one(tmp_path):
    pytest.importorskip("dask.distributed")
    scene = tmp_path / "plane.json"
    scene.write_text(json.dumps(PLANE))
    args = ("--kernel", "general", "--passes", "albedo,depth,samples", "--passes-as", "files")
    local = rt("render", str(scene), "-o", "l.png", "--hdr", "l.pfm", *args, cwd=tmp_path)
    assert local.returncode == 0, local.stderr
    far = rt("render", str(scene), "-o", "c.png", "--hdr", "c.pfm", *args, "--cluster", "local", cwd=tmp_path)
    assert far.returncode == 0, far.stderr
    assert "Traceback" not in far.stderr
    assert (tmp_path / "c.pfm").read_bytes() == (tmp_path / "l.pfm").read_bytes()
    for name in ("albedo", "depth", "samples"):
        assert (tmp_path / f"c.{name}.pfm").read_bytes() == (tmp_path / f"l.{name}.pfm").read_bytes(), name
    assert (read_pfm(tmp_path / "c.samples.pfm") == 4.0).all()
