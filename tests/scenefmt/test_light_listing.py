"""`rt validate` lists the kinds of light a scene has, how many and what makes each, and the
`punctual` effect (the kernels' point, spot and directional path) is switched on by the first
light under `lights:`, with that light named, as the kernel choice reads it."""

import json

from typer.testing import CliRunner

from rt.cli import app
from scenefmt.effects import summarize
from scenefmt.validation import loads

runner = CliRunner()

LIT = """
materials: {white: {type: lambertian, albedo: [0.8, 0.8, 0.8]}, lamp: {type: diffuse_light, emit: [4, 4, 4]}}
groups:
  bulbs: {shapes: [{type: sphere, center: [0, 0, 0], radius: 0.1, material: lamp}, {type: sphere, center: [1, 0, 0], radius: 0.1, material: lamp}]}
shapes:
  - {type: quad, q: [-5, 0, -5], u: [10, 0, 0], v: [0, 0, 10], material: white}
  - {type: instance, group: bulbs, transform: [{translate: [0, 1, 0]}]}
  - {type: instance, group: bulbs, transform: [{translate: [0, 2, 0]}]}
  - {type: instance, group: bulbs, transform: [{translate: [0, 3, 0]}]}
  - {type: quad, q: [0, 4, 0], u: [1, 0, 0], v: [0, 0, 1], material: lamp}
lights:
  - {type: spot, position: [0, 3, 0], look_at: [0, 0, 0]}
  - {type: point, position: [0, 3, 0], power: 100, temperature: 2700}
  - {type: point, position: [1, 3, 0], radius: 0.2}
  - {type: directional, direction: [0, -1, 0], irradiance: 2}
"""
DARK = "materials: {white: {type: lambertian}}\nshapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: white}]\n"


def test_the_first_light_switches_the_punctual_path_on():
    effect = summarize(loads(LIT).graph).effect("punctual")
    assert effect.on and effect.reason == "lights[0] is a spot light and 3 more"
    assert not summarize(loads(DARK).graph).effect("punctual").on


def test_without_light_sampling_the_lights_are_never_found_and_the_path_stays_off():
    loaded = loads(LIT + "image: {integrator: path}\n")
    effect = summarize(loaded.graph).effect("punctual")
    assert not effect.on and "never found" in effect.reason
    # Valid, with a warning at lights: the image would be dark where only they shine.
    assert any("light nothing with image.integrator path" in str(w) for w in loaded.warnings)
    assert not any("integrator" in str(w) for w in loads(LIT).warnings)


def test_the_light_kinds_are_counted_with_instances_placing_emitters():
    kinds = {light.kind: light for light in summarize(loads(LIT).graph).lights}
    assert list(kinds) == ["area", "point", "spot", "directional"]
    # Two bulbs placed three times and a quad: 7 emitting shapes in the scene, 3 in the file.
    assert kinds["area"].count == 7 and "7 in all, as instances place them" in kinds["area"].reason
    assert (kinds["point"].count, kinds["point"].reason) == (2, "lights[1] and 1 more")
    assert (kinds["spot"].count, kinds["spot"].reason) == (1, "lights[0]")
    assert kinds["directional"].count == 1
    assert summarize(loads(DARK).graph).lights == []


def test_validate_prints_the_lights_and_their_json(tmp_path):
    path = tmp_path / "lit.yaml"
    path.write_text(LIT)
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert "  lights:\n    area: 7 (" in text and "    point: 2 (lights[1] and 1 more)" in text
    assert "point, spot, directional and sun lights: on (lights[0] is a spot light and 3 more)" in text
    result = runner.invoke(app, ["validate", "--json", str(path)])
    summary = json.loads(result.stdout)["files"][0]["summary"]
    assert summary["lights"]["spot"] == {"count": 1, "reason": "lights[0]"}
    assert summary["lights"]["area"]["count"] == 7
    dark = tmp_path / "dark.yaml"
    dark.write_text(DARK)
    assert "  lights: none (only the background lights the scene)" in runner.invoke(app, ["validate", str(dark)]).stdout


def test_render_explain_lists_the_lights_too(tmp_path, capsys):
    from rt.render_job import RenderOptions, prepare

    path = tmp_path / "lit.yaml"
    path.write_text(LIT)
    prepare(RenderOptions(scene=path, output=tmp_path / "lit.png", explain=True))
    err = capsys.readouterr().err
    assert "lights: area: 7 (" in err and "point: 2 (lights[1] and 1 more), spot: 1 (lights[0]), directional: 1 (lights[3])" in err
