"""Normal and bump maps in the compiled kernels and in renders (slow: they compile the kernels).

- A constant tilted normal map tilts the shading normal the path tracer uses by the map's
  angle, toward +u, on every shape family, through an instance and on an ellipsoid, from the
  front and from the back; the tangent is orthogonal to the normal, and dp/du, dp/dv follow
  each shape's (u, v) (`tests/renderer/shading_calls.py` makes the integrator's own calls).
- A bump map of a linear ramp tilts it by the arc tangent of the slope.
- A flat map renders the very bits of no map.
- A wild map (random texels, Z into the surface included) on a white lambertian in a white
  furnace gives finite pixels of at most 1: energy is never created.
- No light leaks through a normal-mapped wall: a lamp behind it leaves the side the camera sees
  black, with either integrator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.flat import Frame
from renderer.render import render_flat
from renderer.variants import GENERAL
from scenefmt.validation import load
from tests.renderer.shading_calls import DPDU, DPDV, FRONT, HIT, NORMAL, POINT, SHADING, TANGENT, UV, shading_at

pytestmark = pytest.mark.slow

ANGLE = math.radians(35.0)
TILTED = (0.5 + 0.5 * math.sin(ANGLE), 0.5, 0.5 + 0.5 * math.cos(ANGLE))


def write_png(path, rgb8):
    from PIL import Image

    Image.fromarray(np.asarray(rgb8, np.uint8), "RGB").save(path)


def scene_file(tmp_path, body, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(body)
    return load(path).graph


HEADER = """
camera: {look_from: [0, 0, 5], look_at: [0, 0, 0], vfov: 30}
image: {width: 16, height: 16, samples_per_pixel: 8, max_depth: 12, seed: 3}
"""

# Eight shapes along x, each about x = 6 k, all facing +z at z = 0 where they are flat.
SHAPES = """
groups:
  panel:
    shapes:
      - {type: quad, q: [-1, -1, 0], u: [2, 0, 0], v: [0, 2, 0], material: mapped}
shapes:
  - {type: quad, q: [-1, -1, 0], u: [2, 0, 0], v: [0, 2, 0], material: mapped}
  - {type: sphere, center: [6, 0, -1], radius: 1, material: mapped}
  - {type: mesh, file: tri.obj, material: mapped, transform: [{translate: [12, 0, 0]}]}
  - {type: instance, group: panel, transform: [{scale: [2, 0.5, 1]}, {rotate: {axis: y, degrees: 30}}, {translate: [18, 0, 0]}]}
  - {type: disk, center: [24, 0, 0], normal: [0, 0, 1], radius: 1, material: mapped}
  - {type: triangle, vertices: [[29, -1, 0], [31, -1, 0], [30, 1, 0]], material: mapped}
  - {type: box, min: [35, -1, -2], max: [37, 1, 0], material: mapped}
  - {type: sphere, center: [42, 0, -2], radius: 1, material: mapped, transform: [{scale: [1, 2, 1]}]}
"""
# Two triangles, the second with its texture coordinates mirrored (v runs the other way).
OBJ = """v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
vt 0.1 0.1
vt 0.9 0.2
vt 0.8 0.9
vt 0.2 0.1
f 1/1 2/2 3/3
f 1/4 3/3 4/2
"""
CENTRES = [0.0, 6.0, 12.0, 18.0, 24.0, 30.0, 36.0, 42.0]


def mapped_scene(tmp_path, material):
    (tmp_path / "tri.obj").write_text(OBJ)
    return scene_file(tmp_path, HEADER + "background: [1, 1, 1]\nmaterials:\n  mapped: " + material + "\n" + SHAPES)


def rays_at(centres, offsets, z=5.0):
    o = np.array([[c + dx, dy, z] for c in centres for dx, dy in offsets])
    d = np.tile([0.0, 0.0, -1.0 if z > 0 else 1.0], (len(o), 1))
    return o, d


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def test_a_tilted_normal_map_tilts_the_shading_normal_by_its_angle_toward_u_on_every_shape(tmp_path):
    flat = compile_scene(mapped_scene(tmp_path, "{type: lambertian, albedo: [0.5, 0.5, 0.5], normal_map: %s}" % list(TILTED)))
    offsets = [(0.13, 0.21), (-0.3, 0.1), (0.25, -0.35)]
    for z in (5.0, -5.0):  # from the front, and from behind (the maps bend the same surface)
        o, d = rays_at(CENTRES, offsets, z)
        s = shading_at(flat, o, d)
        assert (s[:, HIT] == 1.0).all()
        n = s[:, NORMAL]
        n_front = np.where((s[:, FRONT] == 1.0)[:, None], n, -n)
        shading, t = s[:, SHADING], s[:, TANGENT]
        assert np.isfinite(s).all()
        np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0, atol=1e-12)
        np.testing.assert_allclose(np.einsum("ij,ij->i", t, n), 0.0, atol=1e-12)
        # The tilt: cos a along the normal, sin a along +t (outward), both turned to the ray's side.
        side = np.where(s[:, FRONT] == 1.0, 1.0, -1.0)[:, None]
        np.testing.assert_allclose(shading, side * (math.cos(ANGLE) * n + math.sin(ANGLE) * t), atol=1e-12)
        angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", shading, n_front), -1, 1)))
        np.testing.assert_allclose(angle, 35.0, atol=1e-9)
        # t is dp/du in the normal's plane.
        dpdu = s[:, DPDU]
        along = dpdu - np.einsum("ij,ij->i", dpdu, n)[:, None] * n
        np.testing.assert_allclose(t, unit_rows(along), atol=1e-12)
        # From behind, the open shapes are hit on their back, the closed ones (spheres, box) on their front.
        closed = np.repeat([False, True, False, False, False, False, True, True], len(offsets))
        assert (s[:, FRONT] == np.where(closed | (z > 0), 1.0, 0.0)).all()


def test_dp_du_and_dp_dv_follow_each_shapes_uv_in_the_world(tmp_path):
    """Rays a small step apart: the points differ by dp/du du + dp/dv dv to first order (so dp/du
    points the way u grows), on every family, through the instance's non-uniform scale and on
    the ellipsoid, whose derivatives go to the world through their instance's transform."""
    flat = compile_scene(mapped_scene(tmp_path, "{type: lambertian, albedo: [0.5, 0.5, 0.5], normal_map: [0.5, 0.5, 1]}"))
    base = [(0.13, 0.21), (-0.3, 0.1)]
    h = 1e-4
    for dx, dy in base:
        o0, d = rays_at(CENTRES, [(dx, dy)])
        s0 = shading_at(flat, o0, d)
        for step in ((h, 0.0), (0.0, h)):
            s1 = shading_at(flat, o0 + np.array([step[0], step[1], 0.0]), d)
            dp = s1[:, POINT] - s0[:, POINT]
            duv = s1[:, UV] - s0[:, UV]
            predicted = s0[:, DPDU] * duv[:, :1] + s0[:, DPDV] * duv[:, 1:]
            err = np.linalg.norm(predicted - dp, axis=1) / np.linalg.norm(dp, axis=1)
            assert (err < 2e-3).all(), err
            n = s0[:, NORMAL]
            for col in (DPDU, DPDV):
                x = s0[:, col]
                assert (np.abs(np.einsum("ij,ij->i", x, n)) <= 1e-9 * np.linalg.norm(x, axis=1)).all()
    # The instance's quad: its u edge (2, 0, 0) through the instance's linear map.
    a = math.radians(30.0)
    rot = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    lin = rot @ np.diag([2.0, 0.5, 1.0])
    o, d = rays_at([18.0], [(0.1, 0.05)])
    s = shading_at(flat, o, d)
    np.testing.assert_allclose(s[0, DPDU], lin @ [2.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(s[0, DPDV], lin @ [0.0, 2.0, 0.0], atol=1e-9)


def test_a_bump_ramp_tilts_the_shading_normal_by_the_arc_tangent_of_its_slope(tmp_path):
    """An image whose texel i (of 256) holds i / 255, read linear: central differences give
    dh/du = 256 / 255 per unit of u; on a quad whose u edge is 2 long, at bump_height 0.5, the
    slope in the world is 0.5 x 256 / 255 / 2, and the normal leans back from +u by its atan."""
    write_png(tmp_path / "ramp.png", np.repeat(np.arange(256)[None, :, None], 3, axis=2).repeat(4, axis=0))
    graph = scene_file(tmp_path, HEADER + """background: [1, 1, 1]
textures:
  ramp: {type: image, file: ramp.png, colorspace: linear}
materials:
  bumpy: {type: lambertian, albedo: [0.5, 0.5, 0.5], bump_map: ramp, bump_height: 0.5}
shapes:
  - {type: quad, q: [-1, -1, 0], u: [2, 0, 0], v: [0, 2, 0], material: bumpy}
""")
    flat = compile_scene(graph)
    o, d = rays_at([0.0], [(0.13, 0.21), (-0.5, 0.3), (0.7, -0.8)])
    s = shading_at(flat, o, d)
    slope = 0.5 * (256 / 255) / 2.0
    m = s[:, SHADING]
    # Texels are float32: their differences are exact to about 1e-7 of the slope.
    np.testing.assert_allclose(np.arctan2(-m[:, 0], m[:, 2]), math.atan(slope), atol=1e-6)
    np.testing.assert_allclose(m[:, 1], 0.0, atol=1e-12)


LIT = HEADER + """background: [0.2, 0.3, 0.4]
materials:
  lamp: {type: diffuse_light, emit: [6, 6, 6]}
  white: %s
shapes:
  - {type: quad, q: [-3, -1, -3], u: [6, 0, 0], v: [0, 0, 6], material: white}
  - {type: sphere, center: [0, 0, 0], radius: 0.8, material: white}
  - {type: quad, q: [-0.5, 2, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp}
"""


@pytest.mark.parametrize("integrator", ["path", "mis"])
def test_a_flat_normal_map_renders_the_bits_of_no_map(tmp_path, integrator):
    plain = scene_file(tmp_path, LIT % "{type: lambertian, albedo: [0.7, 0.7, 0.7]}", "plain.yaml")
    flat_map = scene_file(tmp_path, LIT % "{type: lambertian, albedo: [0.7, 0.7, 0.7], normal_map: [0.5, 0.5, 1]}",
                          "flat.yaml")
    films = []
    for graph in (plain, flat_map):
        frame = Frame.of(graph)._replace(integrator=integrator)
        films.append(render_flat(compile_scene(graph), frame, features=GENERAL).film)
    assert films[0].total.sum() > 0
    np.testing.assert_array_equal(films[0].total, films[1].total)
    np.testing.assert_array_equal(films[0].total_sq, films[1].total_sq)


def wild_map(tmp_path, seed=5):
    """A 64 x 64 image of uniformly random texels: normals anywhere, a quarter of them pointing
    into the surface (blue < 0.5 is Z < 0)."""
    rng = np.random.default_rng(seed)
    write_png(tmp_path / "wild.png", rng.integers(0, 256, size=(64, 64, 3)))
    return "{type: image, file: wild.png, colorspace: linear}"


FURNACE_MATERIALS = {
    "lambertian": "{type: lambertian, albedo: [1, 1, 1], normal_map: wild, normal_scale: %g}",
    # A rough metal: its lobe is built in the bent frame, where the viewer may be grazing (rule 2).
    "conductor": "{type: conductor, metal: Ag, roughness: 0.4, normal_map: wild, normal_scale: %g}",
}


@pytest.mark.parametrize("integrator", ["path", "mis"])
@pytest.mark.parametrize("scale", [1.0, 4.0])
@pytest.mark.parametrize("material", sorted(FURNACE_MATERIALS))
def test_a_wild_normal_map_in_a_white_furnace_creates_no_energy(tmp_path, integrator, scale, material):
    """A sphere and a floor, white lambertian (albedo 1) or a rough silver, in a uniform white
    background: every path ends in the background with a throughput of at most 1 (a sampled
    lobe's weight is at most 1), so every pixel is at most 1 (the lambertian's exactly 1 without
    the map); the camera sees the floor at grazing angles and the sphere's rim."""
    graph = scene_file(tmp_path, """
camera: {look_from: [0, 0.3, 6], look_at: [0, 0.3, 0], vfov: 35}
image: {width: 24, height: 24, samples_per_pixel: 16, max_depth: 64, seed: 9}
background: [1, 1, 1]
textures:
  wild: %s
materials:
  white: %s
shapes:
  - {type: quad, q: [-50, -1, -50], u: [100, 0, 0], v: [0, 0, 100], material: white}
  - {type: sphere, center: [0, 0.3, 0], radius: 1, material: white}
""" % (wild_map(tmp_path), FURNACE_MATERIALS[material] % scale))
    frame = Frame.of(graph)._replace(integrator=integrator)
    film = render_flat(compile_scene(graph), frame, features=GENERAL).film
    mean = film.mean()
    assert np.isfinite(film.total).all() and np.isfinite(film.total_sq).all()
    assert (mean <= 1.0 + 1e-12).all(), mean.max()
    assert mean.mean() > 0.2  # not black: the map loses energy, it does not swallow it all


WALL = """
camera: {look_from: [0, 0, 5], look_at: [0, 0, 0], vfov: 30}
image: {width: 16, height: 16, samples_per_pixel: 32, max_depth: 8, seed: 4}
background: [0, 0, 0]
textures:
  wild: WILD
materials:
  wall: {type: lambertian, albedo: [0.8, 0.8, 0.8], normal_map: wild, normal_scale: 3}
  lamp: {type: diffuse_light, emit: [20, 20, 20]}
shapes:
  - {type: quad, q: [-3, -3, 0], u: [6, 0, 0], v: [0, 6, 0], material: wall}
  - {type: quad, LAMP, material: lamp}
"""


@pytest.mark.parametrize("integrator", ["path", "mis"])
def test_no_light_leaks_through_a_normal_mapped_wall(tmp_path, integrator):
    """The camera sees only the front of a wall (about 30 texels of a random map across the view,
    its normals tilted far by `normal_scale` 3); a lamp lies behind it, facing it. Without rule 3 a light sample (or a bounce) that the bent normal takes for a
    reflection would cross the wall. The control puts the lamp in front, out of the camera's
    view: the same wall is lit."""
    text = WALL.replace("WILD", wild_map(tmp_path, seed=6))
    behind = scene_file(tmp_path, text.replace("LAMP", "q: [-2, -2, -1], u: [4, 0, 0], v: [0, 4, 0]"), "behind.yaml")
    ahead = scene_file(tmp_path, text.replace("LAMP", "q: [-3, 3, 0.5], u: [6, 0, 0], v: [0, 0, 3]"), "ahead.yaml")
    films = []
    for graph in (behind, ahead):
        frame = Frame.of(graph)._replace(integrator=integrator)
        films.append(render_flat(compile_scene(graph), frame, features=GENERAL).film)
    assert np.isfinite(films[0].total).all()
    assert (films[0].total == 0.0).all(), films[0].total.max()
    assert (films[1].total > 0.0).mean() > 0.5  # lit (the books' estimator finds the lamp by chance)


def test_the_specialised_kernel_renders_a_mapped_scene_as_the_general_one(tmp_path):
    """A kernel compiled for the scene's effects only (normal and bump maps on, most paths off)
    gives the general kernel's bits, as every specialised kernel must."""
    from renderer.variants import features_of

    graph = scene_file(tmp_path, LIT % "{type: lambertian, albedo: [0.7, 0.7, 0.7], normal_map: [0.7, 0.4, 0.9]}")
    needed = features_of(graph)
    assert needed.surface_maps and not needed.is_general
    flat = compile_scene(graph)
    frame = Frame.of(graph)
    general = render_flat(flat, frame, needed=needed, features=GENERAL).film
    special = render_flat(flat, frame, needed=needed, features=needed).film
    np.testing.assert_array_equal(general.total, special.total)
    np.testing.assert_array_equal(general.total_sq, special.total_sq)
