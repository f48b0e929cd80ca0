"""The shipped JSON Schema and `rt validate` judge the same corpus, and every disagreement is listed.

The corpus: every book scene (valid), every file of the invalid corpus that parses, and the
cases below (written for the rules the schema expresses, each on both sides of its line). The
schema sees what a YAML or JSON parser makes of a file; `rt validate` sees that and more (names
across sections, files on disk, geometry computed from several values). Each disagreement must be
one of `KNOWN`, whose reasons are the rules the format reference lists as beyond the schema; a new
one fails the test with the whole list printed.
"""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from scenefmt.diagnostics import SceneError
from scenefmt.loading import parse_file, parse_text
from scenefmt.schema_export import BEYOND_THE_SCHEMA, committed_schema_path
from scenefmt.validation import check_document, compose

ROOT = Path(__file__).resolve().parents[2]
INVALID = Path(__file__).parent / "invalid"

SPHERE = "{type: sphere, center: [0, 0, 0], radius: 1"
CASES: dict[str, str] = {
    # Rules the schema now expresses, on both sides.
    "sphere_without_material_or_interior": f"shapes: [{SPHERE}}}]",
    "sphere_with_only_an_interior": f"media: {{fog: {{type: constant, density: 1}}}}\nshapes: [{SPHERE}, interior: fog}}]",
    "sphere_with_null_material_and_an_interior": f"media: {{fog: {{type: constant, density: 1}}}}\nshapes: [{SPHERE}, material: null, interior: fog}}]",
    "box_with_null_material_only": "shapes: [{type: box, min: [0, 0, 0], max: [1, 1, 1], material: null}]",
    "aperture_and_defocus_angle": "camera: {aperture: 0.5, defocus_angle: 2}",
    "aperture_zero_and_defocus_angle": "camera: {aperture: 0, defocus_angle: 2}",
    "aperture_and_defocus_angle_zero": "camera: {aperture: 0.5, defocus_angle: 0}",
    "height_and_aspect_ratio": "image: {height: 100, aspect_ratio: 2}",
    "height_and_null_aspect_ratio": "image: {height: 100, aspect_ratio: null}",
    "width_fractional": "image: {width: 100.5}",
    "width_a_string": "image: {width: '100'}",
    "zero_disk_normal": "materials: {m: {type: metal}}\nshapes: [{type: disk, center: [0, 0, 0], normal: [0, 0.0, 0], radius: 1, material: m}]",
    "zero_rotation_axis": f"materials: {{m: {{type: metal}}}}\nshapes: [{SPHERE}, material: m, transform: [{{rotate: {{axis: [0, 0, 0], degrees: 5}}}}]}}]",
    "zero_scale_in_a_list": f"materials: {{m: {{type: metal}}}}\nshapes: [{SPHERE}, material: m, transform: [{{scale: [1, 0, 1]}}]}}]",
    "negative_scale": f"materials: {{m: {{type: metal}}}}\nshapes: [{SPHERE}, material: m, transform: [{{scale: -2}}]}}]",
    "zero_up": "camera: {up: [0, 0, 0]}",
    "unknown_shape_type": f"shapes: [{{type: sphear, center: [0, 0, 0], radius: 1}}]",
    "misspelt_key_in_a_material": "materials: {m: {type: metal, fuzzz: 0.1}}",
    "inline_material_of_unknown_type": f"shapes: [{SPHERE}, material: {{type: metl}}}}]",
    "include_not_a_name": "include: 7",
    "empty_include_name": "include: ['']",
    # Beyond the schema.
    "width_written_as_a_float": "image: {width: 100.0}",
    "tiny_magnitude": "camera: {vfov: 1e-60}",
    "height_from_width_and_ratio_too_large": "image: {width: 30000, aspect_ratio: 0.5}",
    "albedo_texture_above_one": "textures: {t: {type: solid, color: [2, 2, 2]}}\nmaterials: {m: {type: lambertian, albedo: t}}\n"
    f"shapes: [{SPHERE}, material: m}}]",
    "include_missing_file": "include: [no_such_file.yaml]",
}

# Why each disagreement is beyond a JSON Schema: a key of BEYOND_THE_SCHEMA (listed in docs/format.md).
KNOWN: dict[str, str] = {
    "box_max_not_above_min.yaml": "geometry",
    "look_from_equals_look_at.yaml": "geometry",
    "up_parallel_to_view.yaml": "geometry",
    "shutter_open_after_close.yaml": "geometry",
    "quad_zero_area.yaml": "geometry",
    "triangle_zero_area.yaml": "geometry",
    "singular_matrix.yaml": "geometry",
    "height_from_width_and_ratio_too_large": "geometry",
    "group_cycle_two.yaml": "names",
    "group_instances_itself.yaml": "names",
    "texture_cycle.yaml": "names",
    "material_no_stays_string.yaml": "names",
    "undefined_group.yaml": "names",
    "undefined_material.yaml": "names",
    "undefined_medium.yaml": "names",
    "undefined_texture.yaml": "names",
    "image_texture_missing_file.yaml": "files",
    "image_texture_not_an_image.yaml": "files",
    "include_missing_file": "files",
    "json_duplicate_field.json": "duplicates",
    "json_duplicate_material.json": "duplicates",
    "yaml_duplicate_field.yaml": "duplicates",
    "yaml_duplicate_material.yaml": "duplicates",
    "width_written_as_a_float": "integers",
    "tiny_magnitude": "magnitudes",
    "albedo_texture_above_one": "colours",
}


def corpus():
    """(name, a function that parses it) for every entry of the corpus."""
    scenes = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))
    for path in scenes + sorted(p for p in INVALID.iterdir() if p.suffix in (".yaml", ".json")):
        yield path.name, lambda path=path: parse_file(path)
    for name, text in CASES.items():
        yield name, lambda name=name, text=text: parse_text(text, name, "yaml", base_dir=INVALID)


def judge(make_doc, schema_validator) -> tuple[bool, bool, str] | None:
    """(the validator accepts, the schema accepts, the validator's first message); None if it does not parse."""
    try:
        doc = make_doc()
    except SceneError:
        return None
    schema_ok = schema_validator.is_valid(doc.data)
    try:
        check_document(compose(doc))  # as `rt validate` does: includes merged, then checked
    except SceneError as exc:
        return False, schema_ok, exc.diagnostics[0].message
    return True, schema_ok, ""


@pytest.fixture(scope="module")
def schema_validator():
    return jsonschema.Draft7Validator(json.loads(committed_schema_path().read_text()))


def test_the_schema_and_the_validator_disagree_only_where_the_schema_cannot_follow(schema_validator):
    judged = 0
    disagreements: dict[str, str] = {}
    for name, make_doc in corpus():
        verdict = judge(make_doc, schema_validator)
        if verdict is None:
            continue  # a syntax error: nothing for a schema to see
        judged += 1
        validator_ok, schema_ok, message = verdict
        if validator_ok != schema_ok:
            disagreements[name] = f"validator {'accepts' if validator_ok else 'refuses'}, schema {'accepts' if schema_ok else 'refuses'}: {message}"
    listing = "\n".join(f"{name}: {why}" for name, why in sorted(disagreements.items()))
    print(f"{judged} files judged, {len(disagreements)} disagreements:\n{listing}")
    assert judged >= 100
    unexpected = {n: w for n, w in disagreements.items() if n not in KNOWN}
    assert not unexpected, "disagreements not known to be beyond the schema:\n" + "\n".join(f"{n}: {w}" for n, w in unexpected.items())
    resolved = set(KNOWN) - set(disagreements)
    assert not resolved, f"no longer disagreements (remove them from KNOWN): {sorted(resolved)}"
    assert set(KNOWN.values()) <= set(BEYOND_THE_SCHEMA)
    # Where they disagree, it is always the schema that lets a file through.
    assert all(w.startswith("validator refuses, schema accepts") for w in disagreements.values())


@pytest.mark.parametrize("name", [
    "sphere_without_material_or_interior", "box_with_null_material_only", "aperture_and_defocus_angle",
    "height_and_aspect_ratio", "width_fractional", "zero_disk_normal", "zero_rotation_axis", "zero_scale_in_a_list",
    "zero_up", "include_not_a_name", "empty_include_name",
])
def test_the_schema_refuses_what_it_now_expresses(name, schema_validator):
    assert not schema_validator.is_valid(parse_text(CASES[name], name, "yaml").data)


@pytest.mark.parametrize("name", [
    "sphere_with_only_an_interior", "sphere_with_null_material_and_an_interior", "aperture_zero_and_defocus_angle",
    "aperture_and_defocus_angle_zero", "height_and_null_aspect_ratio", "negative_scale",
])
def test_the_schema_accepts_the_other_side_of_each_rule(name, schema_validator):
    assert schema_validator.is_valid(parse_text(CASES[name], name, "yaml").data)


@pytest.mark.parametrize("data, path, words", [
    # A tagged union checks the member its `type` names, so the error names the wrong key.
    ({"shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m", "radious": 2}]}, ["shapes", 0], "'radious' was unexpected"),
    ({"materials": {"m": {"type": "metal", "fuzzz": 1}}}, ["materials", "m"], "'fuzzz' was unexpected"),
    ({"textures": {"t": {"type": "checker", "scael": 1}}}, ["textures", "t"], "'scael' was unexpected"),
    ({"shapes": [{"type": "sphear"}]}, ["shapes", 0, "type"], "'sphear' is not one of"),
    ({"shapes": [{"center": [0, 0, 0]}]}, ["shapes", 0], "'type' is a required property"),
])
def test_errors_of_tagged_unions_name_the_wrong_key(data, path, words, schema_validator):
    errors = list(schema_validator.iter_errors(data))
    assert len(errors) == 1
    assert list(errors[0].absolute_path) == path
    assert words in errors[0].message


def test_the_format_reference_lists_what_the_schema_cannot_check():
    text = (ROOT / "docs" / "format.md").read_text()
    for reason in BEYOND_THE_SCHEMA.values():
        assert reason in text
