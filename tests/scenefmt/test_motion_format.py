"""The motion format: keyframes on shapes, instances and the camera, what they fold into when they
stand still, what they switch on, and the errors they make (pure Python: no kernels)."""

import pytest

from scenefmt.effects import summarize
from scenefmt.validation import loads

HEAD = """
camera: {look_from: [0, 1, 6], look_at: [0, 0.5, 0]CAMERA}
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
groups:
  g: {shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: white}]}
shapes:
"""


def scene(shape="  - {type: sphere, center: [0, 0, 0], radius: 1, material: white}\n", camera="", extra=""):
    return loads(HEAD.replace("CAMERA", camera) + shape + extra)


def errors(result):
    return [str(d) for d in result.errors] if hasattr(result, "errors") else []


def test_a_moving_shape_and_instance_switch_on_motion_and_instances_naming_them():
    result = scene("  - {type: box, min: [0, 0, 0], max: [1, 1, 1], material: white}\n"
                   "  - {type: instance, group: g, motion: [{time: 0}, {time: 2, transform: [{rotate: {axis: y, degrees: 30}}]}]}\n")
    summary = summarize(result.graph)
    assert str(summary.effect("motion")) == "motion blur: on (shapes[1] moves, shutter 0..1)"
    assert summary.effect("instances").reason.startswith("shapes[1] moves")


def test_keyframes_all_alike_fold_into_the_still_transform():
    moving = scene("  - {type: box, min: [0, 0, 0], max: [1, 1, 1], material: white, transform: [{scale: 2}], "
                   "motion: [{time: 0, transform: [{translate: [1, 2, 3]}]}, {time: 1, transform: [{translate: [1, 2, 3]}]}]}\n")
    still = scene("  - {type: box, min: [0, 0, 0], max: [1, 1, 1], material: white, "
                  "transform: [{scale: 2}, {translate: [1, 2, 3]}]}\n")
    a, b = moving.graph.root.members[0], still.graph.root.members[0]
    assert a.motion is None and a.transform == b.transform
    assert summarize(moving.graph).kernel_paths == summarize(still.graph).kernel_paths


def test_a_keyframe_follows_the_shapes_own_transform():
    result = scene("  - {type: box, min: [0, 0, 0], max: [1, 1, 1], material: white, transform: [{scale: 2}], "
                   "motion: [{time: 0}, {time: 1, transform: [{translate: [5, 0, 0]}]}]}\n")
    node = result.graph.root.members[0]
    times, maps = node.motion
    assert times == (0.0, 1.0)
    assert node.transform[0][0] == 2.0  # the still part: scale 2
    assert maps[1][0][3] == 5.0  # the keyframe's, after it


def test_a_camera_whose_keyframes_agree_stands_still():
    still = scene(camera=", motion: [{time: 0}, {time: 1, look_at: [0, 0.5, 0]}]")
    assert not still.graph.camera.moves
    assert not summarize(still.graph).effect("motion").on
    moving = scene(camera=", motion: [{time: 0}, {time: 1, look_at: [1, 0.5, 0]}]")
    assert moving.graph.camera.moves
    assert str(summarize(moving.graph).effect("motion")) == "motion blur: on (camera moves, shutter 0..1)"


def test_motion_is_off_when_the_shutter_never_opens():
    result = scene("  - {type: instance, group: g, motion: [{time: 0}, {time: 1, transform: [{translate: [1, 0, 0]}]}]}\n",
                   extra="shutter: {open: 0.5, close: 0.5}\n")
    assert not summarize(result.graph).effect("motion").on


@pytest.mark.parametrize("text, message", [
    ("  - {type: instance, group: g, motion: [{time: 1}, {time: 0}]}\n", "keyframe times must increase"),
    ("  - {type: instance, group: g, motion: [{time: 0}]}\n", "at least 2"),
    ("  - {type: instance, group: g, motion: [{time: 0}, {time: 1, transform: [{scale: 0}]}]}\n", "scale factor of 0"),
    ("  - {type: instance, group: g, motion: [{time: 0}, {time: 1, trasform: []}]}\n", "trasform"),
])
def test_bad_keyframes_are_one_clear_error_each(text, message):
    with pytest.raises(Exception) as caught:
        scene(text)
    assert message in str(caught.value)


def test_bad_camera_keyframes_are_refused():
    with pytest.raises(Exception) as caught:
        scene(camera=", motion: [{time: 0}, {time: 1, look_from: [0, 0.5, 0]}]")
    assert "keyframe 1: look_from and look_at are the same point" in str(caught.value)


def test_caustics_refuses_motion_in_one_sentence():
    with pytest.raises(Exception) as caught:
        scene("  - {type: instance, group: g, motion: [{time: 0}, {time: 1, transform: [{translate: [1, 0, 0]}]}]}\n",
              extra="image: {integrator: caustics}\n")
    assert "image.integrator caustics needs shapes and a camera that stand still" in str(caught.value)
