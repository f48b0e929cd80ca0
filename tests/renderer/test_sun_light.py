"""The sun of a `sun_sky` background as a light: its sampler against its density, the density the
integrator's other questions give for the same direction, the irradiance it sends a level
surface against the closed form, and multiple importance sampling under sun and sky against the
books' estimator.

- Directions drawn by `sample_li` from a scene whose only light is the sun are binned by
  (1 - cos theta) / (1 - cos alpha) and phi about the sun's axis: uniform in the cone means
  uniform in both (chi-square), and nothing falls outside the cone. `pdf_li` gives every drawn
  direction the density `sample_li` reported, and so does `radiance_escaped` (read back from the
  weight it gives a BSDF density).
- A white lambertian plane under the sun alone renders a/pi x E per pixel with
  E = pi L sin^2(alpha) cos(theta_s): exact for a uniform cap wholly above the plane's horizon.
  The mean over the image is tested against it within 4 standard errors of the samples.
- Under sun and sky (a broad sun, 20 degrees across, so the books' estimator finds it often enough
  for its noise estimate to hold), `mis` and `path` agree block by block.
"""

import math

import numpy as np
import pytest

from renderer.compile import compile_scene, with_integrator
from renderer.lights import ENVIRONMENT_LIGHT, LIGHT_KIND, LIGHT_PMF, LIGHT_RADIANCE, LIGHT_SIZE, SUN_LIGHT
from renderer.background import BG_SUN
from renderer.render import render
from scenefmt.sky import direction
from scenefmt.validation import loads
from tests.renderer.kernel_calls import li_and_pdf_li, light_samples
from tests.renderer.stats import ALPHA, block_z, chi2_test, film_mean_and_se, z_limit

pytestmark = pytest.mark.slow

N = 40_000
BINS = 8


def scene(background: str, shapes: str, camera: str = "{look_from: [0, 0, 5], look_at: [0, 0, 0], vfov: 40}",
          image: str = "width: 8, aspect_ratio: 1") -> str:
    return (f"camera: {camera}\nimage: {{{image}}}\nbackground: {background}\n"
            "materials: {white: {type: lambertian, albedo: [0.8, 0.8, 0.8]}}\n"
            f"shapes: [{shapes}]\n")


def sun_alone(size: float, elevation: float = 40.0, azimuth: float = 150.0):
    # A small sphere far off to one side: nothing stands between the origin and the sun.
    text = scene(f"{{type: sun_sky, elevation: {elevation}, azimuth: {azimuth}, sky: false, sun_size: {size}}}",
                 "{type: sphere, center: [0, -30, 0], radius: 1, material: white}")
    return compile_scene(loads(text).graph)


def test_the_sun_is_one_row_named_by_the_background():
    flat = sun_alone(0.5332)
    assert list(flat.light_i[:, LIGHT_KIND]) == [SUN_LIGHT], "a black sky is no light; the sun is"
    assert int(flat.background[BG_SUN]) == 0
    assert flat.light_f[0, LIGHT_SIZE] == pytest.approx(math.cos(math.radians(0.2666)), abs=1e-12)
    with_sky = compile_scene(loads(scene("{type: sun_sky, elevation: 40, azimuth: 150}", "")).graph)
    assert list(with_sky.light_i[:, LIGHT_KIND]) == [ENVIRONMENT_LIGHT, SUN_LIGHT]
    assert int(with_sky.background[BG_SUN]) == 1
    no_sun = compile_scene(loads(scene("{type: sun_sky, elevation: 40, azimuth: 150, sun: false}", "")).graph)
    assert list(no_sun.light_i[:, LIGHT_KIND]) == [ENVIRONMENT_LIGHT] and no_sun.background[BG_SUN] == -1


@pytest.mark.parametrize("size", [0.5332, 12.0])
def test_sampled_directions_are_uniform_in_the_suns_cone(size):
    flat = sun_alone(size)
    axis = np.array(direction(40.0, 150.0))
    cos_max = math.cos(math.radians(size / 2))
    rows = light_samples(flat, np.zeros(3), 0.0, 7, N)
    assert rows[:, 0].all()
    wi = rows[:, 1:4]
    assert np.all(rows[:, 4] == np.inf)
    cos_t = wi @ axis
    assert np.all(cos_t >= cos_max - 1e-12), "a direction outside the disc"
    np.testing.assert_allclose(rows[:, 5], 1.0 / (2.0 * math.pi * (1.0 - cos_max)), rtol=1e-9)
    e1 = np.cross(axis, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = np.mod(np.arctan2(wi @ e2, wi @ e1), 2.0 * math.pi)
    s = np.clip((1.0 - cos_t) / (1.0 - cos_max), 0.0, 1.0 - 1e-12)
    cell = (s * BINS).astype(int) * BINS + (phi / (2.0 * math.pi) * BINS).astype(int)
    p, dof = chi2_test(np.bincount(cell, minlength=BINS * BINS), np.full(BINS * BINS, 1.0 / (BINS * BINS)))
    assert p > ALPHA, f"chi-square p = {p:.2e} ({dof} dof)"
    # The emitted radiance is the disc's.
    np.testing.assert_allclose(rows[:, 6:9], np.broadcast_to(flat.light_f[0, LIGHT_RADIANCE:LIGHT_RADIANCE + 3], (N, 3)))


def test_pdf_li_and_radiance_escaped_give_the_sampled_density():
    """Under sky and sun both: each draw's density from pdf_li (of the map's row or the sun's, as
    it drew them) agrees with what sample_li reported, and so does the density radiance_escaped
    weighs a sky draw by; under the sun alone, the one it weighs the disc by."""
    text = scene("{type: sun_sky, elevation: 25, azimuth: 300, sun_size: 3}", "")
    flat = compile_scene(loads(text).graph)
    axis = np.array(direction(25.0, 300.0))
    # The same keys as li_and_pdf_li's: the same draws, whose directions say which light gave them.
    rows = light_samples(flat, np.zeros(3), 0.0, 11, 4000)
    in_disc = rows[:, 1:4] @ axis >= flat.light_f[1, LIGHT_SIZE]
    # The sun's draws have its density, the choice included; the map's few draws of sky texels
    # within the disc (its glow) are the map's.
    choose = flat.light_f[0, LIGHT_PMF]
    sun_pdf = (1.0 - choose) / (2.0 * math.pi * (1.0 - flat.light_f[1, LIGHT_SIZE]))
    by_sun = in_disc & np.isclose(rows[:, 5], sun_pdf, rtol=1e-9)
    assert by_sun.sum() >= 0.99 * in_disc.sum()
    for row in (0, 1):  # li_and_pdf_li asks pdf_li of this row for every draw at infinity
        out = li_and_pdf_li(flat, np.zeros(3), 0.0, 11, 4000, row)
        ok = out[:, 0] == 1.0
        assert ok.mean() > 0.99
        mine = ok & (by_sun if flat.light_i[row, LIGHT_KIND] == SUN_LIGHT else ~in_disc)
        assert mine.sum() > 200
        np.testing.assert_allclose(out[mine, 3], out[mine, 2], rtol=1e-6)
        if row == 0:
            np.testing.assert_allclose(out[mine, 5], out[mine, 2], rtol=1e-6)
    alone = sun_alone(3.0, 25.0, 300.0)
    out = li_and_pdf_li(alone, np.zeros(3), 0.0, 11, 2000, 0)
    assert out[:, 0].all()
    np.testing.assert_allclose(out[:, 3], out[:, 2], rtol=1e-9)
    np.testing.assert_allclose(out[:, 5], out[:, 2], rtol=1e-6)


@pytest.mark.parametrize("elevation, size", [(35.0, 0.5332), (70.0, 4.0)])
def test_a_white_plane_under_the_sun_alone_receives_the_closed_form(elevation, size):
    albedo = 0.8
    text = scene(f"{{type: sun_sky, elevation: {elevation}, azimuth: 200, sky: false, sun_size: {size}}}",
                 "{type: quad, q: [-100, 0, -100], u: [200, 0, 0], v: [0, 0, 200], material: white}",
                 camera="{look_from: [0, 10, 0.001], look_at: [0, 0, 0], vfov: 20}",
                 image="width: 16, aspect_ratio: 1, samples_per_pixel: 16, max_depth: 2")
    graph = loads(text).graph
    flat = compile_scene(graph)
    radiance = flat.light_f[0, LIGHT_RADIANCE:LIGHT_RADIANCE + 3]
    alpha = math.radians(size / 2)
    irradiance = math.pi * radiance * math.sin(alpha) ** 2 * math.sin(math.radians(elevation))
    expected = albedo / math.pi * irradiance
    film = render(graph, kernel="general").film
    mean, se = film_mean_and_se(film)
    assert np.all(np.isfinite(film.total))
    assert np.all(np.abs(mean - expected) <= 4.0 * se + 1e-9 * expected), \
        f"mean {mean} against {expected}: {np.abs(mean - expected) / np.maximum(se, 1e-300)} standard errors"
    assert np.all(se < 0.01 * expected), "the sun's light samples should make this nearly noiseless"


def test_light_sampling_under_sun_and_sky_converges_to_the_books_estimator():
    shapes = ("{type: quad, q: [-3, -1, -3], u: [6, 0, 0], v: [0, 0, 6], material: white},"
              " {type: sphere, center: [-0.6, -0.2, 0], radius: 0.8, material: white},"
              " {type: sphere, center: [0.9, -0.4, 0.3], radius: 0.6, material: {type: metal, albedo: [0.9, 0.9, 0.9], fuzz: 0.3}}")
    text = scene("{type: sun_sky, elevation: 35, azimuth: 150, turbidity: 4, sun_size: 20}", shapes,
                 image="width: 24, aspect_ratio: 1, samples_per_pixel: 256, max_depth: 6")
    graph = loads(text).graph
    mis = render(graph, seed=1, kernel="general").film
    path = render(with_integrator(graph, "path"), seed=2, samples=1024, kernel="general").film
    assert np.all(np.isfinite(mis.total)) and np.all(np.isfinite(path.total))
    z = block_z(mis, path, 4)
    assert np.all(np.abs(z) <= z_limit(z.size)), f"largest |z| {np.abs(z).max():.2f}"
    # And the whole image: a bias of a few percent would show here.
    whole = block_z(mis, path, 24)
    assert np.all(np.abs(whole) <= z_limit(3)), f"whole-image z {whole.ravel()}"


def test_the_map_a_ray_looks_up_is_the_model_in_that_direction():
    """The sky as the kernels see it (environment_radiance's nearest texel) against the model
    evaluated in the same world direction: the map's orientation, its units and its ground. Texels
    are 0.7 degrees: directions at least 3 degrees from the horizon and the sun are compared, where
    the sky varies by at most 3% across a texel (2.9% measured, close to the horizon and the sun),
    and by 0.5% in the median (a map turned or mirrored would be off by tens of percent)."""
    from renderer import sky
    from scenefmt.sky import SunSkyBackground
    from tests.renderer.kernel_calls import environment_lookup

    bg = SunSkyBackground(elevation=25, azimuth=70, turbidity=4)
    flat = compile_scene(loads(scene("{type: sun_sky, elevation: 25, azimuth: 70, turbidity: 4}", "")).graph)
    rng = np.random.default_rng(5)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    s = np.array(direction(25.0, 70.0))
    keep = (np.abs(d[:, 1]) > math.sin(math.radians(3.0))) & (d @ s < math.cos(math.radians(3.0)))
    d = d[keep]
    looked_up = environment_lookup(flat, d)[:, :3]
    above = d[:, 1] > 0.0
    model = sky.radiance(d[above, 1], d[above] @ s, math.radians(25.0), 4.0, 0.3) * sky.MODEL_TO_UNITS
    np.testing.assert_allclose(looked_up[above], model, rtol=0.04)
    assert np.median(np.abs(looked_up[above] / model - 1.0)) < 0.005
    # Below the horizon, one colour: the lit ground.
    ground = looked_up[~above]
    np.testing.assert_allclose(ground, np.broadcast_to(ground[0], ground.shape), rtol=1e-6)
    assert 0.0 < ground[0, 1] < 0.3 / math.pi * 1.2
    assert bg.ground_albedo == 0.3
