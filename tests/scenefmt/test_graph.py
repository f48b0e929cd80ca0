"""Name resolution into the node graph: sharing, inline definitions, transforms, cycles, warnings."""

import math

import pytest

from scenefmt.diagnostics import SceneError
from scenefmt.graph import InstanceNode, ShapeNode
from scenefmt.validation import loads


def errors_of(text, **kw):
    with pytest.raises(SceneError) as excinfo:
        loads(text, **kw)
    return [(d.path, d.message) for d in excinfo.value.diagnostics]


def test_named_definitions_are_shared_nodes_and_inline_ones_are_not():
    graph = loads("""
textures: {chk: {type: checker, scale: 0.32, even: [0.2, 0.3, 0.1], odd: [0.9, 0.9, 0.9]}}
materials: {ground: {type: lambertian, albedo: chk}}
shapes:
  - {type: sphere, center: [0, -10, 0], radius: 10, material: ground}
  - {type: sphere, center: [0, 10, 0], radius: 10, material: ground}
  - {type: sphere, center: [0, 0, 5], radius: 1, material: {type: metal, albedo: [0.7, 0.6, 0.5]}}
""").graph
    a, b, c = graph.root.members
    assert a.material is b.material and a.material.name == "ground"
    assert a.material.textures["albedo"].kind == "checker"
    assert a.material.textures["albedo"].inputs["even"].model.color == (0.2, 0.3, 0.1)
    assert c.material.name is None and c.material.path == ("shapes", 2, "material")
    assert c.material.textures["albedo"].kind == "solid"


def test_transform_steps_apply_first_to_last():
    graph = loads("""
materials: {w: {type: lambertian}}
shapes:
  - type: box
    min: [0, 0, 0]
    max: [1, 1, 1]
    material: w
    transform: [{rotate: {axis: y, degrees: 90}}, {translate: [10, 0, 0]}]
""").graph
    m = graph.root.members[0].transform
    # Rotating (1, 0, 0) by +90 degrees about y gives (0, 0, -1); then translating adds 10 to x.
    x = tuple(m[r][0] * 1 + m[r][3] for r in range(3))
    assert x == pytest.approx((10.0, 0.0, -1.0))


def test_rotate_y_matches_the_books_formula():
    graph = loads("""
materials: {w: {type: lambertian}}
shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: w, transform: [{rotate: {axis: [0, 2, 0], degrees: 15}}]}]
""").graph
    m = graph.root.members[0].transform
    c, s = math.cos(math.radians(15)), math.sin(math.radians(15))
    p = (0.3, -0.7, 1.9)
    got = tuple(sum(m[r][k] * p[k] for k in range(3)) + m[r][3] for r in range(3))
    # Object -> world in the book: x' = cos x + sin z, z' = -sin x + cos z.
    assert got == pytest.approx((c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]))


def test_one_group_placed_twice_is_one_shared_node():
    graph = loads("""
materials: {w: {type: lambertian}}
groups:
  pair: {shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: w}]}
shapes:
  - {type: instance, group: pair, transform: [{translate: [5, 0, 0]}]}
  - {type: instance, group: pair, transform: [{scale: 2}]}
""").graph
    a, b = graph.root.members
    assert isinstance(a, InstanceNode) and a.group is b.group
    assert graph.groups == [a.group]
    assert a.transform[0][3] == 5 and b.transform[1][1] == 2


def test_medium_edges_point_at_the_boundary_shape():
    graph = loads("""
media: {fog: {type: constant, density: 0.01, albedo: [1, 1, 1]}}
shapes: [{type: box, min: [0, 0, 0], max: [1, 1, 1], interior: fog}]
""").graph
    shape = graph.root.members[0]
    assert isinstance(shape, ShapeNode) and shape.material is None
    assert shape.interior.name == "fog" and shape.interior.model.density == 0.01
    assert graph.media == [shape.interior]


def test_undefined_names_get_did_you_mean_or_the_list_of_names():
    errs = errors_of("""
materials: {ground: {type: lambertian}, glass: {type: dielectric}}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: grond}
  - {type: sphere, center: [0, 0, 0], radius: 1, material: zzz}
  - {type: instance, group: nothing}
""")
    assert (("shapes", 0, "material"), "undefined material 'grond'; did you mean 'ground'?") in errs
    assert (("shapes", 1, "material"), "undefined material 'zzz'; defined materials: glass, ground") in errs
    assert (("shapes", 2, "group"), "undefined group 'nothing'; the scene defines no groups") in errs


def test_texture_cycle_is_reported():
    errs = errors_of("""
textures:
  a: {type: checker, even: b, odd: [1, 1, 1]}
  b: {type: checker, even: [0, 0, 0], odd: a}
materials: {m: {type: lambertian, albedo: a}}
shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: m}]
""")
    assert any("cycle: a -> b -> a" in msg for _, msg in errs)


def test_self_instancing_group_is_a_cycle():
    errs = errors_of("""
groups: {g: {shapes: [{type: instance, group: g}]}}
shapes: [{type: instance, group: g}]
""")
    assert errs == [(("groups", "g", "shapes", 0, "group"), "groups instance each other in a cycle: g -> g")]


def test_unused_definitions_are_warnings_not_errors():
    loaded = loads("""
textures: {t: {type: noise}}
materials: {used: {type: lambertian}, spare: {type: lambertian, albedo: t}}
shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: used}]
""")
    assert [(w.path, w.severity) for w in loaded.warnings] == [(("materials", "spare"), "warning")]


def test_image_files_resolve_relative_to_the_scene_file(tmp_path):
    (tmp_path / "maps").mkdir()
    from PIL import Image

    Image.new("RGB", (4, 2), (10, 20, 30)).save(tmp_path / "maps" / "earth.png")
    text = """
materials: {e: {type: lambertian, albedo: {type: image, file: maps/earth.png}}}
shapes: [{type: sphere, center: [0, 0, 0], radius: 2, material: e}]
"""
    graph = loads(text, base_dir=tmp_path).graph
    assert graph.root.members[0].material.textures["albedo"].image_path == tmp_path / "maps" / "earth.png"
    errs = errors_of(text.replace("earth.png", "mars.png"), base_dir=tmp_path)
    assert len(errs) == 1 and errs[0][0] == ("materials", "e", "albedo", "file")
    assert "image file 'maps/mars.png' not found" in errs[0][1]


def test_missing_image_and_mesh_files_are_recorded_as_read(tmp_path):
    """`rt watch` watches the files a load read (files.recording_reads): one looked for and missing
    too, so that creating it counts as a change."""
    from scenefmt.files import recording_reads
    from scenefmt.validation import load

    scene = tmp_path / "scene.yaml"
    scene.write_text("""
background: {type: image, file: sky.pfm}
materials: {e: {type: lambertian, albedo: {type: image, file: maps/earth.png}}}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 2, material: e}
  - {type: mesh, file: parts/bunny.obj, material: e}
""")
    with recording_reads() as reads, pytest.raises(SceneError) as excinfo:
        load(scene)
    assert sorted(d.message.split(" not found")[0] for d in excinfo.value.diagnostics) == [
        "image file 'maps/earth.png'", "image file 'sky.pfm'", "mesh file 'parts/bunny.obj'"]
    base = tmp_path.resolve()
    for missing in (base / "maps" / "earth.png", base / "parts" / "bunny.obj", base / "sky.pfm"):
        assert str(missing) in reads, missing
    assert str(scene.resolve()) in reads or str(scene) in reads


def test_all_errors_of_a_file_are_reported_together():
    errs = errors_of("""
camera: {vfov: 0}
materials: {bad: {type: metal, fuzz: 3}, ok: {type: lambertian}}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 0, material: ok}
  - {type: sphere, center: [0, 0, 0], radius: 1, material: okk}
  - {type: sphere, center: [0, 0, 0], radius: 1, material: bad}
""")
    paths = [p for p, _ in errs]
    # Schema errors and a dangling reference in the valid part, but no echo for 'bad'.
    assert paths == [("camera", "vfov"), ("materials", "bad", "fuzz"), ("shapes", 0, "radius"), ("shapes", 1, "material")]




@pytest.mark.parametrize("text, expected", [
    ("", [(1, 1, "the scene is empty")]),
    ("# a comment and nothing else\n", [(1, 1, "the scene is empty")]),
    ("{}", [(1, 1, "the scene is empty")]),
    ("# a sky\ncamera: {vfov: 30}\n", [(2, 1, "the scene has no shapes key")]),
    ("camera: {vfov: 30}\nshapes: []\n", []),  # none, on purpose (weekend_sky.yaml)
])
def test_a_scene_without_shapes_is_a_warning_unless_it_says_shapes_empty(text, expected):
    warnings = [(w.path, w.line, w.column, w.severity, w.message) for w in loads(text, file="s.yaml").warnings]
    assert warnings == [
        ((), line, column, "warning", f"{what}: the image will show only the background (write shapes: [] if that is meant)")
        for line, column, what in expected
    ]
