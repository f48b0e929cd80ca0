"""The Python API: rt.render, rt.load, rt.validate and the Image they return."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import rt
from rt.cli import app
from tests.test_cli import write

ROOT = Path(__file__).resolve().parents[1]

SMALL = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 24, aspect_ratio: 2, samples_per_pixel: 3, max_depth: 6, seed: 5}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}, g: {type: dielectric, ior: 1.5}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: g}
"""

BROKEN = """
materials: {glass: {type: dielectric, ior: -1}}
shapes:
  - {type: sphere, center: [0, 0, 0], radious: 1, material: glass}
"""


def scene_file(tmp_path, text=SMALL, name="ball.yaml"):
    return write(tmp_path, name, text)


def test_validate_gives_every_diagnostic_with_its_place_without_raising(tmp_path):
    report = rt.validate(scene_file(tmp_path, BROKEN, "bad.yaml"))
    assert not report.ok
    places = {(d.line, d.column, d.message.split(";")[0]) for d in report.errors}
    assert (4, 39, "unknown key 'radious'") in places
    assert any("ior" in str(d) for d in report.errors)
    assert all(d.file.endswith("bad.yaml") for d in report.errors)
    good = rt.validate(scene_file(tmp_path))
    assert good.ok and good.errors == [] and good.loaded.graph.image.width == 24


def test_load_takes_a_file_a_model_or_a_dict_and_applies_overrides(tmp_path):
    import yaml

    from_file = rt.load(scene_file(tmp_path), overrides=["image.width=16"])
    assert from_file.graph.image.width == 16
    from_model = rt.load(from_file.scene)
    assert from_model.scene == from_file.scene
    from_dict = rt.load(yaml.safe_load(SMALL) | {"image": {"width": np.int64(8), "aspect_ratio": 2}})
    assert from_dict.graph.image.width == 8


def test_errors_raise_scene_error_with_the_diagnostics_and_bad_options_value_error(tmp_path):
    with pytest.raises(rt.SceneError) as caught:
        rt.render(scene_file(tmp_path, BROKEN, "bad.yaml"), spp=1)
    assert any(d.path == ("shapes", 0, "radious") for d in caught.value.diagnostics)
    with pytest.raises(rt.SceneError, match=r"<dict>:1:1: error: shapes\[0\]\.center: missing required key"):
        rt.render({"shapes": [{"type": "sphere", "radius": 1}]})
    with pytest.raises(ValueError, match="integrator='bdpt': expected 'guided', 'mis' or 'path'"):
        rt.render(scene_file(tmp_path), integrator="bdpt")
    with pytest.raises(ValueError, match="spp=0: expected a whole number from 1"):
        rt.render(scene_file(tmp_path), spp=0)
    with pytest.raises(ValueError, match=r"threads=65536: at most \d+ threads are available"):
        rt.render(scene_file(tmp_path), threads=65536)  # checked as rt render checks --threads, before loading
    with pytest.raises(ValueError, match="time='soon'"):
        rt.render(scene_file(tmp_path), time="soon")
    with pytest.raises(TypeError, match="expected a scene file name"):
        rt.load(42)


@pytest.mark.slow
def test_importing_rt_loads_neither_numba_nor_the_renderer():
    code = "import sys, rt; print('numba' in sys.modules, 'renderer' in sys.modules, callable(rt.render))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "True"]


@pytest.mark.slow
def test_the_api_array_is_the_cli_hdr_image_bit_for_bit(tmp_path, monkeypatch):
    from renderer.film import read_pfm

    path = scene_file(tmp_path)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["render", str(path), "--spp", "5", "--seed", "11", "-o", "cli.png", "--hdr", "cli.pfm"])
    assert result.exit_code == 0, result.output
    image = rt.render(path, spp=5, seed=11)
    assert image.array.dtype == np.float32 and image.array.shape == (12, 24, 3)
    assert np.array_equal(image.array, read_pfm(tmp_path / "cli.pfm").astype(np.float32))
    # Its files are the command's, byte for byte.
    image.save(tmp_path / "api.pfm")
    image.save(tmp_path / "api.png")
    assert (tmp_path / "api.pfm").read_bytes() == (tmp_path / "cli.pfm").read_bytes()
    assert (tmp_path / "api.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    assert image._repr_png_() == (tmp_path / "cli.png").read_bytes()
    # The noise the command printed is the image's.
    assert f"noise: {100 * image.noise:.2f}% relative RMS" in result.stdout
    assert image.samples == 5 and image.noise_map.shape == (12, 24)
    assert repr(image).startswith("<rt.Image ball 24x12, 5 spp (mis), noise ")


@pytest.mark.slow
def test_a_dict_a_model_and_a_file_render_the_same_image_and_save_openexr(tmp_path):
    import yaml

    from scenefmt.hdr_files import read_hdr

    path = scene_file(tmp_path)
    from_file = rt.render(path, width=12, integrator="path")
    from_dict = rt.render(yaml.safe_load(SMALL), width=12, integrator="path")
    from_model = rt.render(rt.load(path).scene, width=12, integrator="path")
    assert from_file.integrator == "path" and from_file.array.shape == (6, 12, 3)
    assert np.array_equal(from_file.array, from_dict.array)
    assert np.array_equal(from_file.array, from_model.array)
    from_file.save(tmp_path / "lin.exr")
    assert np.array_equal(read_hdr(tmp_path / "lin.exr", 1000).astype(np.float32), from_file.array)
    with pytest.raises(ValueError, match="unsupported image format '.tif'"):
        from_file.save(tmp_path / "x.tif")


@pytest.mark.slow
def test_budgets_and_should_stop(tmp_path):
    path = scene_file(tmp_path)
    noisy = rt.render(path, noise=0.5, spp=64)
    assert noisy.stats.stop_reason == "noise" and noisy.noise <= 0.5
    stopped = rt.render(path, spp=1000, should_stop=lambda: True)
    assert stopped.samples == 0 and stopped.stats.interrupted


def readme_python_example() -> str:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"<!-- api-example -->\s*```python\n(.*?)```\s*<!-- /api-example -->", text, re.S)
    assert block, "the README's Python example sits between the api-example markers"
    return block.group(1)


@pytest.mark.slow
def test_the_readme_python_example_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    code = readme_python_example().replace("cornell.exr", str(tmp_path / "cornell.exr"))
    code = code.replace("cornell.png", str(tmp_path / "cornell.png"))
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert (tmp_path / "cornell.exr").exists() and (tmp_path / "cornell.png").exists()
    # What the example says it gives: the last image 32 wide with its blue wall, the first one
    # written as a finite 64 x 64 EXR, and the misspelt key refused.
    from scenefmt.hdr_files import read_hdr

    exr = read_hdr(tmp_path / "cornell.exr", 64 * 64)
    assert exr.shape == (64, 64, 3) and np.isfinite(exr).all() and exr.mean() > 0
    last = namespace["img"].array
    assert last.shape == (32, 32, 3) and np.isfinite(last).all()
    assert namespace["report"].ok is False
