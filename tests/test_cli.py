"""The `rt` command line, through typer's test runner and as a real process."""

import json
import subprocess
import sys
from pathlib import Path

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
    assert "textures: on (checker on shapes[0])" in result.stdout
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


def test_render_rejects_an_invalid_scene(tmp_path):
    path = write(tmp_path, "bad.yaml", INVALID)
    result = runner.invoke(app, ["render", str(path)])
    assert result.exit_code == 1
    assert "shapes[0].radious" in result.stderr
