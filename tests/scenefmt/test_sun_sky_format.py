"""The `sun_sky` background as a scene file states it: the two ways to place the sun, the errors
in one sentence, the solar position formula against the sun's known places, and the effects it
switches on (fast: no numpy-heavy renderer module is loaded)."""

import math

import pytest

from scenefmt.effects import summarize
from scenefmt.diagnostics import SceneError
from scenefmt.sky import SunSkyBackground, direction, solar_position
from scenefmt.validation import loads

SHAPES = "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: {type: lambertian}}]\n"


def graph_of(background: str, extra: str = ""):
    return loads(f"background: {background}\n{extra}{SHAPES}").graph


def error_of(background: str) -> str:
    with pytest.raises(SceneError) as caught:
        graph_of(background)
    return str(caught.value)


def test_elevation_and_azimuth_place_the_sun_by_compass_bearing():
    bg = graph_of("{type: sun_sky, elevation: 30, azimuth: 90}").background
    assert isinstance(bg, SunSkyBackground)
    d = bg.sun_direction()
    # East is +x; 30 degrees up.
    assert d == pytest.approx((math.cos(math.radians(30)), 0.5, 0.0), abs=1e-12)
    # North (0) is -z, where the default camera looks; south (180) is +z.
    assert direction(0.0, 0.0) == pytest.approx((0.0, 0.0, -1.0), abs=1e-12)
    assert direction(0.0, 180.0) == pytest.approx((0.0, 0.0, 1.0), abs=1e-12)
    assert (bg.turbidity, bg.sun, bg.sky, bg.strength, bg.sun_size) == (3.0, True, True, 1.0, 0.5332)


@pytest.mark.parametrize("background, words", [
    ("{type: sun_sky, elevation: 30}", "azimuth is missing"),
    ("{type: sun_sky}", "place the sun by elevation and azimuth, or by date and time"),
    ("{type: sun_sky, elevation: 30, azimuth: 0, date: '2024-06-21', time: '12:00'}", "not both"),
    ("{type: sun_sky, date: '2024-06-21'}", "time is missing"),
    ("{type: sun_sky, elevation: -2, azimuth: 0}", ">= 0"),
    ("{type: sun_sky, elevation: 30, azimuth: 0, turbidity: 12}", "<= 10"),
    ("{type: sun_sky, date: '2024-02-30', time: '12:00'}", "not a day of the calendar"),
    ("{type: sun_sky, date: '2024-06-21', time: '25:00'}", "not a time of day"),
    ("{type: sun_sky, date: '2024-12-21', time: '00:00', latitude: 50}", "below the horizon"),
])
def test_a_wrong_sun_is_one_sentence_naming_the_key(background, words):
    text = error_of(background)
    assert words in text
    assert "background" in text and "Traceback" not in text


def test_solar_noon_at_the_solstice_and_the_equinox():
    # At true solar noon the sun stands due south (north of the tropic), at 90 - latitude + declination.
    el, az = solar_position("2024-06-21", "12:00", 0.0, 52.5, 0.0)
    # 12:00 UTC at Greenwich is solar noon less the equation of time (-1.7 min): within a degree of south.
    assert el == pytest.approx(90.0 - 52.5 + 23.44, abs=0.05)
    assert az == pytest.approx(180.0, abs=1.0)
    # The March equinox on the equator: the sun passes within 2 degrees of the zenith.
    el, _ = solar_position("2024-03-20", "12:00", 0.0, 0.0, 0.0)
    assert el > 88.0
    # Berlin, June 21, 13:10 CEST (UTC+2, 13.4 E): NOAA's calculator gives 60.95 and 181.0.
    el, az = solar_position("2024-06-21", "13:10", 2.0, 52.52, 13.40)
    assert el == pytest.approx(60.94, abs=0.1)
    assert az == pytest.approx(181.0, abs=1.0)
    # Southern hemisphere at noon: the sun is due north.
    _, az = solar_position("2024-12-21", "12:00", 0.0, -60.0, 0.0)
    assert min(az, 360.0 - az) < 1.0


def test_morning_and_afternoon_mirror_about_noon():
    morning = solar_position("2024-06-21", "09:00", 0.0, 40.0, 0.0)
    afternoon = solar_position("2024-06-21", "15:00", 0.0, 40.0, 0.0)
    # The equation of time (-1.7 min) shifts noon by under half a degree of hour angle.
    assert morning[0] == pytest.approx(afternoon[0], abs=0.6)
    assert morning[1] + afternoon[1] == pytest.approx(360.0, abs=1.0)
    assert morning[1] < 180.0 < afternoon[1]


def test_date_and_time_give_the_direction_the_angles_give():
    bg = graph_of("{type: sun_sky, date: '2024-06-21', time: '15:00', latitude: 40}").background
    el, az = solar_position("2024-06-21", "15:00", 0.0, 40.0, 0.0)
    assert bg.sun_direction() == pytest.approx(direction(el, az), abs=1e-12)


def test_sun_sky_switches_on_the_map_and_the_sun():
    effects = summarize(graph_of("{type: sun_sky, elevation: 40, azimuth: 200}")).kernel_paths
    assert effects["environment"] and effects["punctual"]
    summary = summarize(graph_of("{type: sun_sky, elevation: 40, azimuth: 200}"))
    assert "sun_sky" in summary.effect("environment").reason and "sun" in summary.effect("punctual").reason
    # With path tracing the sun's disc is still met by rays that escape.
    effects = summarize(graph_of("{type: sun_sky, elevation: 40, azimuth: 200}", "image: {integrator: path}\n")).kernel_paths
    assert effects["environment"] and effects["punctual"]


def test_no_sun_no_punctual_and_other_backgrounds_neither():
    effects = summarize(graph_of("{type: sun_sky, elevation: 40, azimuth: 200, sun: false}")).kernel_paths
    assert effects["environment"] and not effects["punctual"]
    for background in ("[0.5, 0.7, 1.0]", "{type: sky}"):
        effects = summarize(graph_of(background)).kernel_paths
        assert not effects["environment"] and not effects["punctual"]


def test_the_light_listing_names_the_sky_and_the_sun():
    kinds = {k.kind: k for k in summarize(graph_of("{type: sun_sky, elevation: 40, azimuth: 200}")).lights}
    assert set(kinds) == {"environment", "sun"} and "sun_sky" in kinds["environment"].reason
    kinds = {k.kind for k in summarize(graph_of("{type: sun_sky, elevation: 40, azimuth: 200, sky: false}")).lights}
    assert kinds == {"sun"}
