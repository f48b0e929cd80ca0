"""The models of lights that are no shape (scenefmt/lights.py) and `temperature` on a diffuse
light: what they accept, the one clear error for what they do not, what they send (intensity,
power, irradiance, colour), and that the JSON Schema has them."""

import json
import math
from pathlib import Path

import pytest

from scenefmt.blackbody import luminance, temperature_rgb
from scenefmt.diagnostics import SceneError
from scenefmt.lights import DirectionalLight, PointLight, SpotLight, spot_solid_angle
from scenefmt.validation import loads

ROOT = Path(__file__).resolve().parents[2]
HEAD = "shapes: []\n"


def scene(lights: str):
    return loads(HEAD + f"lights: [{lights}]\n")


def errors(lights: str) -> str:
    with pytest.raises(SceneError) as info:
        scene(lights)
    return str(info.value)


def test_the_three_kinds_load_into_the_graph_in_order():
    loaded = scene("{type: point, position: [0, 3, 0]}, {type: spot, position: [0, 3, 0], look_at: [0, 0, 0]},"
                   " {type: directional, direction: [0, -1, 0]}")
    assert [type(l) for l in loaded.graph.lights] == [PointLight, SpotLight, DirectionalLight]
    assert loads(HEAD).graph.lights == []


@pytest.mark.parametrize("light, message", [
    ("{type: point, position: [0, 1, 0], intensity: 2, power: 3}", "lights[0].power: give either `intensity` or `power`, not both"),
    ("{type: spot, position: [0, 1, 0], look_at: [0, 0, 0], power: 3, intensity: 1}", "not both"),
    ("{type: spot, position: [0, 1, 0], direction: [0, 0, 0]}", "lights[0].direction: `direction` must not be the zero vector"),
    ("{type: directional, direction: [0, 0, 0]}", "lights[0].direction: `direction` must not be the zero vector"),
    ("{type: spot, position: [0, 1, 0], look_at: [0, 0, 0], cutoff_angle: 30, beam_width: 31}",
     "lights[0].beam_width: `beam_width` (31) must be at most `cutoff_angle` (30)"),
    ("{type: spot, position: [0, 1, 0], look_at: [0, 1, 0]}", "`look_at` is the spot's `position`"),
    ("{type: spot, position: [0, 1, 0]}", "give `look_at` or `direction`"),
    ("{type: spot, position: [0, 1, 0], look_at: [0, 0, 0], direction: [0, -1, 0]}", "not both"),
    ("{type: spot, position: [0, 1, 0], look_at: [0, 0, 0], cutoff_angle: 91}", "lights[0].cutoff_angle"),
    ("{type: spot, position: [0, 1, 0], look_at: [0, 0, 0], cutoff_angle: 0}", "lights[0].cutoff_angle"),
    ("{type: point, position: [0, 1, 0], power: [1, 2, 3], temperature: 3000}", "with a temperature, `power` is a number"),
    ("{type: directional, direction: [0, -1, 0], irradiance: [1, 1, 2], temperature: 3000}", "`irradiance` is a number"),
    ("{type: point, position: [0, 1, 0], temperature: 500}", "lights[0].temperature"),
    ("{type: point, position: [0, 1, 0], intensity: -2}", "expected a number >= 0"),
    ("{type: point, position: [0, 1, 0], intensity: [1, -1, 0]}", "lights[0].intensity"),
    ("{type: point, position: [0, 1, 0], intensity: yes}", "expected a number >= 0 or a colour"),
    ("{type: point, position: [0, 1, 0], radius: -1}", "lights[0].radius"),
    ("{type: point}", "lights[0].position"),
    ("{type: point, position: [0, 1, 0], colour: 1}", "unknown key 'colour'"),
    ("{type: lamp, position: [0, 1, 0]}", "unknown type 'lamp'"),
])
def test_bad_input_is_one_clear_error_at_its_key(light, message):
    text = errors(light)
    assert message in text, text
    assert "Traceback" not in text and text.count("error:") == 1


def test_a_point_lights_power_is_four_pi_intensity():
    light = PointLight(position=(0, 0, 0), power=100.0)
    assert light.intensity_rgb() == pytest.approx((100 / (4 * math.pi),) * 3, rel=1e-15)
    assert light.flux() == pytest.approx(100.0, rel=1e-12)
    assert PointLight(position=(0, 0, 0)).intensity_rgb() == (1.0, 1.0, 1.0)
    coloured = PointLight(position=(0, 0, 0), power=(4 * math.pi, 0, 8 * math.pi))
    assert coloured.intensity_rgb() == pytest.approx((1.0, 0.0, 2.0), rel=1e-15)


def test_a_temperature_gives_the_colour_and_the_number_its_luminance():
    light = PointLight(position=(0, 0, 0), intensity=5.0, temperature=2700)
    assert light.intensity_rgb() == pytest.approx(tuple(5 * c for c in temperature_rgb(2700)), rel=1e-15)
    assert luminance(light.intensity_rgb()) == pytest.approx(5.0, rel=1e-12)
    sun = DirectionalLight(direction=(0, -1, 0), irradiance=3.0, temperature=5800)
    assert luminance(sun.irradiance_rgb()) == pytest.approx(3.0, rel=1e-12)
    assert sun.toward_light() == (0.0, 1.0, 0.0)


def profile_integral(cutoff_deg, beam_deg, n=100_000):
    """The spot profile integrated over the sphere by the midpoint rule in theta, on the beam and
    on the ramp apart (the profile has a kink between them)."""
    c, b = math.radians(cutoff_deg), math.radians(beam_deg)
    total = 0.0
    for lo, hi in ((0.0, b), (b, c)):
        step = (hi - lo) / n
        for k in range(n):
            t = lo + (k + 0.5) * step
            f = 1.0 if t <= b else (c - t) / (c - b)
            total += f * math.sin(t) * step
    return 2 * math.pi * total


@pytest.mark.parametrize("cutoff, beam", [(20, 15), (45, 10), (90, 60), (30, 30), (30, 29.9999), (1, 0.5), (90, 1e-3)])
def test_the_spots_solid_angle_is_its_profiles_integral(cutoff, beam):
    assert spot_solid_angle(cutoff, beam) == pytest.approx(profile_integral(cutoff, beam), rel=1e-8)


def test_a_spots_power_spreads_over_its_profile():
    spot = SpotLight(position=(0, 0, 0), direction=(0, 0, -2), power=50.0, cutoff_angle=40)
    assert spot.beam == 30.0  # 3/4 of the cutoff by default, as Mitsuba's
    assert spot.axis() == (0.0, 0.0, -1.0)
    assert spot.intensity_rgb()[0] * spot.solid_angle() == pytest.approx(50.0, rel=1e-12)
    assert spot.flux() == pytest.approx(50.0, rel=1e-12)
    hard = SpotLight(position=(0, 0, 0), direction=(0, 0, -1), power=1.0, cutoff_angle=30, beam_width=30)
    assert hard.solid_angle() == pytest.approx(2 * math.pi * (1 - math.cos(math.radians(30))), rel=1e-12)


def test_a_directional_lights_flux_is_the_disc_of_the_scene():
    light = DirectionalLight(direction=(1, -1, 0), irradiance=(2.0, 2.0, 2.0))
    assert light.flux(3.0) == pytest.approx(math.pi * 9 * 2.0, rel=1e-12)
    assert light.toward_light() == pytest.approx((-math.sqrt(0.5), math.sqrt(0.5), 0.0), rel=1e-15)


def test_a_diffuse_light_takes_a_temperature_with_a_grey_emit():
    loaded = loads("materials: {warm: {type: diffuse_light, emit: [4, 4, 4], temperature: 3000}}\n"
                   "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: warm}]\n")
    colour = loaded.graph.materials[0].textures["emit"].model.color
    assert colour == pytest.approx(tuple(4 * c for c in temperature_rgb(3000)), rel=1e-15)
    with pytest.raises(SceneError, match="materials.warm.emit: with a temperature, `emit` is grey"):
        loads("materials: {warm: {type: diffuse_light, emit: [4, 3, 4], temperature: 3000}}\n"
              "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: warm}]\n")


def test_the_json_schema_has_every_light():
    schema = json.loads((ROOT / "schemas" / "scene.schema.json").read_text())
    text = json.dumps(schema)
    for name in ("PointLight", "SpotLight", "DirectionalLight"):
        assert name in schema["definitions"], name
    assert "lights" in schema["properties"]
    assert "cutoff_angle" in text and "beam_width" in text and "irradiance" in text
    assert "temperature" in json.dumps(schema["definitions"]["DiffuseLight"])
