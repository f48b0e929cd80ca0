"""Every scene file in scenes/ loads, and holds the books' values."""

from __future__ import annotations

import math
import subprocess
import sys
from collections import Counter
from functools import lru_cache
from pathlib import Path

import pytest

from scenefmt.materials import Dielectric, Lambertian, Metal
from scenefmt.media import ConstantMedium
from scenefmt.scene import SkyBackground
from scenefmt.textures import CheckerTexture, ImageTexture, NoiseTexture
from scenefmt.validation import load

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
SCENE_FILES = sorted(p for p in SCENES.iterdir() if p.suffix in (".yaml", ".json"))

SKY_BLUE = (0.7, 0.8, 1.0)
BLACK = (0.0, 0.0, 0.0)
OLD_CAMERA = dict(look_from=(0, 0, 0), look_at=(0, 0, -1), vfov=90)

# name: (shape count by type, (width, height), samples_per_pixel, max_depth, camera fields, background)
EXPECTED = {
    "weekend_sky.yaml": ({}, (200, 100), 100, 50, OLD_CAMERA, "sky"),
    "weekend_diffuse.yaml": ({"sphere": 2}, (200, 100), 100, 50, OLD_CAMERA, "sky"),
    "weekend_metal.yaml": ({"sphere": 4}, (200, 100), 100, 50, OLD_CAMERA, "sky"),
    "weekend_glass.yaml": ({"sphere": 5}, (200, 100), 100, 50, OLD_CAMERA, "sky"),
    "weekend_wide_angle.yaml": ({"sphere": 2}, (200, 100), 100, 50, OLD_CAMERA, "sky"),
    "weekend_camera.yaml": (
        {"sphere": 5}, (200, 100), 100, 50, dict(look_from=(-2, 2, 1), look_at=(0, 0, -1), vfov=90), "sky"
    ),
    "weekend_defocus.yaml": (
        {"sphere": 5}, (200, 100), 100, 50,
        dict(look_from=(3, 3, 2), look_at=(0, 0, -1), vfov=20, aperture=2.0, focus_distance=5.196152422706632), "sky",
    ),
    "weekend_cover.yaml": (
        None, (1200, 800), 10, 50,
        dict(look_from=(13, 2, 3), look_at=(0, 0, 0), vfov=20, aperture=0.1, focus_distance=10), "sky",
    ),
    "bouncing_spheres.yaml": (
        None, (400, 225), 100, 50,
        dict(look_from=(13, 2, 3), look_at=(0, 0, 0), vfov=20, defocus_angle=0.6, focus_distance=10), SKY_BLUE,
    ),
    "checkered_spheres.yaml": (
        {"sphere": 2}, (400, 225), 100, 50, dict(look_from=(13, 2, 3), look_at=(0, 0, 0), vfov=20), SKY_BLUE
    ),
    "earth.yaml": ({"sphere": 1}, (400, 225), 100, 50, dict(look_from=(0, 0, 12), look_at=(0, 0, 0), vfov=20), SKY_BLUE),
    "perlin_spheres.yaml": (
        {"sphere": 2}, (400, 225), 100, 50, dict(look_from=(13, 2, 3), look_at=(0, 0, 0), vfov=20), SKY_BLUE
    ),
    "quads.json": ({"quad": 5}, (400, 400), 100, 50, dict(look_from=(0, 0, 9), look_at=(0, 0, 0), vfov=80), SKY_BLUE),
    "simple_light.yaml": (
        {"sphere": 3, "quad": 1}, (400, 225), 100, 50, dict(look_from=(26, 3, 6), look_at=(0, 2, 0), vfov=20), BLACK
    ),
    "cornell_box.yaml": (
        {"quad": 6, "box": 2}, (600, 600), 200, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    "cornell_smoke.yaml": (
        {"quad": 6, "box": 2}, (600, 600), 200, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    "cornell_knot.yaml": (
        {"quad": 6, "mesh": 1}, (600, 600), 200, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    # Not from the books: motion of a mesh and a panning camera (issue 36, docs/motion.md).
    "motion_knot.yaml": (
        {"quad": 6, "mesh": 1}, (600, 600), 200, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    "motion_pan.yaml": (
        {"sphere": 6}, (400, 225), 100, 20, dict(look_from=(0, 1.5, 8), look_at=(-0.25, 0.8, 0), vfov=30), "sky",
    ),
    "final_scene.yaml": (
        {"box": 400, "quad": 1, "moving_sphere": 1, "sphere": 6, "instance": 1}, (400, 400), 250, 4,
        dict(look_from=(478, 278, -600), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    # Not from the books: the project's environment map (scenes/generate_sky.py) in use.
    "sky_spheres.yaml": (
        {"sphere": 4}, (320, 180), 64, 16, dict(look_from=(0, 1.1, 4.5), look_at=(0, 0.45, 0), vfov=35), "image",
    ),
    # Not from the books: issue 33's sun and sky over a few objects on a ground.
    "sun_sky.yaml": (
        {"quad": 1, "sphere": 3, "box": 1}, (320, 180), 64, 16, dict(look_from=(0, 1.4, 6), look_at=(0, 0.6, 0), vfov=38),
        "sun_sky",
    ),
    # Not from the books: issue 31's material families, one Cornell box each, and a row of them under the map.
    "cornell_conductor.yaml": (
        {"quad": 6, "sphere": 2}, (400, 400), 128, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    "cornell_rough_glass.yaml": (
        {"quad": 6, "sphere": 1, "box": 1}, (400, 400), 256, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    "cornell_plastic.yaml": (
        {"quad": 6, "sphere": 1, "box": 1}, (400, 400), 128, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    "cornell_principled.yaml": (
        {"quad": 6, "sphere": 3}, (400, 400), 128, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    # Issue 33: the Cornell box lit by a spot light (lights:), its ceiling lamp removed.
    "cornell_spot.yaml": (
        {"quad": 5, "box": 2}, (600, 600), 64, 50,
        dict(look_from=(278, 278, -800), look_at=(278, 278, 0), vfov=40), BLACK,
    ),
    # Issue 33: many lights, a night market of 1,040 stalls (instances of two groups) and 12,480 bulbs.
    "many_lights.yaml": (
        {"quad": 1, "instance": 1040}, (480, 270), 64, 6,
        dict(look_from=(5, 26, 15), look_at=(0, 0, -1), vfov=50), (0.004, 0.006, 0.016),
    ),
    # Issue 35: imported by `rt import` from the glTF model scenes/generate_gltf.py builds.
    "still_life.yaml": (
        {"mesh": 7, "instance": 7}, (640, 426), 64, 12,
        dict(look_from=(0, 1.35, 2.3), look_at=(0, 0.78921745537, 0.344318854004), vfov=32), BLACK,
    ),
    "material_spheres.yaml": (
        {"sphere": 7}, (480, 270), 64, 16, dict(look_from=(0, 1.3, 6.5), look_at=(0, 0.4, 0), vfov=26), "image",
    ),
    # Issue 36: a plume of smoke from a grid (scenes/generate_smoke.py) in a lit room.
    "smoke_plume.yaml": (
        {"quad": 6, "box": 2}, (400, 400), 256, 24, dict(look_from=(5, 4.5, -11), look_at=(5, 4, 5), vfov=42), BLACK,
    ),
}


@lru_cache(maxsize=None)
def loaded(name: str):
    return load(SCENES / name)


def scene(name: str):
    return loaded(name).scene


def material(sc, slot):
    """The material model of a shape's `material` slot (named or inline)."""
    return sc.materials[slot] if isinstance(slot, str) else slot


def texture(sc, slot):
    return sc.textures[slot] if isinstance(slot, str) else slot


def test_every_scene_file_is_listed():
    assert sorted(p.name for p in SCENE_FILES) == sorted(EXPECTED)


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.name)
def test_scene_file_loads_with_book_settings(path: Path):
    result = loaded(path.name)
    sc = result.scene
    counts, (width, height), spp, depth, camera, background = EXPECTED[path.name]

    assert result.warnings == []
    assert sc.version == 1
    assert sc.description.strip() and "\n" not in sc.description.strip()
    if counts is not None:
        assert Counter(s.type for s in sc.shapes) == Counter(counts)
    assert (sc.image.width, sc.image.pixel_height) == (width, height)
    assert sc.image.samples_per_pixel == spp
    assert sc.image.max_depth == depth
    for field, value in camera.items():
        assert getattr(sc.camera, field) == pytest.approx(value), field
    assert tuple(sc.camera.up) == (0, 1, 0)
    if background == "sky":
        assert sc.background == SkyBackground(bottom=(1, 1, 1), top=(0.5, 0.7, 1.0))
    elif background == "image":
        assert sc.background.file == "sky.pfm"
        assert result.graph.environment_path == (SCENES / "sky.pfm").resolve()
    elif background == "sun_sky":
        assert sc.background.type == "sun_sky" and sc.background.sun and sc.background.sky
    else:
        assert tuple(sc.background) == pytest.approx(background)


@pytest.mark.parametrize("path", [p for p in SCENE_FILES if p.suffix == ".yaml"], ids=lambda p: p.name)
def test_yaml_files_name_the_schema(path: Path):
    assert path.read_text(encoding="utf-8").splitlines()[0] == "# yaml-language-server: $schema=../schemas/scene.schema.json"


def test_quads_is_json():
    assert (SCENES / "quads.json").is_file() and not (SCENES / "quads.yaml").exists()


# --- the first book -------------------------------------------------------------------------------


def test_weekend_sky_has_no_shapes():
    assert scene("weekend_sky.yaml").shapes == []


def test_weekend_diffuse_is_half_grey():
    sc = scene("weekend_diffuse.yaml")
    assert [(s.center, s.radius) for s in sc.shapes] == [((0, 0, -1), 0.5), ((0, -100.5, -1), 100)]
    assert all(material(sc, s.material) == Lambertian(albedo=(0.5, 0.5, 0.5)) for s in sc.shapes)


def test_weekend_metal_fuzz():
    sc = scene("weekend_metal.yaml")
    by_x = {s.center[0]: material(sc, s.material) for s in sc.shapes if s.radius == 0.5}
    assert by_x[-1] == Metal(albedo=(0.8, 0.8, 0.8), fuzz=0.3)
    assert by_x[1] == Metal(albedo=(0.8, 0.6, 0.2), fuzz=1.0)
    assert by_x[0] == Lambertian(albedo=(0.8, 0.3, 0.3))


@pytest.mark.parametrize("name", ["weekend_glass.yaml", "weekend_camera.yaml", "weekend_defocus.yaml"])
def test_hollow_glass_bubble(name):
    sc = scene(name)
    left = [s for s in sc.shapes if s.center == (-1, 0, -1)]
    assert sorted((s.radius, material(sc, s.material).ior) for s in left) == [(0.45, 1 / 1.5), (0.5, 1.5)]
    assert "1/1.5" in sc.description
    right = next(s for s in sc.shapes if s.center == (1, 0, -1))
    assert material(sc, right.material) == Metal(albedo=(0.8, 0.6, 0.2), fuzz=0.0)


def test_weekend_wide_angle_spheres_touch():
    sc = scene("weekend_wide_angle.yaml")
    r = math.cos(math.pi / 4)
    assert [(s.center, s.radius) for s in sc.shapes] == [((-r, 0, -1), r), ((r, 0, -1), r)]


def test_weekend_defocus_lens():
    cam = scene("weekend_defocus.yaml").camera
    assert cam.lens_radius == 1.0
    assert cam.focus == pytest.approx(math.dist(cam.look_from, cam.look_at))


def _small_spheres(sc):
    return [s for s in sc.shapes if s.radius == 0.2]


def _check_cover_layout(sc):
    small = _small_spheres(sc)
    assert len(sc.shapes) == 1 + len(small) + 3
    assert 400 < len(small) <= 22 * 22
    for s in small:
        c = s.center if s.type == "sphere" else s.center0
        assert c[1] == 0.2
        assert -11 <= c[0] < 10.9 + 1e-9 and -11 <= c[2] < 10.9 + 1e-9
        assert math.dist(c, (4, 0.2, 0)) > 0.9 - 1e-4  # values are rounded to 4 places
    big = {s.center: material(sc, s.material) for s in sc.shapes if s.radius == 1}
    assert big == {
        (0, 1, 0): Dielectric(ior=1.5),
        (-4, 1, 0): Lambertian(albedo=(0.4, 0.2, 0.1)),
        (4, 1, 0): Metal(albedo=(0.7, 0.6, 0.5), fuzz=0.0),
    }
    assert sc.shapes[0].center == (0, -1000, 0) and sc.shapes[0].radius == 1000
    kinds = Counter(type(material(sc, s.material)).__name__ for s in small)
    assert kinds["Lambertian"] > kinds["Metal"] > kinds["Dielectric"] > 0


def test_weekend_cover_is_static_random_field():
    sc = scene("weekend_cover.yaml")
    _check_cover_layout(sc)
    assert {s.type for s in sc.shapes} == {"sphere"}
    assert material(sc, sc.shapes[0].material) == Lambertian(albedo=(0.5, 0.5, 0.5))
    for s in _small_spheres(sc):
        m = material(sc, s.material)
        if isinstance(m, Metal):
            assert all(0.5 <= a <= 1 for a in m.albedo) and 0 <= m.fuzz <= 0.5


# --- The Next Week ---------------------------------------------------------------------------------


def test_bouncing_spheres_move_up_only_diffuse():
    sc = scene("bouncing_spheres.yaml")
    _check_cover_layout(sc)
    assert sc.textures["checker"] == CheckerTexture(scale=0.32, even=(0.2, 0.3, 0.1), odd=(0.9, 0.9, 0.9))
    assert material(sc, sc.shapes[0].material) == Lambertian(albedo="checker")
    moving = [s for s in sc.shapes if s.type == "moving_sphere"]
    assert moving and all(isinstance(material(sc, s.material), Lambertian) for s in moving)
    for s in moving:
        dx, dy, dz = (b - a for a, b in zip(s.center0, s.center1))
        assert dx == 0 and dz == 0 and 0 <= dy <= 0.5
    static_small = [s for s in _small_spheres(sc) if s.type == "sphere"]
    assert all(not isinstance(material(sc, s.material), Lambertian) for s in static_small)
    assert sc.camera.lens_radius == pytest.approx(0.05236, abs=1e-5)
    assert (sc.shutter.open, sc.shutter.close) == (0, 1)


def test_checkered_spheres_share_one_texture():
    sc = scene("checkered_spheres.yaml")
    assert list(sc.textures) == ["checker"]
    assert sc.textures["checker"] == CheckerTexture(scale=0.32, even=(0.2, 0.3, 0.1), odd=(0.9, 0.9, 0.9))
    assert [(s.center, s.radius) for s in sc.shapes] == [((0, -10, 0), 10), ((0, 10, 0), 10)]
    assert all(material(sc, s.material).albedo == "checker" for s in sc.shapes)
    assert sc.camera.lens_radius == 0


def test_earth_image_texture_is_next_to_the_scene():
    result = loaded("earth.yaml")
    sc = result.scene
    globe = sc.shapes[0]
    assert (globe.center, globe.radius) == ((0, 0, 0), 2)
    tex = texture(sc, material(sc, globe.material).albedo)
    assert tex == ImageTexture(file="earthmap.png", colorspace="srgb")
    assert (SCENES / "earthmap.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert any(t.image_path == (SCENES / "earthmap.png").resolve() for t in result.graph.textures)


def test_perlin_spheres_marble_scale_4():
    sc = scene("perlin_spheres.yaml")
    assert [(s.center, s.radius) for s in sc.shapes] == [((0, -1000, 0), 1000), ((0, 2, 0), 2)]
    textures = {texture(sc, material(sc, s.material).albedo) for s in sc.shapes}
    assert textures == {NoiseTexture(scale=4, form="marble", octaves=7)}


def test_quads_colours_and_corners():
    sc = scene("quads.json")
    quads = [(s.q, s.u, s.v, material(sc, s.material).albedo) for s in sc.shapes]
    assert quads == [
        ((-3, -2, 5), (0, 0, -4), (0, 4, 0), (1.0, 0.2, 0.2)),
        ((-2, -2, 0), (4, 0, 0), (0, 4, 0), (0.2, 1.0, 0.2)),
        ((3, -2, 1), (0, 0, 4), (0, 4, 0), (0.2, 0.2, 1.0)),
        ((-2, 3, 1), (4, 0, 0), (0, 0, 4), (1.0, 0.5, 0.0)),
        ((-2, -3, 5), (4, 0, 0), (0, 0, -4), (0.2, 0.8, 0.8)),
    ]


def test_simple_light_has_quad_and_sphere_lights():
    sc = scene("simple_light.yaml")
    lights = [s for s in sc.shapes if s.material == "difflight"]
    assert sc.materials["difflight"].emit == (4, 4, 4)
    assert {s.type for s in lights} == {"quad", "sphere"}
    quad = next(s for s in lights if s.type == "quad")
    assert (quad.q, quad.u, quad.v) == ((3, 1, -2), (2, 0, 0), (0, 2, 0))
    sphere = next(s for s in lights if s.type == "sphere")
    assert (sphere.center, sphere.radius) == ((0, 7, 0), 2)


def _box_placements(sc):
    return sorted(
        (b.max, b.transform[0].rotate.axis, b.transform[0].rotate.degrees, b.transform[1].translate)
        for b in sc.shapes
        if b.type == "box"
    )


def test_cornell_box_light_and_rotated_boxes():
    sc = scene("cornell_box.yaml")
    light = next(s for s in sc.shapes if s.material == "light")
    assert (light.q, light.u, light.v) == ((343, 554, 332), (-130, 0, 0), (0, 0, -105))
    assert sc.materials["light"].emit == (15, 15, 15)
    assert _box_placements(sc) == [
        ((165, 165, 165), "y", -18, (130, 0, 65)),
        ((165, 330, 165), "y", 15, (265, 0, 295)),
    ]
    assert all(b.material == "white" and b.interior is None for b in sc.shapes if b.type == "box")


def test_cornell_smoke_boxes_are_invisible_media():
    sc = scene("cornell_smoke.yaml")
    assert sc.media == {
        "smoke": ConstantMedium(density=0.01, albedo=(0, 0, 0)),
        "fog": ConstantMedium(density=0.01, albedo=(1, 1, 1)),
    }
    boxes = [s for s in sc.shapes if s.type == "box"]
    assert all(b.material is None for b in boxes)
    assert sorted(b.interior for b in boxes) == ["fog", "smoke"]
    assert _box_placements(sc) == _box_placements(scene("cornell_box.yaml"))
    light = next(s for s in sc.shapes if s.material == "light")
    assert (light.q, light.u, light.v) == ((113, 554, 127), (330, 0, 0), (0, 0, 305))
    assert sc.materials["light"].emit == (7, 7, 7)
    assert len(loaded("cornell_smoke.yaml").graph.media) == 2


def test_final_scene_contents():
    sc = scene("final_scene.yaml")
    (instance,) = [s for s in sc.shapes if s.type == "instance"]
    group = sc.groups[instance.group]
    assert len(group.shapes) == 1000
    assert all(s.type == "sphere" and s.radius == 10 and s.material == "white" for s in group.shapes)
    assert all(0 <= x < 165 + 1e-4 for s in group.shapes for x in s.center)
    assert [step.model_dump() for step in instance.transform] == [
        {"rotate": {"axis": "y", "degrees": 15}},
        {"translate": (-100, 270, 395)},
    ]

    boxes = [s for s in sc.shapes if s.type == "box"]
    assert sorted((b.min[0], b.min[2]) for b in boxes) == [
        (-1000 + 100 * i, -1000 + 100 * j) for i in range(20) for j in range(20)
    ]
    assert all(b.min[1] == 0 and 1 <= b.max[1] <= 101 and b.max[0] - b.min[0] == 100 for b in boxes)

    spheres = {s.center: s for s in sc.shapes if s.type == "sphere"}
    mist = spheres[(0, 0, 0)]
    assert mist.radius == 5000 and mist.material is None
    assert sc.media[mist.interior] == ConstantMedium(density=0.0001, albedo=(1, 1, 1))
    assert math.dist(sc.camera.look_from, mist.center) < mist.radius  # the camera sits in the mist
    subsurface = spheres[(360, 150, 145)]
    assert subsurface.radius == 70 and material(sc, subsurface.material) == Dielectric(ior=1.5)
    assert sc.media[subsurface.interior] == ConstantMedium(density=0.2, albedo=(0.2, 0.4, 0.9))
    assert material(sc, spheres[(0, 150, 145)].material) == Metal(albedo=(0.8, 0.8, 0.9), fuzz=1.0)
    assert texture(sc, material(sc, spheres[(220, 280, 300)].material).albedo) == NoiseTexture(scale=0.2)
    assert texture(sc, material(sc, spheres[(400, 200, 400)].material).albedo).file == "earthmap.png"
    (moving,) = [s for s in sc.shapes if s.type == "moving_sphere"]
    assert (moving.center0, moving.center1, moving.radius) == ((400, 400, 200), (430, 400, 200), 50)
    assert "800" in sc.description and "10000" in sc.description and "40" in sc.description


# --- the generator ---------------------------------------------------------------------------------


def test_the_torus_knot_is_the_one_meshgen_makes(tmp_path):
    """scenes/torus_knot.ply is made by the project, not downloaded: the same numpy call writes it again."""
    from scenefmt import meshgen

    made = meshgen.write_ply(tmp_path / "knot.ply", *meshgen.torus_knot(2, 3, 256, 16, 1.0, 0.25))
    assert made.read_bytes() == (SCENES / "torus_knot.ply").read_bytes()
    mesh = loaded("cornell_knot.yaml").graph.root.members[-1]
    assert mesh.kind == "mesh" and len(mesh.mesh.faces) == 8192 and mesh.model.smooth
    assert scene("cornell_knot.yaml").materials["glass"].type == "dielectric"


@pytest.mark.parametrize("script, small", [("generate.py", None), ("generate_sky.py", "sky.pfm"), ("generate_many_lights.py", None),
                                           ("generate_gltf.py", None), ("generate_smoke.py", "smoke_plume.npz")])
def test_generated_files_are_up_to_date(script, small):
    """What each of the scripts in scenes/ writes is what is committed (--check), and the sky map
    it writes stays small."""
    result = subprocess.run(
        [sys.executable, str(SCENES / script), "--check"], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stdout + result.stderr
    if small is not None:
        assert (SCENES / small).stat().st_size < 400_000
