"""The `rt` command line, through typer's test runner and as a real process."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from rt.cli import app

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()

VALID = """
camera: {look_from: [13, 2, 3], look_at: [0, 0, 0], defocus_angle: 0.6, focus_distance: 10}
materials: {g: {type: lambertian, albedo: {type: checker, scale: 0.32}}, spare: {type: metal}}
shapes:
  - {type: moving_sphere, center0: [0, 0, 0], center1: [0, 1, 0], radius: 1, material: g}
  - {type: sphere, center: [0, -1000, 0], radius: 1000, material: g}
"""

INVALID = """
materials: {glass: {type: dielectric, ior: -1}}
shapes:
  - {type: sphere, center: [0, 0, 0], radious: 1, material: glass}
"""


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_validate_summarises_a_valid_scene(tmp_path):
    path = write(tmp_path, "ok.yaml", VALID)
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    assert f"{path}: valid" in result.stdout
    assert "shapes: 2 (1 moving_sphere, 1 sphere)" in result.stdout
    assert "motion blur: on (shapes[0] moves, shutter 0..1)" in result.stdout
    assert "defocus: on (camera defocus_angle 0.6, focus distance 10)" in result.stdout
    assert "media: off" in result.stdout
    assert "integrator mis;" in result.stdout  # the default estimator, named
    assert "checker textures: on (shapes[0] uses one and 1 more)" in result.stdout
    assert "materials.spare: material 'spare' is defined but never used" in result.stderr


def test_validate_prints_every_error_and_exits_1(tmp_path):
    path = write(tmp_path, "bad.yaml", INVALID)
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 1
    lines = result.stderr.splitlines()
    assert f"{path}:2:44: error: materials.glass.ior: expected a number > 0, found -1" in lines
    assert f"{path}:4:39: error: shapes[0].radious: unknown key 'radious'; did you mean 'radius'?" in lines
    assert lines[-1] == f"{path}: invalid (2 errors)"


def test_validate_json_reports_each_file(tmp_path):
    good = write(tmp_path, "ok.yaml", VALID)
    bad = write(tmp_path, "bad.yaml", INVALID)
    result = runner.invoke(app, ["validate", "--json", str(good), str(bad)])
    assert result.exit_code == 1
    report = json.loads(result.stdout)
    assert report["valid"] is False
    first, second = report["files"]
    assert first["valid"] and first["summary"]["effects"]["motion blur"]["on"] is True
    assert first["summary"]["shapes"] == {"moving_sphere": 1, "sphere": 1}
    assert [e["path"] for e in second["errors"]] == ["materials.glass.ior", "shapes[0].radious"]
    assert second["errors"][0]["line"] == 2 and second["errors"][0]["column"] == 44


def test_validate_all_book_scenes_exits_0():
    scenes = sorted(str(p) for p in (ROOT / "scenes").glob("*.yaml")) + sorted(str(p) for p in (ROOT / "scenes").glob("*.json"))
    result = runner.invoke(app, ["validate", "--quiet", *scenes])
    assert result.exit_code == 0, result.output
    assert len(scenes) >= 17


def test_schema_prints_the_shipped_schema(tmp_path):
    result = runner.invoke(app, ["schema"])
    assert result.exit_code == 0
    assert json.loads(result.stdout)["$schema"] == "http://json-schema.org/draft-07/schema#"
    out = tmp_path / "s.json"
    assert runner.invoke(app, ["schema", "-o", str(out)]).exit_code == 0
    assert json.loads(out.read_text()) == json.loads(result.stdout)


@pytest.mark.slow
def test_validate_runs_without_numba_as_a_real_process(tmp_path):
    path = write(tmp_path, "ok.yaml", VALID)
    code = (
        "import sys; from rt.cli import app\n"
        "try:\n    app(['validate', '--quiet', sys.argv[1]])\n"
        "except SystemExit as e:\n    code = e.code\n"
        "print('numba' in sys.modules, 'renderer' in sys.modules, code)"
    )
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "0"]


@pytest.mark.slow
def test_render_rejects_an_invalid_scene(tmp_path):
    path = write(tmp_path, "bad.yaml", INVALID)
    result = runner.invoke(app, ["render", str(path)])
    assert result.exit_code == 1
    assert "shapes[0].radious" in result.stderr


SMALL = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 32, aspect_ratio: 2, samples_per_pixel: 4, max_depth: 8, seed: 5}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}, g: {type: dielectric, ior: 1.5}}
media: {fog: {type: constant, density: 0.5}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: g, interior: fog}
"""


def run_rt(*args, cwd, env_extra=None, **kw):
    import os

    env = dict(os.environ, **(env_extra or {}))
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, env=env, capture_output=True, text=True, **kw)


@pytest.mark.slow
def test_the_program_keeps_the_collector_off_and_freezes_what_lives_at_its_end():
    # The console script runs rt.__main__:run; its exit status is the command's, and the
    # objects alive at the end are frozen so the interpreter's shutdown passes skip them.
    from importlib.metadata import entry_points

    (script,) = [e for e in entry_points(group="console_scripts") if e.name == "rt"]
    assert script.value == "rt.__main__:run"
    probe = (
        "import gc, sys\n"
        "from rt.__main__ import run\n"
        "sys.argv = ['rt', 'validate', sys.argv[1]]\n"
        "try:\n    run()\nexcept SystemExit as exc:\n    code = exc.code\n"
        "print(code, gc.isenabled(), gc.get_freeze_count() > 1000)\n"
    )
    scene = Path(__file__).resolve().parents[1] / "scenes" / "cornell_box.yaml"
    out = subprocess.run([sys.executable, "-c", probe, str(scene)], capture_output=True, text=True)
    assert out.stdout.split()[-3:] == ["0", "False", "True"], out.stdout + out.stderr


@pytest.mark.slow
def test_render_writes_the_default_output_name_and_applies_overrides(tmp_path):
    write(tmp_path, "ball.yaml", SMALL)
    out = run_rt("render", "ball.yaml", "--spp", "2", "--width", "20", "--max-depth", "3", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    from PIL import Image

    with Image.open(tmp_path / "ball.png") as img:
        assert img.size == (20, 10)
        assert np.asarray(img.convert("L")).max() > 0
    assert "wrote ball.png: 20x10, 2 spp" in out.stdout
    assert "Mrays/s" in out.stdout


@pytest.mark.slow
def test_render_is_identical_with_one_thread_or_two(tmp_path):
    write(tmp_path, "ball.yaml", SMALL)
    images = []
    for threads in ("1", "2"):
        out = run_rt("render", "ball.yaml", "-o", f"t{threads}.png", "--hdr", f"t{threads}.pfm", "--threads", threads,
                     cwd=tmp_path, env_extra={"NUMBA_NUM_THREADS": threads})
        assert out.returncode == 0, out.stderr
        images.append((tmp_path / f"t{threads}.pfm").read_bytes())
    assert images[0] == images[1]


def test_render_refuses_bad_output_names_before_rendering(tmp_path):
    write(tmp_path, "ball.yaml", SMALL)
    result = runner.invoke(app, ["render", str(tmp_path / "ball.yaml"), "-o", str(tmp_path / "x.jpg")])
    assert result.exit_code == 1 and "must end in .png" in result.stderr
    result = runner.invoke(app, ["render", str(tmp_path / "ball.yaml"), "-o", str(tmp_path / "no" / "x.png")])
    assert result.exit_code == 1 and "does not exist" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ball.yaml"]


@pytest.mark.slow
def test_ctrl_c_saves_the_samples_rendered_so_far(tmp_path):
    import signal
    import time

    write(tmp_path, "ball.yaml", SMALL.replace("samples_per_pixel: 4", "samples_per_pixel: 1000000").replace("width: 32", "width: 64"))
    proc = subprocess.Popen([sys.executable, "-m", "rt", "render", "ball.yaml"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Wait until the progress bar shows that passes are running, then interrupt.
    deadline = time.time() + 120
    seen = ""
    while time.time() < deadline and "spp" not in seen:
        seen += proc.stderr.readline()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "interrupted: the image holds" in err
    assert (tmp_path / "ball.png").is_file()
    assert "wrote ball.png" in out


@pytest.mark.slow
def test_render_reports_noise_writes_a_noise_map_and_resumes(tmp_path):
    write(tmp_path, "ball.yaml", SMALL)
    first = run_rt("render", "ball.yaml", "--spp", "4", "--save-state", "s.npz", "--noise-map", "n.png", "--hdr", "a.pfm",
                   cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    assert "noise: " in first.stdout and "% relative RMS" in first.stdout
    assert (tmp_path / "n.png").is_file() and (tmp_path / "s.npz").is_file()
    resumed = run_rt("render", "ball.yaml", "--spp", "8", "--resume", "s.npz", "--hdr", "b.pfm", cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming s.npz: 4 samples per pixel already rendered" in resumed.stderr
    whole = run_rt("render", "ball.yaml", "--spp", "8", "--hdr", "c.pfm", cwd=tmp_path)
    assert whole.returncode == 0, whole.stderr
    assert (tmp_path / "b.pfm").read_bytes() == (tmp_path / "c.pfm").read_bytes()
    other = run_rt("render", "ball.yaml", "--spp", "8", "--seed", "9", "--resume", "s.npz", cwd=tmp_path)
    assert other.returncode == 1 and "does not match" in other.stderr and "seed 5 (now 9)" in other.stderr


@pytest.mark.slow
def test_render_with_a_noise_target_says_why_it_stopped(tmp_path):
    write(tmp_path, "ball.yaml", SMALL)
    out = run_rt("render", "ball.yaml", "--noise", "0.05", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "stopped: the estimated noise" in out.stderr and "below the 5.00% target" in out.stderr


def test_durations_are_parsed():
    from rt.render_job import parse_duration as _parse_duration

    assert _parse_duration("30s") == 30
    assert _parse_duration("2m") == 120
    assert _parse_duration("1h30m") == 5400
    assert _parse_duration("45") == 45
    assert _parse_duration("1.5h") == 5400
    assert _parse_duration("soon") is None
    assert _parse_duration("3x") is None


@pytest.mark.slow
def test_render_explain_names_the_element_behind_each_effect(tmp_path):
    write(tmp_path, "ball.yaml", SMALL)
    out = run_rt("render", "ball.yaml", "--spp", "1", "--explain", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "media: on (shapes[1] holds fog)" in out.stderr
    assert "motion blur: off" in out.stderr and "dielectrics: on (shapes[1] is glass-like)" in out.stderr


@pytest.mark.slow
def test_an_unreadable_image_texture_is_a_scene_error_without_a_traceback(tmp_path):
    (tmp_path / "tex.png").write_text("not a png")
    write(tmp_path, "s.yaml", "materials: {e: {type: lambertian, albedo: {type: image, file: tex.png}}}\n"
                              "shapes: [{type: sphere, center: [0, 0, -2], radius: 1, material: e}]\n")
    out = run_rt("render", "s.yaml", cwd=tmp_path)
    assert out.returncode == 1
    # The scene check already reads the image's header, so the error has a file position.
    assert "s.yaml:1:63: error: materials.e.albedo.file: image file 'tex.png' is not a readable image" in out.stderr
    assert "Traceback" not in out.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml", "tex.png"]


def test_version_names_the_package_and_the_format():
    from importlib.metadata import version

    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.stdout.startswith(f"rt {version('rt-render')} (scene format version 1, Python ")


def test_validate_reads_yaml_or_json_from_standard_input(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "lib.yaml").write_text("materials: {m: {type: metal}}\n")
    text = "include: [lib.yaml]\nshapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: m}]\n"
    result = runner.invoke(app, ["validate", "-", "--set", "image.width=64"], input=text)
    assert result.exit_code == 0, result.output
    assert "<stdin>: valid" in result.stdout
    assert "image: 64x64" in result.stdout
    as_json = '{"image": {"width": 1.5}}'
    for args in (["validate", "-"], ["validate", "--format", "json", "-"]):
        result = runner.invoke(app, args, input=as_json)
        assert result.exit_code == 1
        assert "<stdin>:1:21: error: image.width: expected a valid integer, found 1.5" in result.stderr
    # Read as YAML on request, the same text is still a scene (JSON is YAML), with positions.
    result = runner.invoke(app, ["validate", "--format", "yaml", "-"], input=as_json)
    assert "<stdin>:1:21: error: image.width" in result.stderr
    result = runner.invoke(app, ["validate", "--format", "json", "-"], input="image: {width: 3}\n")
    assert "<stdin>:1:1: error: (top level): JSON syntax error" in result.stderr


def test_standard_input_is_read_once_and_bounded():
    from io import BytesIO

    from scenefmt.files import FileProblem, read_stream

    result = runner.invoke(app, ["validate", "-", "-"], input="{}")
    assert result.exit_code == 2
    assert "standard input (-) can be read only once" in result.stderr
    assert read_stream(BytesIO(b"x" * 10), 10) == b"x" * 10
    with pytest.raises(FileProblem, match="larger than the 9 bytes allowed"):
        read_stream(BytesIO(b"x" * 10), 9)


def test_validate_reports_a_bad_set_argument_and_exits_1(tmp_path):
    path = write(tmp_path, "ok.yaml", VALID)
    result = runner.invoke(app, ["validate", str(path), "--set", "image.width=wide", "--json"])
    assert result.exit_code == 1
    (error,) = json.loads(result.stdout)["files"][0]["errors"]
    assert error["file"] == "--set image.width=wide"
    assert (error["line"], error["column"], error["path"]) == (1, 13, "image.width")


@pytest.mark.slow
def test_render_reads_stdin_applies_set_and_writes_openexr(tmp_path):
    # One render through the whole program: the scene on standard input, a --set value, an EXR
    # image texture (relative to the current folder) and the linear image written as EXR.
    from renderer.film import write_exr
    from scenefmt.hdr_files import read_hdr

    write_exr(tmp_path / "tex.exr", np.full((2, 2, 3), 0.5))
    scene = SMALL.replace("albedo: [0.6, 0.3, 0.2]", "albedo: {type: image, file: tex.exr}")
    out = run_rt("render", "-", "--set", "image.width=16", "--spp", "2", "--hdr", "lin.exr", cwd=tmp_path, input=scene)
    assert out.returncode == 0, out.stderr
    assert "wrote stdin.png, lin.exr: 16x8, 2 spp" in out.stdout
    linear = read_hdr(tmp_path / "lin.exr", 1000)
    assert linear.shape == (8, 16, 3) and linear.max() > 0
    bad = run_rt("render", "-", "--set", "image.width=0", cwd=tmp_path, input=scene)
    assert bad.returncode == 1
    assert "--set image.width=0:1:13: error: image.width: expected a number >= 1, found 0" in bad.stderr
