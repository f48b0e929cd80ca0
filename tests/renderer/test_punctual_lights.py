"""Point, spot and directional lights (renderer/punctual.py) against closed forms.

- Their rows: the power each is chosen by (4 pi I, the spot's profile integral times I, pi R^2 E).
- `sample_li` at chosen points: inverse-square falloff, the spot's profile (Mitsuba 3's linear
  ramp in angle), parallel light, each exact to 1e-12; the density is the probability of the
  choice, the delta flag is set, and `pdf_li` is 0 for them.
- A point light with a radius: its directions are uniform in the cone the sphere subtends
  (chi-square), with the cone's density.
- Images: a lambertian sphere under a point light has radiance a/pi I cos / d^2 (max_depth 2:
  direct light only); a plane under parallel light a/pi E cos, exactly; a plane under a point
  light with a radius the same as under the point (a sphere above a surface's horizon lights it
  as a point does), within the noise of its cone samples.
- Linearity: a scene lit by an area light, a point, a spot and parallel light at once renders the
  sum of the four lit alone, within noise (each light's share of the samples is right).
- Which kernel: a scene with a light under `lights:` needs the punctual path, one without does not.
"""

import math

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.environment import scene_radius
from renderer.light_table import DIRECTIONAL_LIGHT, LIGHT_KIND, LIGHT_PMF, LIGHT_POWER, POINT_LIGHT, SPOT_LIGHT
from renderer.variants import features_of
from scenefmt import models as m
from scenefmt.graph import build_graph
from scenefmt.lights import spot_solid_angle
from scenefmt.validation import loads
from tests.renderer.stats import ALPHA, chi2_test, pixel_mean_and_se, z_limit

FAR = "materials: {white: {type: lambertian, albedo: [0.5, 0.5, 0.5]}}\n" \
      "shapes: [{type: quad, q: [-1, -10, -1], u: [2, 0, 0], v: [0, 0, 2], material: white}]\n"


def flat_with(lights: str):
    return compile_scene(loads(FAR + f"lights: [{lights}]\n").graph)


# --- which kernel, and the rows (no kernel compiled) -------------------------------------------


def test_a_light_under_lights_needs_the_punctual_path_and_none_does_not():
    assert features_of(loads(FAR + "lights: [{type: point, position: [0, 1, 0]}]\n").graph).punctual
    assert features_of(loads(FAR + "lights: [{type: directional, direction: [0, -1, 0]}]\n").graph).punctual
    assert not features_of(loads(FAR).graph).punctual
    # Without light sampling nothing finds them: the path is not compiled for them.
    assert not features_of(loads(FAR + "image: {integrator: path}\nlights: [{type: point, position: [0, 1, 0]}]\n").graph).punctual


def test_the_rows_carry_each_lights_power_and_are_chosen_by_it():
    flat = flat_with("{type: point, position: [0, 1, 0], intensity: [1, 2, 3]},"
                     " {type: spot, position: [0, 2, 0], direction: [0, -1, 0], intensity: 4, cutoff_angle: 30, beam_width: 20},"
                     " {type: directional, direction: [0, -1, 0], irradiance: 0.5},"
                     " {type: point, position: [0, 1, 0], intensity: 0}")
    kinds = flat.light_i[:, LIGHT_KIND].tolist()
    assert kinds == [POINT_LIGHT, SPOT_LIGHT, DIRECTIONAL_LIGHT]  # the dark one has no row
    lum = 0.2126 * 1 + 0.7152 * 2 + 0.0722 * 3
    radius = scene_radius(flat)  # the bounding box's half diagonal (the quad's 2 x 0 x 2, padded a little)
    assert radius == pytest.approx(math.sqrt(2), rel=1e-6)
    power = [4 * math.pi * lum, spot_solid_angle(30, 20) * 4, math.pi * radius ** 2 * 0.5]
    assert flat.light_f[:, LIGHT_POWER] == pytest.approx(power, rel=1e-12)
    assert flat.light_f[:, LIGHT_PMF] == pytest.approx(np.array(power) / sum(power), rel=1e-12)


# --- sample_li against closed forms -------------------------------------------------------------


@pytest.mark.slow
def test_a_point_lights_falloff_is_the_inverse_square_exactly():
    from tests.renderer.punctual_calls import li_at, pdf_li_of

    c = np.array([0.3, 2.0, -0.4])
    flat = flat_with("{type: point, position: [0.3, 2, -0.4], intensity: [3, 2, 1]}")
    points = np.array([[0, 0, 0], [1, 0.5, 2], [0.3, 1.9, -0.4], [-5, -3, 7], [0.3, 2.0, -0.4]], np.float64)
    out = li_at(flat, points, 1, 3)
    for row in out:
        p = points[int(row[0])]
        to = c - p
        d = np.linalg.norm(to)
        if d == 0.0:
            assert row[1] == 0.0  # at the light itself: nothing drawn
            continue
        assert row[1] == 1.0 and row[13] == 1.0  # ok, a delta
        assert row[2:5] == pytest.approx(c, abs=0)
        assert row[5:8] == pytest.approx(to / d, rel=1e-12, abs=1e-15)
        assert row[8] == pytest.approx(d, rel=1e-12) and row[9] == 1.0  # the only light: chosen with probability 1
        assert row[10:13] == pytest.approx(np.array([3, 2, 1]) / d ** 2, rel=1e-12)
        assert pdf_li_of(flat, 0, p, c) == 0.0


SPOT = "{type: spot, position: [0, 2, 0], direction: [0, -1, 0], intensity: [5, 4, 3], cutoff_angle: 30, beam_width: 20}"


def mitsuba_profile(theta_deg, cutoff=30.0, beam=20.0):
    """Mitsuba 3's spot profile, written here from its documentation: 1 within the beam, linear in
    angle to 0 at the cutoff."""
    if theta_deg <= beam:
        return 1.0
    if theta_deg >= cutoff:
        return 0.0
    return (cutoff - theta_deg) / (cutoff - beam)


@pytest.mark.slow
def test_a_spots_profile_is_mitsubas_exactly():
    from tests.renderer.punctual_calls import li_at, pdf_li_of

    flat = flat_with(SPOT)
    c = np.array([0.0, 2.0, 0.0])
    angles = [0.0, 5.0, 19.9, 20.0, 20.1, 25.0, 29.9, 30.1, 45.0, 120.0]
    dists = [0.5, 1.0, 3.0]
    points, expected = [], []
    for a in angles:
        for k, r in enumerate(dists):
            phi = 0.7 + 2.1 * k
            d = np.array([math.sin(math.radians(a)) * math.cos(phi), -math.cos(math.radians(a)), math.sin(math.radians(a)) * math.sin(phi)])
            points.append(c + r * d)
            expected.append((a, r))
    points = np.array(points)
    out = li_at(flat, points, 2, 1)
    for row, (a, r) in zip(out, expected):
        f = mitsuba_profile(a)
        if f == 0.0:
            assert row[1] == 0.0  # outside the cone nothing arrives and no shadow ray is cast
            continue
        assert row[1] == 1.0 and row[13] == 1.0 and row[9] == 1.0
        assert row[8] == pytest.approx(r, rel=1e-12)
        assert row[10:13] == pytest.approx(np.array([5, 4, 3]) * f / r ** 2, rel=1e-12, abs=1e-14), (a, r)
    assert pdf_li_of(flat, 0, points[0], c) == 0.0


@pytest.mark.slow
def test_parallel_light_arrives_from_its_direction_at_infinity():
    from tests.renderer.punctual_calls import li_at, pdf_li_of

    flat = flat_with("{type: directional, direction: [1, -2, 0.5], irradiance: [2, 3, 4]}")
    toward = -np.array([1, -2, 0.5]) / np.linalg.norm([1, -2, 0.5])
    out = li_at(flat, np.array([[0.0, 0, 0], [3, -1, 2]]), 3, 2)
    assert (out[:, 1] == 1.0).all() and (out[:, 13] == 1.0).all() and (out[:, 9] == 1.0).all()
    assert np.isinf(out[:, 8]).all()
    assert out[:, 5:8] == pytest.approx(np.tile(toward, (4, 1)), rel=1e-15, abs=1e-16)
    assert out[:, 10:13] == pytest.approx(np.tile([2, 3, 4], (4, 1)), rel=0, abs=0)
    assert pdf_li_of(flat, 0, np.zeros(3), toward) == 0.0


@pytest.mark.slow
def test_among_several_lights_each_is_drawn_with_its_power_share():
    from tests.renderer.punctual_calls import li_at

    flat = flat_with("{type: point, position: [0, 1, 0], intensity: 2}, " + SPOT + ", {type: directional, direction: [0, -1, 0]}")
    pmf = flat.light_f[:, LIGHT_PMF]
    n = 6000
    out = li_at(flat, np.array([[0.1, 0.0, 0.2]]), 4, n)
    which = np.where(np.isinf(out[:, 8]), 2, np.where(out[:, 3] == 1.0, 0, 1))  # the point sits at y = 1, the spot at 2
    for k in range(3):
        assert out[which == k, 9] == pytest.approx(pmf[k], rel=1e-12)
    counts = np.bincount(which, minlength=3)
    p, _ = chi2_test(counts, pmf)
    assert p > ALPHA, (counts, pmf * n)


@pytest.mark.slow
def test_a_point_light_with_a_radius_is_drawn_uniformly_in_its_cone():
    from tests.renderer.punctual_calls import li_at

    c, r, i = np.array([0.0, 3.0, 0.0]), 0.8, 6.0
    flat = flat_with(f"{{type: point, position: [0, 3, 0], radius: {r}, intensity: {i}}}")
    p = np.array([0.5, 0.0, 0.3])
    n = 40_000
    out = li_at(flat, p[None, :], 5, n)
    assert (out[:, 1] == 1.0).all() and (out[:, 13] == 1.0).all()  # no BSDF ray meets it: a delta for MIS
    to = c - p
    dist = np.linalg.norm(to)
    axis = to / dist
    one_minus_max = 1 - math.sqrt(1 - (r / dist) ** 2)
    assert out[:, 9] == pytest.approx(1 / (2 * math.pi * one_minus_max), rel=1e-9)
    assert out[:, 10:13] == pytest.approx(np.full((n, 3), i / (math.pi * r * r)), rel=1e-14)
    x = out[:, 2:5]
    assert np.abs(np.linalg.norm(x - c, axis=1) - r) == pytest.approx(np.zeros(n), abs=1e-12)
    wi = out[:, 5:8]
    assert (x - p) / out[:, 8:9] == pytest.approx(wi, abs=1e-12)
    # Uniform in the cone: 1 - cos theta uniform in [0, 1 - cos theta_max], phi uniform about the axis.
    e1 = np.cross(axis, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    a = np.clip((1 - wi @ axis) / one_minus_max, 0, 1 - 1e-12)
    b = (np.arctan2(wi @ e2, wi @ e1) + np.pi) / (2 * np.pi)
    k = 12
    cells = np.minimum((a * k).astype(int), k - 1) * k + np.minimum((b * k).astype(int), k - 1)
    pvalue, _ = chi2_test(np.bincount(cells, minlength=k * k), np.full(k * k, 1.0 / (k * k)))
    assert pvalue > ALPHA
    # From inside its sphere it is a point at its centre.
    inside = li_at(flat, np.array([[0.0, 3.3, 0.0]]), 6, 2)
    assert inside[:, 2:5] == pytest.approx(np.tile(c, (2, 1)), abs=0) and inside[:, 9] == pytest.approx([1.0, 1.0])
    assert inside[:, 10] == pytest.approx(i / 0.09, rel=1e-12)


# --- images against closed forms ---------------------------------------------------------------


def render_of(shapes, lights, *, look_from, look_at, vfov=40.0, width=20, samples=32, seed=3, max_depth=2):
    from renderer.render import render
    from renderer.variants import GENERAL

    sc = m.Scene(camera=m.Camera(look_from=look_from, look_at=look_at, vfov=vfov),
                 image=m.Image(width=width, height=width, samples_per_pixel=samples, max_depth=max_depth, seed=seed),
                 background=m.SolidBackground(color=(0.0, 0.0, 0.0)), shapes=list(shapes), lights=list(lights))
    return sc, render(build_graph(sc), features=GENERAL).film


def first_hits(sc, sub=8):
    """Per pixel: camera ray origins and unit directions on a sub x sub grid (tests/renderer/scenes.py)."""
    from tests.renderer.scenes import pixel_rays

    return pixel_rays(sc, sub=sub)


def summed_z(film, reference, mask, channel=0):
    """z of the summed difference between the film's pixel means and `reference` over `mask`."""
    mean, se = pixel_mean_and_se(film, channel)
    diff = (mean - reference)[mask].sum()
    return diff / math.sqrt((se[mask] ** 2).sum())


@pytest.mark.slow
def test_a_sphere_under_a_point_light_shows_its_analytic_irradiance():
    albedo, intensity, light = 0.6, 40.0, np.array([2.0, 3.0, 2.0])
    sphere = m.Sphere(center=(0, 0, 0), radius=1.0, material=m.Lambertian(albedo=(albedo,) * 3))
    sc, film = render_of([sphere], [m.PointLight(position=tuple(light), intensity=intensity)],
                         look_from=(0.0, 0.5, 4.0), look_at=(0.0, 0.0, 0.0), vfov=30.0)
    origin, d = first_hits(sc)
    # Ray-sphere: |o + t d|^2 = 1 (unit sphere at the origin).
    b = d @ origin
    disc = b * b - (origin @ origin - 1.0)
    inside = (disc > 0).all(axis=-1)  # pixels wholly on the sphere
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    x = origin + t[..., None] * d
    to = light - x
    dist2 = (to * to).sum(-1)
    cos = np.maximum(0.0, (x * to).sum(-1) / np.sqrt(dist2))
    reference = (albedo / math.pi * intensity * cos / dist2).mean(axis=-1)
    assert inside.sum() >= 60 and reference[inside].mean() > 0.1
    z = summed_z(film, reference, inside)
    assert abs(z) < z_limit(1), z
    mean, _ = pixel_mean_and_se(film, 0)
    assert np.abs(mean[inside] - reference[inside]).max() < 0.05 * reference[inside].max()


@pytest.mark.slow
def test_a_plane_under_parallel_light_has_radiance_a_over_pi_e_cos_exactly():
    albedo, e, direction = 0.5, 3.0, np.array([1.0, -2.0, 0.5])
    plane = m.Quad(q=(-50, 0, -50), u=(100, 0, 0), v=(0, 0, 100), material=m.Lambertian(albedo=(albedo,) * 3))
    _, film = render_of([plane], [m.DirectionalLight(direction=tuple(direction), irradiance=e)],
                        look_from=(0.0, 4.0, 3.0), look_at=(0.0, 0.0, 0.0), samples=4)
    cos = 2.0 / np.linalg.norm(direction)
    assert film.mean() == pytest.approx(np.full(film.mean().shape, albedo / math.pi * e * cos), rel=1e-6)


@pytest.mark.slow
def test_a_point_light_with_a_radius_lights_a_plane_as_the_point_does():
    """A sphere of radiance L = I / (pi r^2) wholly above a surface's horizon gives it the irradiance
    pi L (r/d)^2 cos = I cos / d^2: the point's, whatever the radius."""
    albedo, intensity, c = 0.7, 5.0, np.array([0.0, 1.5, 0.0])
    plane = m.Quad(q=(-50, 0, -50), u=(100, 0, 0), v=(0, 0, 100), material=m.Lambertian(albedo=(albedo,) * 3))
    sc, film = render_of([plane], [m.PointLight(position=tuple(c), intensity=intensity, radius=0.5)],
                         look_from=(0.0, 5.0, 3.0), look_at=(0.0, 0.0, 0.0), samples=64)
    origin, d = first_hits(sc)
    t = -origin[1] / d[..., 1]
    x = origin + t[..., None] * d
    to = c - x
    dist2 = (to * to).sum(-1)
    reference = (albedo / math.pi * intensity * to[..., 1] / np.sqrt(dist2) / dist2).mean(axis=-1)
    every = np.ones(reference.shape, bool)
    mean, se = pixel_mean_and_se(film, 0)
    assert (se > 0).mean() > 0.9  # the cone's samples make noise: this is not the point's image by accident
    assert abs(summed_z(film, reference, every)) < z_limit(1)
    assert (np.abs(mean - reference) / np.maximum(se, 1e-12)).max() < z_limit(reference.size)


@pytest.mark.slow
def test_lights_of_every_kind_together_render_the_sum_of_each_alone():
    white = m.Lambertian(albedo=(0.7, 0.7, 0.7))
    shapes = [m.Quad(q=(-2, 0, -2), u=(4, 0, 0), v=(0, 0, 4), material=white),
              m.Quad(q=(-2, 0, -2), u=(4, 0, 0), v=(0, 3, 0), material=white),
              m.Sphere(center=(0.3, 0.6, 0.2), radius=0.6, material=white)]
    lamp = m.Quad(q=(-1.5, 2.5, -1.0), u=(0.6, 0, 0), v=(0, 0, 0.6), material=m.DiffuseLight(emit=(6.0, 6.0, 6.0)))
    lights = [m.PointLight(position=(-1.0, 1.8, 1.0), intensity=(2.0, 1.0, 0.5)),
              m.SpotLight(position=(1.2, 2.5, 0.8), look_at=(0.5, 0.0, 0.0), power=30.0, temperature=3000, cutoff_angle=35),
              m.DirectionalLight(direction=(0.3, -1.0, -0.6), irradiance=(0.4, 0.5, 0.7))]
    view = dict(look_from=(0.0, 1.5, 4.5), look_at=(0.0, 0.8, 0.0), width=16, samples=48, max_depth=4)
    _, together = render_of(shapes + [lamp], lights, seed=11, **view)
    alone = [render_of(shapes + [lamp], [], seed=12, **view)[1]]
    alone += [render_of(shapes, [light], seed=13 + k, **view)[1] for k, light in enumerate(lights)]
    for channel in range(3):
        mean, se = pixel_mean_and_se(together, channel)
        total, var = mean.copy(), se ** 2
        for film in alone:
            mk, sk = pixel_mean_and_se(film, channel)
            total -= mk
            var += sk ** 2
        z = total.sum() / math.sqrt(var.sum())
        assert abs(z) < z_limit(3), (channel, z)
        assert pixel_mean_and_se(together, channel)[0].mean() > 0.05
