"""Motion of transforms and of the camera, rendered: a quad sliding across the frame against the
analytic blur of its edge, a still transform written as motion renders bit for bit as the still
one, a moving camera as the scene moving the other way, a moving light sampled at the path's
time, and one thread as two."""

import math
import subprocess
import sys

import numpy as np
import pytest

from renderer import target
from renderer.compile import compile_scene
from renderer.render import render
from renderer.variants import features_of
from scenefmt.validation import loads

pytestmark = pytest.mark.slow

# A black quad, far taller than the frame, slides right by SLIDE over the shutter in front of a
# white background, on the camera's focus plane (z = 0); the camera looks down -z from z = 10.
WIDTH, HEIGHT, SPP = 48, 12, 96
SLIDE = 4.0
SLIDING_QUAD = f"""
camera: {{look_from: [0, 0, 10], look_at: [0, 0, 0], vfov: 20}}
image: {{width: {WIDTH}, height: {HEIGHT}, samples_per_pixel: {SPP}, max_depth: 2, seed: 3}}
background: [1, 1, 1]
materials:
  black: {{type: lambertian, albedo: [0, 0, 0]}}
shapes:
  - type: quad
    q: [-1, -50, 0]
    u: [100, 0, 0]
    v: [0, 100, 0]
    material: black
    motion:
      - {{time: 0}}
      - {{time: 1, transform: [{{translate: [{SLIDE}, 0, 0]}}]}}
"""


def film_of(text, **options):
    graph = loads(text).graph
    return render(graph, kernel="general", **options).film


def test_a_quad_sliding_across_the_frame_blurs_its_edge_as_the_analytic_ramp():
    """A point at x in [x0, x0 + SLIDE] is covered for the fraction (x - x0) / SLIDE of the
    shutter, so the white it shows falls linearly across the band swept by the edge: each
    column's mean against that ramp averaged over the column's pixels, within 4.5 standard errors
    of the column's samples (Bernoulli draws)."""
    film = film_of(SLIDING_QUAD)
    image = film.mean()[:, :, 0]
    # The focus plane at the look-at distance (10): a pixel spans du on it.
    viewport_h = 2.0 * math.tan(math.radians(20) / 2.0) * 10.0
    du = viewport_h * (WIDTH / HEIGHT) / WIDTH
    fine = 200  # points across a pixel: the pixel's jitter averages the ramp over its width
    expected = np.empty(WIDTH)
    for i in range(WIDTH):
        x = (-WIDTH / 2 + i + (np.arange(fine) + 0.5) / fine) * du
        expected[i] = np.mean(1.0 - np.clip((x - (-1.0)) / SLIDE, 0.0, 1.0))
    measured = image.mean(axis=0)
    p = np.clip(expected, 1e-3, 1 - 1e-3)
    se = np.sqrt(p * (1 - p) / (HEIGHT * SPP))
    z = (measured - expected) / se
    assert np.abs(z).max() < 4.5, np.round(z, 1)
    band = (expected > 0.05) & (expected < 0.95)
    assert band.sum() >= 10  # the ramp spans many columns, so a wrong slope would show
    assert np.isfinite(film.total).all()


STILL = """
camera: {look_from: [0, 1, 6], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 16, height: 12, samples_per_pixel: 4, max_depth: 6, seed: 9}
background: {type: sky}
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
  lamp: {type: diffuse_light, emit: [4, 4, 4]}
groups:
  pair:
    shapes:
      - {type: box, min: [-0.3, 0, -0.3], max: [0.3, 0.6, 0.3], material: white}
      - {type: sphere, center: [0, 0.9, 0], radius: 0.3, material: white}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: white}
  - {type: quad, q: [-0.5, 2.5, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp, PLACE_A}
  - {type: instance, group: pair, PLACE_B}
"""
A = "[{rotate: {axis: [1, 1, 0], degrees: 30}}, {translate: [0.2, 0, 0]}]"
B = "[{scale: [1, 1.5, 1]}, {rotate: {axis: y, degrees: 40}}, {translate: [-1, 0, 0]}]"


def test_a_still_transform_written_as_motion_renders_bit_for_bit_as_the_still_one():
    still = STILL.replace("PLACE_A", f"transform: {A}").replace("PLACE_B", f"transform: {B}")
    keyed = STILL.replace("PLACE_A", f"motion: [{{time: 0, transform: {A}}}, {{time: 1, transform: {A}}}]").replace(
        "PLACE_B", f"motion: [{{time: 0, transform: {B}}}, {{time: 0.5, transform: {B}}}, {{time: 1, transform: {B}}}]")
    assert features_of(loads(keyed).graph) == features_of(loads(still).graph)
    assert not features_of(loads(keyed).graph).motion
    flat = compile_scene(loads(keyed).graph)
    assert flat.motion_f.shape[0] == 0
    a, b = film_of(still), film_of(keyed)
    assert a.total.sum() > 0
    assert np.array_equal(a.total, b.total) and np.array_equal(a.total_sq, b.total_sq)


ROOM = """
camera: {look_from: [0, 1, 6], look_at: [0, 0.8, 0], vfov: 40CAMERA_MOTION}
image: {width: 24, height: 16, samples_per_pixel: 32, max_depth: 4, seed: 4}
background: [0.2, 0.25, 0.3]
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
  red: {type: lambertian, albedo: [0.8, 0.1, 0.1]}
  lamp: {type: diffuse_light, emit: [6, 6, 6]}
groups:
  world:
    shapes:
      - {type: quad, q: [-4, 0, -3], u: [8, 0, 0], v: [0, 0, 6], material: white}
      - {type: box, min: [-0.8, 0, -0.5], max: [0, 1.2, 0.3], material: red}
      - {type: sphere, center: [0.8, 0.5, 0], radius: 0.5, material: white}
      - {type: quad, q: [-0.5, 2.5, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp}
shapes:
  - {type: instance, group: world SCENE_MOTION}
"""


def regions_agree(a, b, block=4, z_max=4.5):
    """Means of block x block regions of two films within z_max combined standard errors."""
    h, w = a.total.shape[:2]
    worst = 0.0
    for y in range(0, h, block):
        for x in range(0, w, block):
            ma, mb = a.mean()[y:y + block, x:x + block].mean(axis=(0, 1)), b.mean()[y:y + block, x:x + block].mean(axis=(0, 1))
            va = a.mean_variance()[y:y + block, x:x + block].sum(axis=(0, 1)) / block ** 4
            vb = b.mean_variance()[y:y + block, x:x + block].sum(axis=(0, 1)) / block ** 4
            z = np.abs(ma - mb) / np.sqrt(va + vb + 1e-12)
            worst = max(worst, float(z.max()))
    assert worst < z_max, worst


def test_a_camera_moving_renders_as_the_scene_moving_the_other_way():
    """The camera slides 0.6 to the right and turns 0 degrees; the scene slides 0.6 to the left:
    every ray meets the same surfaces at the same places, so the images agree region by region
    (and nearly pixel by pixel: the same random numbers drive both)."""
    camera = ROOM.replace("CAMERA_MOTION", ", motion: [{time: 0}, {time: 1, look_from: [0.6, 1, 6], look_at: [0.6, 0.8, 0]}]")
    camera = camera.replace("SCENE_MOTION", "")
    scene = ROOM.replace("CAMERA_MOTION", "").replace(
        "SCENE_MOTION", ", motion: [{time: 0}, {time: 1, transform: [{translate: [-0.6, 0, 0]}]}]")
    a, b = film_of(camera), film_of(scene)
    regions_agree(a, b)
    close = np.isclose(a.total, b.total, rtol=1e-6, atol=1e-9).mean()
    assert close > 0.9, close
    # And it is blurred: the same camera standing still renders something else.
    still = film_of(ROOM.replace("CAMERA_MOTION", "").replace("SCENE_MOTION", ""))
    assert np.abs(still.mean() - a.mean()).max() > 0.1


MOVING_LAMP = ROOM.replace("CAMERA_MOTION", "").replace("SCENE_MOTION", "").replace(
    "      - {type: quad, q: [-0.5, 2.5, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp}\n", "").replace(
    "shapes:\n  - {type: instance", "shapes:\n  - {type: quad, q: [-0.5, 2.5, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp, "
    "motion: [{time: 0, transform: [{translate: [-1.5, 0, 0]}]}, {time: 1, transform: [{rotate: {axis: z, degrees: 30}}, "
    "{translate: [1.5, -0.5, 0]}]}]}\n  - {type: instance")


def test_a_moving_light_is_sampled_where_it_is_at_the_paths_time():
    """Light sampling (mis) finds the moving lamp where the path's time puts it, with the density
    the hits are weighed by: it converges to the books' estimator (path), which finds it only by
    chance, region by region."""
    assert features_of(loads(MOVING_LAMP).graph).motion
    mis = film_of(MOVING_LAMP, samples=64)
    path = film_of(MOVING_LAMP.replace("seed: 4}", "seed: 4, integrator: path}"), samples=256)
    assert mis.mean().mean() > 0.05
    regions_agree(mis, path)


def test_a_lamp_stretched_as_it_moves_is_sampled_by_area_not_by_its_cone():
    """A spherical lamp that is round when the shutter opens and stretched when it closes is no
    sphere in between: its light samples are drawn by area (a cone would be biased), and mis
    still converges to the books' estimator."""
    lamp = ("  - {type: sphere, center: [0, 0, 0], radius: 0.3, material: lamp, motion: [{time: 0, transform: "
            "[{translate: [-1, 2.2, 0]}]}, {time: 1, transform: [{scale: [2.5, 0.5, 1]}, {translate: [1, 2.0, 0]}]}]}\n")
    text = MOVING_LAMP.replace("shapes:\n  - {type: quad, q: [-0.5, 2.5, -0.5]", "shapes:\n" + lamp + "  - {type: quad, q: [-0.5, 2.5, -0.5]", 1)
    flat = compile_scene(loads(text).graph)
    from renderer.light_table import BY_AREA, LIGHT_PRIMITIVE, LIGHT_STRATEGY
    from renderer.shapes import PRIM_KIND, SPHERE

    spheres = flat.prims_i[flat.light_i[:, LIGHT_PRIMITIVE], PRIM_KIND] == SPHERE
    assert spheres.sum() == 1 and flat.light_i[spheres, LIGHT_STRATEGY][0] == BY_AREA
    mis = film_of(text, samples=64)
    path = film_of(text.replace("seed: 4}", "seed: 4, integrator: path}"), samples=256)
    regions_agree(mis, path)


def test_moving_lights_chosen_by_a_light_tree_are_bounded_over_their_motion():
    """Eight small lamps, each sliding and turning over the shutter (a light tree chooses among
    eight: its boxes must hold each lamp's whole motion and its cones any normal, or a lamp
    would be left out where it is): mis against the books' estimator, region by region."""
    lamps = "".join(
        f"  - {{type: quad, q: [{-2 + 0.5 * k}, 2.2, -0.3], u: [0.3, 0, 0], v: [0, 0, 0.3], material: lamp, "
        f"motion: [{{time: 0}}, {{time: 1, transform: [{{rotate: {{axis: z, degrees: {20 + 10 * k}}}}}, "
        f"{{translate: [{0.4 - 0.1 * k}, -0.3, 0]}}]}}]}}\n" for k in range(8))
    text = ROOM.replace("CAMERA_MOTION", "").replace("SCENE_MOTION", "").replace(
        "      - {type: quad, q: [-0.5, 2.5, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp}\n", "")
    text = text.replace("shapes:\n  - {type: instance", "shapes:\n" + lamps + "  - {type: instance")
    graph = loads(text).graph
    assert features_of(graph).light_tree and features_of(graph).motion
    mis = film_of(text, samples=64)
    path = film_of(text.replace("seed: 4}", "seed: 4, integrator: path}"), samples=256)
    assert mis.mean().mean() > 0.02
    regions_agree(mis, path)


def test_one_thread_renders_a_moving_scene_as_two():
    text = MOVING_LAMP.replace("CAMERA_MOTION", "")
    before = target.thread_count()
    try:
        films = []
        for threads in (1, 2):
            target.set_thread_count(min(threads, target.max_thread_count()))
            films.append(film_of(text, samples=4))
    finally:
        target.set_thread_count(before)
    assert np.array_equal(films[0].total, films[1].total)


def test_rt_validate_names_the_moving_element(tmp_path):
    path = tmp_path / "moving.yaml"
    path.write_text(MOVING_LAMP)
    out = subprocess.run([sys.executable, "-m", "rt", "validate", str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "motion blur: on (shapes[0] moves, shutter 0..1)" in out.stdout
    camera = tmp_path / "camera.yaml"
    camera.write_text(ROOM.replace("CAMERA_MOTION", ", motion: [{time: 0}, {time: 1, look_at: [1, 0.8, 0]}]").replace("SCENE_MOTION", ""))
    out = subprocess.run([sys.executable, "-m", "rt", "validate", str(camera)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "motion blur: on (camera moves, shutter 0..1)" in out.stdout
