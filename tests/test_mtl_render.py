"""An OBJ of two materials renders with them: bit for bit the scene written by hand with two
meshes of the materials the .mtl mapping chooses (docs/meshes.md, "Materials from a .mtl file")."""

import numpy as np
import pytest

import rt

OBJ = (b"mtllib two.mtl\nv -1 0 0\nv 0 0 0\nv 0 1 0\nv -1 1 0\nv 1 0 0\nv 1 1 0\n"
       b"usemtl red\nf 1 2 3 4\nusemtl blue\nf 2 5 6 3\n")
MTL = b"newmtl red\nKd 0.8 0.1 0.1\nKa 1 1 1\nillum 2\nnewmtl blue\nKd 0.1 0.1 0.8\nKs 0.5 0.5 0.5\nNs 100\nNi 1.45\nillum 2\n"
COMMON = """camera: {look_from: [0, 0.5, 2.2], look_at: [0, 0.5, 0], vfov: 45}
image: {width: 16, aspect_ratio: 1, samples_per_pixel: 4, seed: 3}
background: [1, 1, 1]
"""
# What the mapping gives: red, Kd without Ks -> lambertian; blue, Ks with Ns 100 -> plastic of
# alpha sqrt(2 / 102) and the coat's ior Ni. Each part's vertices are the ones its faces use, in
# file order, so these are the meshes the split makes.
BY_HAND = COMMON + """materials:
  red: {type: lambertian, albedo: [0.8, 0.1, 0.1]}
  blue: {type: plastic, albedo: [0.1, 0.1, 0.8], ior: 1.45, alpha: 0.14002800840280097}
shapes:
  - {type: mesh, vertices: [[-1, 0, 0], [0, 0, 0], [0, 1, 0], [-1, 1, 0]], faces: [[0, 1, 2, 3]], material: red}
  - {type: mesh, vertices: [[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]], faces: [[0, 2, 3, 1]], material: blue}
"""


@pytest.mark.slow
def test_a_two_material_obj_renders_as_the_same_scene_written_by_hand(tmp_path):
    (tmp_path / "two.obj").write_bytes(OBJ)
    (tmp_path / "two.mtl").write_bytes(MTL)
    (tmp_path / "obj.yaml").write_text(COMMON + "shapes: [{type: mesh, file: two.obj}]\n")
    (tmp_path / "hand.yaml").write_text(BY_HAND)
    from_obj = rt.render(str(tmp_path / "obj.yaml"), kernel="general").array
    by_hand = rt.render(str(tmp_path / "hand.yaml"), kernel="general").array
    assert np.array_equal(from_obj, by_hand)
    # And the two materials are where they belong: the quads fill the middle rows of the image,
    # red on the left, blue on the right (lit by the white background; the noise of 4 samples is
    # far below these margins).
    rows = from_obj[5:11]
    left, right = rows[:, 2:7].reshape(-1, 3).mean(0), rows[:, 9:14].reshape(-1, 3).mean(0)
    assert left[0] > 3 * left[2] and right[2] > 3 * right[0]
