"""Kernels specialised to a scene's features: which paths a scene needs, and that leaving the
others out never changes an image."""

from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from renderer.compile import compile_scene, with_width
from renderer.film import Film
from renderer.render import render
from renderer.sampling import uniform_sampling
from renderer.variants import GENERAL, KernelFeatures, _variant_cache_dir, features_of, is_compiled, kernel_set
from scenefmt.effects import summarize
from scenefmt.validation import load, loads

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

SCENES = Path(__file__).resolve().parents[2] / "scenes"
FLAGS = [f.name for f in fields(KernelFeatures)]

BASE = """
camera: {look_from: [0, 1, 6], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 12, height: 8, samples_per_pixel: 2, max_depth: 6}
background: {type: solid, color: [0.7, 0.8, 1.0]}
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
"""
GROUND = "  - {type: sphere, center: [0, -100, 0], radius: 100, material: white}\n"
# Each snippet switches exactly one kernel path on when added to BASE; lines under 'shapes:'.
SWITCH_ON = {
    "motion": ("", "  - {type: moving_sphere, center0: [0, 0.5, 0], center1: [0, 0.9, 0], radius: 0.5, material: white}\n"),
    "defocus": ("", "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}\n"),
    "media": ("media:\n  fog: {type: constant, density: 0.5, albedo: [0.5, 0.5, 0.5]}\n",
              "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, interior: fog}\n"),
    "instances": ("", "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white, transform: [{scale: [1, 2, 1]}]}\n"),
    "checker": ("textures:\n  chk: {type: checker, scale: 0.3, even: [0, 0, 0], odd: [1, 1, 1]}\n"
                "materials:\n  tiles: {type: lambertian, albedo: chk}\n",
                "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: tiles}\n"),
    "image": ("textures:\n  earth: {type: image, file: EARTH}\nmaterials:\n  globe: {type: lambertian, albedo: earth}\n",
              "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: globe}\n"),
    "noise": ("textures:\n  n: {type: noise, scale: 4}\nmaterials:\n  stone: {type: lambertian, albedo: n}\n",
              "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: stone}\n"),
    "emitters": ("materials:\n  lamp: {type: diffuse_light, emit: [3, 3, 3]}\n",
                 "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: lamp}\n"),
    "dielectrics": ("materials:\n  glass: {type: dielectric, ior: 1.5}\n",
                    "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: glass}\n"),
    "sky": ("", "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}\n"),
    "environment": ("", "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}\n"),
    "meshes": ("", "  - {type: mesh, vertices: [[-0.5, 0, 0], [0.5, 0, 0], [0, 1, 0]], faces: [[0, 1, 2]], material: white}\n"),
    "conductors": ("materials:\n  gold: {type: conductor, metal: gold, roughness: 0.3}\n",
                   "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: gold}\n"),
    "rough_dielectrics": ("materials:\n  frost: {type: rough_dielectric, ior: 1.5}\n",
                          "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: frost}\n"),
    "plastics": ("materials:\n  toy: {type: plastic, albedo: [0.1, 0.2, 0.8]}\n",
                 "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: toy}\n"),
    "principled": ("materials:\n  paint: {type: principled, base_color: [0.8, 0.1, 0.1], clearcoat: 1}\n",
                   "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: paint}\n"),
    # A map given as a colour is a solid texture: no texture kind's flag comes with it.
    "surface_maps": ("materials:\n  dented: {type: lambertian, normal_map: [0.6, 0.5, 1]}\n",
                     "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: dented}\n"),
    "parameter_textures": ("materials:\n  worn: {type: conductor, roughness: {texture: [0.3, 0.4, 0.5], channel: g}}\n",
                           "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: worn}\n"),
}
# A light that is no shape; and enough of them (8, LIGHT_TREE_THRESHOLD) for a light tree.
SWITCH_ON["punctual"] = ("lights:\n  - {type: point, position: [0, 3, 0], intensity: 5}\n",
                         "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}\n")
SWITCH_ON["light_tree"] = ("lights:\n" + "".join(f"  - {{type: point, position: [{x}, 3, 0], intensity: 5}}\n" for x in range(8)),
                           "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}\n")
SWITCH_ON["guiding"] = ("", "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}\n")
SWITCH_ON["caustics"] = SWITCH_ON["guiding"]
# Light sampling samples the emitters: it comes with them (the books' estimator leaves it out).
SWITCH_ON["lights"] = SWITCH_ON["emitters"]
# A medium of varying density, and one with an anisotropic phase: both come with the media's path.
SWITCH_ON["varying_media"] = ("media:\n  puff: {type: noise, density: 0.5}\n",
                              "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, interior: puff}\n")
SWITCH_ON["phase_hg"] = ("media:\n  haze: {type: constant, density: 0.5, phase: {type: henyey_greenstein, g: 0.6}}\n",
                         "  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, interior: haze}\n")
ALSO_ON = {"lights": {"emitters": True}, "parameter_textures": {"conductors": True}, "light_tree": {"punctual": True},
           "varying_media": {"media": True}, "phase_hg": {"media": True}}


def scene_text(flag=None):
    head, shape = SWITCH_ON[flag] if flag else ("", "")
    text = BASE
    if flag == "defocus":
        text = text.replace("vfov: 40}", "vfov: 40, defocus_angle: 2}")
    if flag == "sky":
        text = text.replace("{type: solid, color: [0.7, 0.8, 1.0]}", "{type: sky}")
    if flag == "environment":
        text = text.replace("{type: solid, color: [0.7, 0.8, 1.0]}", "{type: image, file: SKY}")
    if flag in ("guiding", "caustics"):
        text = text.replace("max_depth: 6}", f"max_depth: 6, integrator: {'guided' if flag == 'guiding' else 'caustics'}}}")
    if flag == "emitters":
        text = text.replace("max_depth: 6}", "max_depth: 6, integrator: path}")
    if head.startswith("materials:"):
        text = text.replace("materials:\n", head)
    elif "\nmaterials:\n" in head:  # a texture section and a material using it
        tex, mats = head.split("materials:\n")
        text = text.replace("materials:\n", tex + "materials:\n" + mats)
    else:
        text += head
    return text + "shapes:\n" + GROUND + shape


def graph_of(flag=None):
    return loads(scene_text(flag).replace("EARTH", str(SCENES / "earthmap.png")).replace("SKY", str(SCENES / "sky.pfm"))).graph


def flat_of(flag=None):
    return compile_scene(graph_of(flag))


NONE = KernelFeatures(**{name: False for name in FLAGS})


def test_a_plain_scene_needs_no_optional_path():
    assert features_of(graph_of()) == NONE


@pytest.mark.parametrize("flag", FLAGS)
def test_each_element_switches_on_exactly_its_path(flag):
    assert features_of(graph_of(flag)) == replace(NONE, **{flag: True, **ALSO_ON.get(flag, {})})


def test_a_moving_sphere_needs_no_motion_when_the_shutter_is_closed_or_it_stands_still():
    closed = scene_text("motion").replace("image:", "shutter: {open: 0.5, close: 0.5}\nimage:")
    still = scene_text("motion").replace("center1: [0, 0.9, 0]", "center1: [0, 0.5, 0]")
    assert not features_of(loads(closed).graph).motion
    assert not features_of(loads(still).graph).motion


def test_transforms_baked_into_shapes_need_no_instances():
    baked = scene_text("instances").replace("transform: [{scale: [1, 2, 1]}]", "transform: [{translate: [1, 0, 0]}, {scale: 2}]")
    assert not features_of(loads(baked).graph).instances


@pytest.mark.parametrize("path", sorted(SCENES.glob("*.yaml")) + sorted(SCENES.glob("*.json")), ids=lambda p: p.stem)
def test_the_kernel_compiles_in_exactly_the_effects_validate_reports(path):
    """One analysis: the kernel's paths are the effects `rt validate` prints, by key."""
    graph = load(path).graph
    summary = summarize(graph)
    assert {f.name: getattr(features_of(graph), f.name) for f in fields(KernelFeatures)} == {
        e.key: e.on for e in summary.effects}


# Tried first, so that few specialised kernels are compiled (each takes 10 to 20 s on 2 cores):
# weekend_diffuse needs only the sky, which the tests below compile anyway, and cornell_box, the
# light-sampling paths, stands in where the sky is the flag.
PREFERRED = ("weekend_diffuse", "cornell_box")


def book_scene_lacking(flag):
    """A small render of a book scene whose kernel leaves `flag` out (a preferred one, else the first by name)."""
    rank = {stem: k for k, stem in enumerate(PREFERRED)}
    for path in sorted(SCENES.glob("*.yaml"), key=lambda p: (rank.get(p.stem, len(PREFERRED)), p.stem)):
        graph = load(path).graph
        small = with_width(graph, 12)
        if not getattr(features_of(small), flag):
            return small, compile_scene(small)
    raise AssertionError(f"every book scene uses {flag}")


@pytest.mark.parametrize("flag", FLAGS)
def test_a_specialised_kernel_renders_the_general_kernels_image(flag):
    """Bit for bit: specialisation never changes an answer, whatever path it leaves out."""
    graph, flat = book_scene_lacking(flag)
    special = render(graph, samples=2, max_depth=8, seed=5, flat=flat, kernel="specialised")
    general = render(graph, samples=2, max_depth=8, seed=5, flat=flat, features=GENERAL)
    assert not getattr(special.stats.features, flag)
    assert general.stats.features == GENERAL
    assert special.film.total.sum() > 0
    assert np.array_equal(special.film.total, general.film.total)
    assert np.array_equal(special.film.total_sq, general.film.total_sq)


def test_a_path_left_out_is_really_gone():
    """The flags are not ignored: a kernel built without media, handed a scene with fog, renders
    something else than the general kernel (render() never does this: it refuses such a kernel)."""
    flat = flat_of("media")
    no_media = replace(features_of(graph_of("media")), media=False)
    images = {}
    for name, feats in (("without", no_media), ("with", GENERAL)):
        film = Film.empty(12, 8)
        rays, bad = np.zeros(8, np.int64), np.zeros(8, np.int64)
        kernel_set(feats).render_pass(flat, 12, 8, 1, 0, 4, 6, 1, uniform_sampling(), film.sums, rays, bad, 0, 8)
        images[name] = film.total
    assert not np.array_equal(images["without"], images["with"])


def test_render_refuses_a_kernel_that_lacks_a_path_the_scene_needs():
    text = scene_text("media").replace("EARTH", "")
    graph = loads(text).graph
    with pytest.raises(ValueError, match="lacks paths"):
        render(graph, samples=1, features=NONE)


def test_each_feature_set_has_a_cache_folder_of_its_own():
    sky = replace(NONE, sky=True)
    for features in (NONE, sky):
        render(loads(scene_text("sky" if features.sky else None).replace("EARTH", "")).graph, samples=1, features=features)
    folders = {tag: Path(_variant_cache_dir(tag)) for tag in ("none", "sky")}
    for tag, folder in folders.items():
        assert any(folder.rglob("integrator.render_band*")), f"no cached render kernel in {folder}"
    assert len(set(folders.values())) == 2
    assert is_compiled(NONE) and is_compiled(sky)


def test_auto_starts_with_the_general_kernel_until_the_specialised_one_is_compiled(monkeypatch):
    import renderer.variants as variants

    needed = replace(NONE, sky=True)
    monkeypatch.setattr(variants, "is_compiled", lambda features: features.is_general)
    assert variants.first_kernel(needed) == GENERAL
    monkeypatch.setattr(variants, "is_compiled", lambda features: True)
    assert variants.first_kernel(needed) == needed
    assert variants.first_kernel(needed, "general") == GENERAL
    assert variants.first_kernel(needed, "specialised") == needed


def test_auto_starts_with_the_smallest_general_kernel_that_covers_the_scene(monkeypatch):
    """On a fresh install a scene without the microfacet materials and maps compiles the core
    general kernel, not the full one; a scene with them the full one; a compiled full kernel
    serves a scene the core one would, rather than compiling the core one too."""
    import renderer.variants as variants

    books = replace(NONE, sky=True, media=True)
    gold = replace(NONE, sky=True, conductors=True)
    assert variants.CORE.covers(books) and not variants.CORE.covers(gold) and variants.CORE.tag == "core"
    monkeypatch.setattr(variants, "is_compiled", lambda features: False)
    assert variants.first_kernel(books) == variants.CORE
    assert variants.first_kernel(gold) == GENERAL
    assert variants.first_kernel(books, "general") == GENERAL
    monkeypatch.setattr(variants, "is_compiled", lambda features: features.is_general)
    assert variants.first_kernel(books) == GENERAL


def test_a_scene_lit_by_a_spot_or_the_sun_compiles_the_core_with_lights_not_the_microfacets(monkeypatch):
    """Point, spot, directional and sun lights and the light tree (tier 1) come with the core in
    the middle general kernel: such a scene compiles no microfacet code; a book scene still
    compiles only the core; a scene with both compiles the full kernel."""
    import renderer.variants as variants

    books = replace(NONE, sky=True, media=True)
    spot = replace(NONE, punctual=True, emitters=True)
    many = replace(NONE, lights=True, emitters=True, light_tree=True, environment=True, punctual=True)
    gold_spot = replace(spot, conductors=True)
    monkeypatch.setattr(variants, "is_compiled", lambda features: False)
    assert variants.first_kernel(books) == variants.CORE
    assert variants.first_kernel(spot) == variants.CORE_LIGHTS == variants.first_kernel(many)
    assert variants.CORE_LIGHTS.tag == "core+lights" and not variants.CORE_LIGHTS.conductors
    assert variants.first_kernel(gold_spot) == GENERAL
    assert variants.compile_wait(variants.CORE_LIGHTS) == variants.compile_wait(variants.CORE) == "about a minute on 2 cores"


def test_the_compile_message_says_the_full_kernel_takes_longer():
    import renderer.variants as variants

    assert variants.compile_wait(variants.CORE) == "about a minute on 2 cores"
    assert variants.compile_wait(GENERAL) == variants.compile_wait(replace(NONE, plastics=True)) == "about two minutes on 2 cores"


def test_a_long_render_switches_to_the_specialised_kernel_and_keeps_the_image(monkeypatch):
    """The switch is mid-render, after the first pass: the image is the general kernel's, bit for bit."""
    import renderer.session as session_module

    graph = graph_of("sky")
    monkeypatch.setattr(session_module, "first_kernel", lambda needed, choice: GENERAL)
    monkeypatch.setattr(session_module, "worth_specialising", lambda seconds_left: True)
    lines = []
    switched = render(graph, samples=6, seed=3, notify=lines.append)
    general = render(graph, samples=6, seed=3, features=GENERAL)
    assert switched.stats.features == replace(NONE, sky=True)
    assert any("switching" in line for line in lines)
    assert np.array_equal(switched.film.total, general.film.total)
    assert np.array_equal(switched.film.total_sq, general.film.total_sq)
