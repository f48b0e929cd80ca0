"""The new materials as a user writes and renders them: image files beside the scene for a
normal map and a packed roughness texture, `rt validate` and `rt render` in fresh processes."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from renderer.film import read_pfm

SCENE = """
camera: {look_from: [0, 1, 4], look_at: [0, 0.4, 0], vfov: 35}
image: {width: 32, aspect_ratio: 1.5, samples_per_pixel: 8, max_depth: 6}
background: [0.6, 0.7, 0.9]
textures:
  bumps: {type: image, file: normals.png}
  packed: {type: image, file: metal_rough.png}
materials:
  ground: {type: lambertian, albedo: [0.5, 0.5, 0.5]}
  coated: {type: plastic, albedo: [0.7, 0.1, 0.1], roughness: {texture: packed, channel: g}MAP}
  lamp: {type: diffuse_light, emit: [8, 8, 8]}
shapes:
  - {type: quad, q: [-3, 0, -3], u: [6, 0, 0], v: [0, 0, 6], material: ground}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: coated}
  - {type: sphere, center: [1, 2, 1], radius: 0.3, material: lamp}
"""


def rt(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, capture_output=True, text=True)


@pytest.mark.slow
def test_a_normal_map_and_a_packed_roughness_image_render_from_the_command_line(tmp_path):
    # A normal map tilted toward +u everywhere, and roughness in the green channel (glTF's packing).
    Image.fromarray(np.tile(np.array([200, 128, 230], np.uint8), (4, 4, 1))).save(tmp_path / "normals.png")
    Image.fromarray(np.tile(np.array([0, 90, 255], np.uint8), (4, 4, 1))).save(tmp_path / "metal_rough.png")
    (tmp_path / "mapped.yaml").write_text(SCENE.replace("MAP", ", normal_map: bumps"))
    (tmp_path / "plain.yaml").write_text(SCENE.replace("MAP", ""))
    checked = rt("validate", "mapped.yaml", cwd=tmp_path)
    assert checked.returncode == 0, checked.stderr
    assert "normal and bump maps: on" in checked.stdout and "textured parameters: on" in checked.stdout
    assert "plastics: on" in checked.stdout
    images = {}
    for name in ("mapped", "plain"):
        out = rt("render", f"{name}.yaml", "-o", f"{name}.png", "--hdr", f"{name}.pfm", "--seed", "3", cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        assert "Traceback" not in out.stderr
        images[name] = read_pfm(tmp_path / f"{name}.pfm")
    for image in images.values():
        assert np.isfinite(image).all() and image.min() >= 0 and image.mean() > 0.05
    # The same seed, so the same random numbers: only the map tells the two apart, on the sphere.
    differs = np.abs(images["mapped"] - images["plain"]).max(axis=2) > 1e-9
    assert 0.02 < differs.mean() < 0.6, differs.mean()
