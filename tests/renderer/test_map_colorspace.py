"""Maps and textured parameters hold numbers, not colours: an image read for one is decoded as
linear unless the file says `colorspace: srgb`; the same image as an albedo is still sRGB."""

from __future__ import annotations

import numpy as np
from PIL import Image

from renderer.compile import compile_scene
from scenefmt.validation import load

MID = 128 / 255
MID_DECODED = ((MID + 0.055) / 1.055) ** 2.4  # the sRGB curve at 128


def texel_values(tmp_path, material: str) -> set:
    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(tmp_path / "grey.png")
    text = ("camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\nimage: {width: 8, aspect_ratio: 1}\n"
            "textures: {grey: {type: image, file: grey.png}, grey_srgb: {type: image, file: grey.png, colorspace: srgb}}\n"
            f"materials: {{m: {material}}}\n"
            "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: m}]\n")
    (tmp_path / "scene.yaml").write_text(text)
    flat = compile_scene(load(tmp_path / "scene.yaml").graph)
    return {round(float(x), 6) for x in np.asarray(flat.texels).ravel()}


def test_a_normal_map_image_is_read_as_linear(tmp_path):
    assert texel_values(tmp_path, "{type: lambertian, normal_map: grey}") == {round(MID, 6)}


def test_a_roughness_image_is_read_as_linear_and_the_albedo_as_srgb(tmp_path):
    values = texel_values(tmp_path, "{type: plastic, albedo: grey, roughness: {texture: grey, channel: g}}")
    assert values == {round(MID, 6), round(MID_DECODED, 6)}


def test_a_map_the_file_says_is_srgb_is_decoded(tmp_path):
    assert texel_values(tmp_path, "{type: lambertian, bump_map: grey_srgb}") == {round(MID_DECODED, 6)}
