"""The shipped JSON Schema: generated from the models, draft-07, and in agreement with them."""

import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import jsonschema
import pytest

from scenefmt.loading import parse_file
from scenefmt.schema_export import NEWER_KEYWORDS, committed_schema_path, schema_json, shipped_schema_text

ROOT = Path(__file__).resolve().parents[2]
SCENES = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))


@pytest.fixture(scope="module")
def validator():
    schema = json.loads(committed_schema_path().read_text())
    return jsonschema.Draft7Validator(schema)


def test_committed_schema_matches_the_models():
    assert committed_schema_path().read_text() == schema_json(), (
        "schemas/scene.schema.json is out of date: run `python -m scenefmt.schema_export`"
    )


def test_schema_is_valid_draft_07_without_newer_keywords():
    schema = json.loads(schema_json())
    assert schema["$schema"] == "http://json-schema.org/draft-07/schema#"
    jsonschema.Draft7Validator.check_schema(schema)

    def keys(node):
        if isinstance(node, dict):
            for k, v in node.items():
                yield k
                if k not in ("properties", "definitions"):
                    yield from keys(v)
                else:
                    for sub in v.values():
                        yield from keys(sub)
        elif isinstance(node, list):
            for item in node:
                yield from keys(item)

    assert not (set(keys(schema)) & NEWER_KEYWORDS)


def test_installed_package_ships_the_same_schema():
    assert shipped_schema_text() == committed_schema_path().read_text()


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_every_book_scene_validates_against_the_json_schema(path, validator):
    errors = [e.message for e in validator.iter_errors(parse_file(path).data)]
    assert errors == []


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_yaml_scenes_point_editors_at_the_schema(path):
    if path.suffix == ".yaml":
        assert path.read_text().splitlines()[0] == "# yaml-language-server: $schema=../schemas/scene.schema.json"
        assert (path.parent / "../schemas/scene.schema.json").resolve() == committed_schema_path()


@pytest.mark.parametrize("data", [
    {"shapes": [{"type": "sphere", "center": [0, 0], "radius": 1, "material": "m"}]},
    {"shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": -1, "material": "m"}]},
    {"shapes": [{"type": "sphear", "center": [0, 0, 0], "radius": 1, "material": "m"}]},
    {"materials": {"m": {"type": "metal", "fuzz": 2}}},
    {"materials": {"bad name": {"type": "lambertian"}}},
    {"camera": {"vfov": 180}},
    {"image": {"width": 0}},
    {"shapes": [{"type": "box", "min": [0, 0, 0], "max": [1, 1, 1], "material": "m", "transform": [{"translte": [1, 2, 3]}]}]},
    {"version": 2},
    {"colour": [1, 1, 1]},
])
def test_json_schema_rejects_what_the_models_reject(data, validator):
    assert list(validator.iter_errors(data))


@pytest.mark.slow
def test_wheel_contains_the_schema(tmp_path):
    # A non-editable install ships what the wheel holds; build one without network access.
    # Build from a clean copy: a leftover *.egg-info in the checkout would add files the package
    # list forgets, and hide exactly the mistake this test is for.
    source = tmp_path / "src"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns("*.egg-info", "build", "dist", ".venv", ".git", "__pycache__"))
    out = tmp_path / "wheel"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation", "-q", "-w", str(out)],
        check=True,
        cwd=tmp_path,
    )
    (wheel,) = out.glob("*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "scenefmt/schemas/scene.schema.json" in names
    assert json.loads(zipfile.ZipFile(wheel).read("scenefmt/schemas/scene.schema.json")) == json.loads(schema_json())
    # Every source module of the packages ships (a subpackage left out of the list broke `pip install .`).
    for package in ("scenefmt", "renderer", "rt"):
        for module in (ROOT / package).rglob("*.py"):
            assert module.relative_to(ROOT).as_posix() in names, f"{module.relative_to(ROOT)} is missing from the wheel"
