"""A colour temperature on every emitter: the principled material's emission takes one as the
diffuse light's `emit` and the lights under `lights:` do, with the same black body's colour."""

import pytest

from scenefmt.blackbody import temperature_rgb
from scenefmt.diagnostics import SceneError
from scenefmt.validation import loads

SCENE = """
materials:
  warm: {{type: principled, emission: {emission}, emission_temperature: {kelvin}}}
  lamp: {{type: diffuse_light, emit: [2, 2, 2], temperature: {kelvin}}}
shapes:
  - {{type: sphere, center: [0, 0, -2], radius: 0.5, material: warm}}
  - {{type: sphere, center: [1, 0, -2], radius: 0.5, material: lamp}}
"""


def emitted(kelvin, emission="[2, 2, 2]"):
    graph = loads(SCENE.format(kelvin=kelvin, emission=emission)).graph
    by_kind = {m.kind: m for m in graph.materials}
    return by_kind["principled"].textures["emission"].model.color, by_kind["diffuse_light"].textures["emit"].model.color


@pytest.mark.parametrize("kelvin", [1900, 2700, 4000, 6500, 12000])
def test_a_principled_emission_takes_the_black_body_colour_the_diffuse_light_does(kelvin):
    principled, diffuse = emitted(kelvin)
    expected = tuple(2.0 * c for c in temperature_rgb(kelvin))
    assert principled == pytest.approx(expected, rel=1e-12) and diffuse == pytest.approx(expected, rel=1e-12)
    # Luminance 1 per unit of L: the grey's value is the emission's luminance.
    assert 0.2126 * principled[0] + 0.7152 * principled[1] + 0.0722 * principled[2] == pytest.approx(2.0, rel=1e-9)
    if kelvin < 5000:
        assert principled[0] > principled[1] > principled[2]  # warm: red over blue


def test_a_coloured_emission_with_a_temperature_is_refused_in_one_sentence():
    with pytest.raises(SceneError) as caught:
        emitted(2700, emission="[2, 1, 1]")
    text = str(caught.value)
    assert "emission" in text and "grey" in text and "Traceback" not in text


def test_without_a_temperature_the_emission_is_as_written():
    graph = loads("materials: {m: {type: principled, emission: [0.5, 1, 2]}}\n"
                  "shapes: [{type: sphere, center: [0, 0, -2], radius: 0.5, material: m}]").graph
    assert graph.materials[0].textures["emission"].model.color == (0.5, 1.0, 2.0)
