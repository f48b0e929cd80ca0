"""Float images (OpenEXR and PFM): written by --hdr, read as image textures, checked like any input."""

import numpy as np
import pytest

from renderer.film import write_exr, write_pfm
from renderer.textures import load_image_texels
from scenefmt.diagnostics import SceneError
from scenefmt.hdr_files import HdrProblem, hdr_size, read_hdr
from scenefmt.validation import loads

IMAGE = np.array([[[0.0, 0.5, 1.0], [2.0, 1e-3, 0.25]], [[3.5, 0.0, 0.125], [0.75, 0.5, 0.0]]])


@pytest.mark.parametrize("suffix, write", [(".exr", write_exr), (".pfm", write_pfm)])
def test_float_images_round_trip_as_linear_float32(tmp_path, suffix, write):
    path = tmp_path / f"img{suffix}"
    write(path, IMAGE)
    assert hdr_size(path) == (2, 2)
    assert np.array_equal(read_hdr(path, 4), IMAGE.astype(np.float32))
    # As a texture: linear as stored, whatever colorspace says, row 0 at the top.
    assert np.array_equal(load_image_texels(path, "srgb"), IMAGE.astype(np.float32))
    with pytest.raises(HdrProblem, match="is 2 x 2 pixels, more than the 3 allowed"):
        read_hdr(path, 3)


def scene_with(texture_file: str, slot: str = "albedo", kind: str = "lambertian") -> str:
    return (
        f"textures: {{t: {{type: image, file: {texture_file}}}}}\n"
        f"materials: {{m: {{type: {kind}, {slot}: t}}}}\n"
        "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: m}]\n"
    )


def errors(text, tmp_path) -> list[str]:
    with pytest.raises(SceneError) as info:
        loads(text, base_dir=tmp_path)
    return [f"{d.line}:{d.column} {d.message}" for d in info.value.diagnostics]


def test_an_exr_texture_is_checked_as_the_colour_it_is_used_as(tmp_path):
    write_exr(tmp_path / "bright.exr", IMAGE)  # peaks at 3.5
    assert errors(scene_with("bright.exr"), tmp_path) == [
        "1:15 a reflectance (albedo) must be at most 1 per channel, found 3.5 (it is used at materials.m.albedo)"
    ]
    loaded = loads(scene_with("bright.exr", "emit", "diffuse_light"), base_dir=tmp_path)  # a radiance may exceed 1
    (node,) = loaded.graph.textures
    assert node.image_peak == 3.5
    assert loaded.graph.memory.textures == 4 * 48


def test_unusable_float_images_are_scene_errors(tmp_path):
    bad = IMAGE.copy()
    bad[0, 0, 0] = -0.5
    write_exr(tmp_path / "neg.exr", bad)
    bad[0, 0, 0] = np.inf
    write_pfm(tmp_path / "inf.pfm", bad)
    (tmp_path / "junk.exr").write_bytes(b"not an image")
    (tmp_path / "short.pfm").write_bytes(b"PF\n4 4\n-1.0\n" + b"\0" * 12)
    (tmp_path / "grey.pfm").write_bytes(b"Pf\n1 1\n-1.0\n" + b"\0" * 4)
    found = {name: errors(scene_with(name), tmp_path) for name in ("neg.exr", "inf.pfm", "junk.exr", "short.pfm", "grey.pfm")}
    assert found["neg.exr"] == ["1:35 image file 'neg.exr' holds negative values (the least is -0.5); colours must be >= 0"]
    assert found["inf.pfm"] == ["1:35 image file 'inf.pfm' holds values that are not finite (inf or NaN)"]
    assert found["junk.exr"][0].startswith("1:35 image file 'junk.exr' is not a readable OpenEXR image")
    assert found["short.pfm"] == ["1:35 image file 'short.pfm' is shorter than its header says (4 x 4 colour pixels)"]
    assert found["grey.pfm"][0].startswith("1:35 image file 'grey.pfm' is not a colour PFM file")
