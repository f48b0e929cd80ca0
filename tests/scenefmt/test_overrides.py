"""`--set KEY.PATH=VALUE`: values changed from the command line, checked like the file's own."""

import pytest

from scenefmt.diagnostics import SceneError
from scenefmt.validation import load, loads

SCENE = """\
include: [lib.yaml]
image: {width: 40, samples_per_pixel: 4}
materials:
  glass.1: {type: dielectric, ior: 1.5}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: glass.1}
  - {type: sphere, center: [0, -100, 0], radius: 99, material: ground}
"""


@pytest.fixture
def scene(tmp_path):
    (tmp_path / "lib.yaml").write_text("materials:\n  ground: {type: lambertian, albedo: [0.5, 0.5, 0.5]}\n")
    path = tmp_path / "scene.yaml"
    path.write_text(SCENE)
    return path


def errors(scene, *overrides) -> list[str]:
    with pytest.raises(SceneError) as info:
        load(scene, overrides)
    return [str(d) for d in info.value.diagnostics]


def test_values_are_set_by_key_path(scene):
    loaded = load(
        scene,
        [
            "image.samples_per_pixel=64",
            "materials.glass.1.ior=1.33",  # a name holding a dot
            "materials.ground.albedo=[0.2, 0.3, 0.4]",  # defined in an included file
            "shapes[1].radius=98.5",
            "camera.look_from=[0, 1, 5]",  # camera was not in the file: created
            "image.seed=3",
            "image.seed=4",  # a later one wins
            "background={type: solid, color: [0, 0, 0]}",
        ],
    )
    scene_model = loaded.scene
    assert scene_model.image.samples_per_pixel == 64
    assert scene_model.image.width == 40
    assert scene_model.materials["glass.1"].ior == 1.33
    assert scene_model.materials["ground"].albedo == (0.2, 0.3, 0.4)
    assert scene_model.shapes[1].radius == 98.5
    assert scene_model.camera.look_from == (0, 1, 5)
    assert scene_model.image.seed == 4
    assert scene_model.background.type == "solid"


def test_a_bad_value_is_reported_in_its_argument(scene):
    assert errors(scene, "image.width=100.5", "materials.ground.albedo=[2, 0, 0]", "image.sampels=3") == [
        "--set image.sampels=3:1:1: error: image.sampels: unknown key 'sampels'; did you mean 'sampler'?",
        "--set image.width=100.5:1:13: error: image.width: expected a valid integer, found 100.5",
        "--set materials.ground.albedo=[2, 0, 0]:1:25: error: materials.ground.albedo: a reflectance (albedo) must be at "
        "most 1 per channel, found 2",
    ]


def test_a_value_that_breaks_a_rule_elsewhere_is_reported_where_it_is(scene):
    # The file's own error stays in the file; the --set value's error in the argument.
    assert errors(scene, "shapes[0].material=glas", "image.height=30", "image.aspect_ratio=2") == [
        "--set image.aspect_ratio=2:1:20: error: image.aspect_ratio: give either height or aspect_ratio, not both",
        "--set shapes[0].material=glas:1:20: error: shapes[0].material: undefined material 'glas'; did you mean "
        "'glass.1'?",
    ]


@pytest.mark.parametrize("argument, message", [
    ("image.width", "--set image.width:1:1: error: (top level): expected KEY.PATH=VALUE"),
    ("shapes[5].radius=1", "shapes has 2 items, so [5] names none of them"),
    ("image.width.x=1", "image.width is a single value, not a mapping, so it has no key 'x'"),
    ("image[0]=1", "image is not a list, so [0] names nothing"),
    ("..=1", "cannot read the key path '..' at character 1"),
    ("shapes[0]radius=1", "cannot read the key path 'shapes[0]radius' at character 10"),
    ("include=[x.yaml]", "include cannot be changed by --set"),
    ("image.width=[1, 2", "--set image.width=[1, 2:1:13: error: image.width: YAML syntax error: this '[' is never closed"),
    ("image.width=!!python/object:os.system x", "the tag 'tag:yaml.org,2002:python/object:os.system' is not allowed"),
    ("image.width=*a", "YAML syntax error"),
])
def test_arguments_that_cannot_be_applied(scene, argument, message):
    (found,) = errors(scene, argument)
    assert found.startswith(f"--set {argument}:1:")
    assert message in found


def test_every_bad_argument_is_reported_at_once(scene):
    assert len(errors(scene, "a", "b", "image.width=2")) == 2


def test_overrides_apply_to_text_too():
    loaded = loads("image: {width: 10}\n", overrides=["image.width=20"])
    assert loaded.scene.image.width == 20
