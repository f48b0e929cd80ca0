"""rt import: glTF 2.0 files built here (pygltflib + numpy) imported, checked for the scene they
write (values), for hostile input (one clear error, nothing written, nothing large allocated),
through the command in a fresh process, and (slow) rendered against the same scene by hand."""

from __future__ import annotations

import base64
import json
import math
import os
import struct
import subprocess
import sys
import tracemalloc
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pygltflib")

from rt.importing import import_gltf  # noqa: E402
from scenefmt.gltf_read import GltfProblem  # noqa: E402
from scenefmt.meshfile import read_ply  # noqa: E402

from .gltf_models import QUAD_INDICES, QUAD_NORMALS, QUAD_POSITIONS, QUAD_UVS, UBYTE, Builder, png  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def scene_of(path: Path) -> dict:
    import yaml

    return yaml.safe_load(path.read_text(encoding="utf-8"))


def validated(path: Path):
    from scenefmt.validation import load_source

    return load_source(path, [], None, [])


def quad_model(tmp_path: Path, **mesh_kw) -> Path:
    b = Builder()
    mesh = b.mesh(QUAD_POSITIONS, QUAD_INDICES, **mesh_kw)
    b.node(mesh=mesh, translation=[0.5, 0, -2])
    return b.save_glb(tmp_path / "quad.glb")


# --- geometry ---------------------------------------------------------------------------------


def test_indexed_quad_becomes_one_ply_with_normals_and_flipped_uvs(tmp_path):
    model = quad_model(tmp_path, normals=QUAD_NORMALS, uvs=QUAD_UVS)
    result = import_gltf(model, tmp_path / "out.yaml")
    assert (result.meshes, result.triangles) == (1, 2)
    data = scene_of(tmp_path / "out.yaml")
    (shape,) = data["shapes"]
    assert shape["type"] == "mesh" and shape["smooth"] is True
    assert shape["transform"] == [{"translate": [0.5, 0, -2]}]
    mesh = read_ply(tmp_path / shape["file"])
    np.testing.assert_array_equal(mesh.vertices, QUAD_POSITIONS)
    np.testing.assert_array_equal(mesh.faces, QUAD_INDICES.reshape(-1, 3))
    np.testing.assert_array_equal(mesh.normals, QUAD_NORMALS)
    # glTF's v runs down the image; ours up.
    np.testing.assert_array_equal(mesh.uvs, np.stack([QUAD_UVS[:, 0], 1 - QUAD_UVS[:, 1]], 1))
    # The default glTF material (no material on the primitive): white, metallic 1, roughness 1.
    assert data["materials"][shape["material"]] == {"type": "principled", "base_color": [1, 1, 1], "metallic": 1, "roughness": 1}
    validated(tmp_path / "out.yaml")


def test_unindexed_triangles_strips_and_fans(tmp_path):
    b = Builder()
    corners = QUAD_POSITIONS[QUAD_INDICES]  # six vertices, no index buffer
    plain = b.mesh(corners, name="plain")
    strip = b.mesh(QUAD_POSITIONS[[0, 1, 3, 2]], indices=[0, 1, 2, 3], mode=5, name="strip", index_type=UBYTE)
    fan = b.mesh(QUAD_POSITIONS, indices=[0, 1, 2, 3], mode=6, name="fan")
    lines = b.mesh(QUAD_POSITIONS, mode=1, name="lines")
    for m in (plain, strip, fan, lines):
        b.node(mesh=m)
    result = import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml")
    assert result.meshes == 3 and result.triangles == 6
    assert any("lines are skipped" in w for w in result.warnings)
    meshes = {Path(s["file"]).stem: read_ply(tmp_path / s["file"]) for s in scene_of(tmp_path / "m.yaml")["shapes"]}
    np.testing.assert_array_equal(meshes["plain"].faces, [[0, 1, 2], [3, 4, 5]])
    np.testing.assert_array_equal(meshes["strip"].faces, [[0, 1, 2], [1, 3, 2]])  # the second turned back to one winding
    np.testing.assert_array_equal(meshes["fan"].faces, [[0, 1, 2], [0, 2, 3]])
    for mesh in meshes.values():  # every triangle faces +z, as the quad does
        a, b_, c = (mesh.vertices[mesh.faces[:, k]] for k in range(3))
        assert (np.cross(b_ - a, c - a)[:, 2] > 0).all()


def test_gltf_with_bin_file_and_with_data_uri(tmp_path):
    for embed in (False, True):
        b = Builder()
        b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES))
        folder = tmp_path / f"embed{embed}"
        folder.mkdir()
        model = b.save_gltf(folder / "m.gltf", embed=embed)
        import_gltf(model, folder / "s.yaml")
        mesh = read_ply(folder / "s_assets" / "mesh0.ply")
        np.testing.assert_array_equal(mesh.vertices, QUAD_POSITIONS)


# --- materials and textures -------------------------------------------------------------------


def test_principled_material_with_textures_and_extensions(tmp_path):
    b = Builder()
    g = b.g
    colour = b.image_texture(png(np.full((2, 2, 3), 188)))  # sRGB 188 is linear 0.5029
    packed = b.image_texture(png(np.zeros((2, 2, 3))))
    normal = b.image_texture(png(np.full((2, 2, 3), [128, 128, 255])))
    emissive = b.image_texture(png(np.full((2, 2, 3), 255)))
    mat = b.material(
        name="painted metal",
        pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[0.5, 1.0, 1.0, 1.0], baseColorTexture=g.TextureInfo(index=colour),
            metallicFactor=0.75, roughnessFactor=0.25, metallicRoughnessTexture=g.TextureInfo(index=packed)),
        normalTexture=g.NormalMaterialTexture(index=normal, scale=0.5),
        emissiveFactor=[0.25, 0.25, 0.25], emissiveTexture=g.TextureInfo(index=emissive),
        doubleSided=True,
        extensions={
            "KHR_materials_emissive_strength": {"emissiveStrength": 8.0},
            "KHR_materials_transmission": {"transmissionFactor": 0.5},
            "KHR_materials_ior": {"ior": 1.33},
            "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1.0, 0.5, 0.25]},
            "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.125},
        },
    )
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, uvs=QUAD_UVS, material=mat))
    import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml")
    data = scene_of(tmp_path / "m.yaml")
    m = data["materials"]["m_painted_metal"]
    tex = data["textures"]
    assert m["metallic"] == {"texture": m["roughness"]["texture"], "channel": "b", "scale": 0.75}
    assert m["roughness"]["channel"] == "g" and m["roughness"]["scale"] == 0.25
    assert tex[m["metallic"]["texture"]]["colorspace"] == "linear"
    assert tex[m["normal_map"]]["colorspace"] == "linear" and m["normal_scale"] == 0.5
    assert tex[m["base_color"]]["colorspace"] == "srgb" and tex[m["emission"]]["colorspace"] == "srgb"
    # A grey emissive factor becomes the strength: 0.25 x 8.
    assert m["emission_strength"] == 2.0
    assert (m["transmission"], m["thin_walled"], m["ior"]) == (0.5, True, 1.33)
    assert (m["specular"], m["specular_color"]) == (0.5, [1.0, 0.5, 0.25])
    assert (m["clearcoat"], m["clearcoat_roughness"]) == (1.0, 0.125)
    # The base colour factor is baked into the image: linear 0.5029 x 0.5 in red, unchanged in green.
    from renderer.textures import load_image_texels

    texels = load_image_texels(tmp_path / tex[m["base_color"]]["file"], "srgb")
    assert texels[0, 0, 0] == pytest.approx(0.5029 * 0.5, abs=0.003)
    assert texels[0, 0, 1] == pytest.approx(0.5029, abs=0.001)
    validated(tmp_path / "m.yaml")


def test_what_is_ignored_is_said(tmp_path):
    b = Builder()
    g = b.g
    mat = b.material(alphaMode="BLEND", doubleSided=False, extensions={"KHR_materials_sheen": {}})
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, material=mat))
    result = import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml")
    text = "\n".join(result.warnings)
    assert "alphaMode" in text and "doubleSided" in text and "'KHR_materials_sheen' is ignored" in text
    header = (tmp_path / "m.yaml").read_text().split("version:")[0]
    assert "Ignored: transparency by alpha" in header


# --- nodes, lights, cameras -------------------------------------------------------------------


def test_reused_mesh_in_a_hierarchy_is_one_ply_and_two_instances(tmp_path):
    b = Builder()
    mesh = b.mesh(QUAD_POSITIONS, QUAD_INDICES, name="leaf")
    a = b.node(root=False, mesh=mesh, translation=[1, 0, 0])
    c = b.node(root=False, mesh=mesh, matrix=[2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 5, 0, 1])  # column-major
    b.node(children=[a, c], rotation=[0, math.sin(math.pi / 4), 0, math.cos(math.pi / 4)], translation=[0, 0, -3])
    import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml")
    data = scene_of(tmp_path / "m.yaml")
    assert list(data["groups"]) == ["m_leaf"]
    assert len(list((tmp_path / "m_assets").glob("*.ply"))) == 1
    first, second = data["shapes"]
    assert first["type"] == second["type"] == "instance"
    # Parent: a quarter turn about +y then a move to z = -3; children: x + 1, and scale 2 then y + 5.
    rot = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)
    want1 = np.hstack([rot, (rot @ [1, 0, 0] + [0, 0, -3])[:, None]])
    want2 = np.hstack([2 * rot, (rot @ [0, 5, 0] + [0, 0, -3])[:, None]])
    np.testing.assert_allclose(first["transform"][0]["matrix"], want1, atol=1e-12)
    np.testing.assert_allclose(second["transform"][0]["matrix"], want2, atol=1e-12)
    validated(tmp_path / "m.yaml")


def test_punctual_lights_and_camera(tmp_path):
    b = Builder()
    g = b.g
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES))
    b.lights([
        {"type": "point", "color": [1, 0.5, 0.25], "intensity": 683 * 4, "range": 10},
        {"type": "spot", "intensity": 683, "spot": {"innerConeAngle": 0.25, "outerConeAngle": 0.5}},
        {"type": "directional", "intensity": 683 * 2},
    ])
    b.node(translation=[0, 2, 0], extensions={"KHR_lights_punctual": {"light": 0}})
    # A spot turned a quarter about +x: its -z axis now points down (-y).
    q = [-math.sin(math.pi / 4), 0, 0, math.cos(math.pi / 4)]
    b.node(translation=[1, 3, 0], rotation=q, extensions={"KHR_lights_punctual": {"light": 1}})
    b.node(extensions={"KHR_lights_punctual": {"light": 2}})
    b.gltf.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(yfov=math.radians(30), aspectRatio=2.0, znear=0.1)))
    b.node(camera=0, translation=[0, 1, 6])
    result = import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml")
    assert any("ranges are ignored" in w for w in result.warnings)
    data = scene_of(tmp_path / "m.yaml")
    point, spot, sun = data["lights"]
    assert point == {"type": "point", "position": [0, 2, 0], "intensity": [4, 2, 1]}
    assert spot["position"] == [1, 3, 0] and spot["intensity"] == [1, 1, 1]
    np.testing.assert_allclose(spot["direction"], [0, -1, 0], atol=1e-12)
    assert spot["cutoff_angle"] == pytest.approx(math.degrees(0.5)) and spot["beam_width"] == pytest.approx(math.degrees(0.25))
    assert sun == {"type": "directional", "direction": [0, 0, -1], "irradiance": [2, 2, 2]}
    cam = data["camera"]
    assert cam["look_from"] == [0, 1, 6] and cam["vfov"] == pytest.approx(30)
    np.testing.assert_allclose(np.subtract(cam["look_at"], cam["look_from"]) / 6, [0, 0, -1])
    assert data["image"]["aspect_ratio"] == 2 and data["background"] == [0, 0, 0]
    validated(tmp_path / "m.yaml")


def test_without_camera_or_light_the_model_is_framed_under_the_sky(tmp_path):
    model = quad_model(tmp_path)
    import_gltf(model, tmp_path / "q.yaml")
    data = scene_of(tmp_path / "q.yaml")
    assert data["background"] == {"type": "sky"}
    cam = data["camera"]
    centre = np.array([0.5, 0, -2])
    np.testing.assert_allclose(cam["look_at"], centre)
    # The bounding sphere (radius sqrt(2)) fits the vertical field of view.
    distance = np.linalg.norm(np.subtract(cam["look_from"], centre))
    assert math.degrees(math.asin(math.sqrt(2) / distance)) < cam["vfov"] / 2
    assert "frames the model's bounds" in (tmp_path / "q.yaml").read_text()


def test_a_part_file_is_included_by_another_scene(tmp_path):
    b = Builder()
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, material=b.material(name="paint")))
    b.lights([{"type": "point"}])
    b.node(extensions={"KHR_lights_punctual": {"light": 0}})
    result = import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "chair.yaml", part=True)
    assert any("--part" in w for w in result.warnings)
    assert set(scene_of(tmp_path / "chair.yaml")) == {"version", "materials", "shapes"}
    main = tmp_path / "room.yaml"
    main.write_text("version: 1\ninclude: chair.yaml\ncamera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\n"
                    "lights: [{type: point, position: [0, 2, 2], intensity: 3}]\n", encoding="utf-8")
    loaded = validated(main)
    assert "chair_paint" in loaded.scene.materials


# --- files: never half-written, never over the input ------------------------------------------


def test_refuses_to_replace_without_force_and_never_the_input(tmp_path):
    model = quad_model(tmp_path)
    out = tmp_path / "q.yaml"
    import_gltf(model, out)
    first = out.read_text()
    with pytest.raises(GltfProblem, match="exists: give --force"):
        import_gltf(model, out)
    import_gltf(model, out, force=True, width=100)
    assert "width: 100" in out.read_text() and out.read_text() != first
    with pytest.raises(GltfProblem, match="give -o a name ending in .yaml"):
        import_gltf(model, tmp_path / "quad.glb", force=True)
    assert model.read_bytes()[:4] == b"glTF"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["q.yaml", "q_assets", "quad.glb"]


# --- hostile files ----------------------------------------------------------------------------


def _glb(doc: dict, blob: bytes = b"") -> bytes:
    """A GLB container around a JSON document and a BIN chunk, lengths as they really are."""
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
    if blob:
        chunks += struct.pack("<II", len(blob), 0x004E4942) + blob
    return b"glTF" + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def _triangle_doc(**changes) -> tuple[dict, bytes]:
    blob = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes()
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(blob)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    for path, value in changes.items():
        where = doc
        keys = path.split(".")
        for k in keys[:-1]:
            where = where[int(k)] if k.isdigit() else where[k]
        where[int(keys[-1]) if keys[-1].isdigit() else keys[-1]] = value
    return doc, blob


HOSTILE = {
    "huge buffer": (dict(**{"buffers.0.byteLength": 10**12}), "outside|declares"),
    "huge count": (dict(**{"accessors.0.count": 2**31}), "needs bytes"),
    "accessor past its view": (dict(**{"accessors.0.byteOffset": 8}), "needs bytes 8 to 44"),
    "view past its buffer": (dict(**{"bufferViews.0.byteLength": 37}), "reaches byte 37 of buffer 0"),
    "wide stride": (dict(**{"bufferViews.0.byteStride": 252}), "needs bytes"),
    "bad accessor index": (dict(**{"meshes.0.primitives.0.attributes.POSITION": 7}), "accessor is 7, outside"),
    "cycle": (dict(**{"nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}]}), "reached twice"),
    "shared child": (dict(**{"nodes": [{"children": [2]}, {"children": [2]}, {"mesh": 0}], "scenes": [{"nodes": [0, 1]}]}), "reached twice"),
    "not a number": (dict(**{"nodes.0.translation": [0, "x", 0]}), "does not have glTF's structure"),
    "absolute uri": (dict(**{"buffers.0.uri": "/etc/passwd"}), "absolute paths and URLs are refused"),
    "escaping uri": (dict(**{"buffers.0.uri": "../../secret.bin"}), "outside the model's folder"),
    "url": (dict(**{"buffers.0.uri": "https://example.com/a.bin"}), "absolute paths and URLs are refused"),
    "bad base64": (dict(**{"buffers.0.uri": "data:application/octet-stream;base64,@@@@"}), "not valid base64"),
    "short data uri": (dict(**{"buffers.0.uri": "data:application/octet-stream;base64,AAAA"}), "declares 36 bytes but holds 3"),
    "long data uri": (dict(**{"buffers.0.uri": "data:application/octet-stream;base64," + "A" * 4000}), "more than the 39 expected"),
    "not glTF 2": (dict(**{"asset.version": "1.0"}), "not glTF 2.0"),
    "sparse": (dict(**{"accessors.0.sparse": {"count": 1}}), "sparse"),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_files_give_one_clear_error_and_write_nothing(tmp_path, case):
    changes, message = HOSTILE[case]
    doc, blob = _triangle_doc(**changes)
    model = tmp_path / "models" / "bad.glb"
    model.parent.mkdir()
    model.write_bytes(_glb(doc, blob))
    out = tmp_path / "out"
    out.mkdir()
    tracemalloc.start()
    try:
        with pytest.raises(GltfProblem, match=message) as caught:
            import_gltf(model, out / "s.yaml")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert "\n" not in str(caught.value)
    assert peak < 8 << 20, f"{peak:,} bytes allocated"
    assert list(out.iterdir()) == []


def test_nan_positions_and_lying_glb_chunks(tmp_path):
    doc, blob = _triangle_doc()
    bad = bytearray(blob)
    bad[0:4] = struct.pack("<f", float("nan"))
    cases = {
        "nan.glb": (_glb(doc, bytes(bad)), "NaN or infinite"),
        "chunk.glb": (_glb(doc, blob)[:-20], "declares"),
        "json_nan.glb": (_glb({**doc, "nodes": [{"mesh": 0, "translation": [float("nan"), 0, 0]}]}, blob), "NaN, which glTF does not allow"),
    }
    glb = bytearray(_glb(doc, blob))
    glb[8:12] = struct.pack("<I", 10**9)
    cases["header.glb"] = (bytes(glb), "declares 1,000,000,000 bytes")
    for name, (data, message) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(GltfProblem, match=message):
            import_gltf(tmp_path / name, tmp_path / "s.yaml")
    assert not (tmp_path / "s.yaml").exists() and not (tmp_path / "s_assets").exists()


def test_image_uri_outside_the_folder_is_refused(tmp_path):
    b = Builder()
    g = b.g
    b.gltf.images.append(g.Image(uri="../outside.png"))
    b.gltf.textures.append(g.Texture(source=0))
    mat = b.material(pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorTexture=g.TextureInfo(index=0)))
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, material=mat))
    (tmp_path / "outside.png").write_bytes(png(np.zeros((1, 1, 3))))
    (tmp_path / "m").mkdir()
    model = b.save_glb(tmp_path / "m" / "m.glb")
    with pytest.raises(GltfProblem, match="image 0 names .*, which lies outside the model's folder"):
        import_gltf(model, tmp_path / "m" / "s.yaml")


# --- the command ------------------------------------------------------------------------------


def _rt(*args, cwd, env=None):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


def test_rt_import_in_a_fresh_process(tmp_path):
    quad_model(tmp_path)
    done = _rt("import", "quad.glb", "-o", "quad.yaml", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "wrote quad.yaml (1 mesh file(s), 2 triangles" in done.stdout
    check = _rt("validate", "quad.yaml", cwd=tmp_path)
    assert check.returncode == 0 and "2 triangles" in check.stdout
    again = _rt("import", "quad.glb", "-o", "quad.yaml", cwd=tmp_path)
    assert again.returncode == 1 and again.stderr.startswith("error: quad.glb:") and "Traceback" not in again.stderr
    (tmp_path / "junk.glb").write_bytes(b"glTF" + b"\xff" * 30)
    bad = _rt("import", "junk.glb", "-o", "junk.yaml", cwd=tmp_path)
    assert bad.returncode == 1 and "Traceback" not in bad.stderr and bad.stderr.count("\n") == 1


def test_without_pygltflib_the_command_says_what_to_install(tmp_path):
    quad_model(tmp_path)
    blocker = tmp_path / "block"
    blocker.mkdir()
    (blocker / "sitecustomize.py").write_text("import sys\nsys.modules['pygltflib'] = None\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(blocker), str(ROOT)])}
    done = _rt("import", "quad.glb", "-o", "quad.yaml", cwd=tmp_path, env=env)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "pip install '.[gltf]'" in done.stderr and done.stderr.count("\n") == 1
    assert not (tmp_path / "quad.yaml").exists()


# --- rendering ---------------------------------------------------------------------------------


HAND_WRITTEN = """version: 1
camera: {look_from: [0, 0.5, 4], look_at: [0, 0, 0], vfov: 40}
image: {width: 24, aspect_ratio: 1, samples_per_pixel: 4, max_depth: 4}
background: [0, 0, 0]
materials:
  red: {type: principled, base_color: [0.75, 0.25, 0.25], metallic: 0, roughness: 0.5}
shapes:
- type: mesh
  vertices: [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
  faces: [[0, 1, 2], [0, 2, 3]]
  material: red
  transform: [{translate: [0, 0, -0.5]}]
lights:
- {type: point, position: [0, 1, 2], intensity: [3, 3, 3]}
"""


@pytest.mark.slow
def test_imported_scene_renders_as_the_same_scene_written_by_hand(tmp_path):
    import rt

    b = Builder()
    g = b.g
    mat = b.material(pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.75, 0.25, 0.25, 1], metallicFactor=0.0,
                                                                  roughnessFactor=0.5), doubleSided=True)
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, material=mat), translation=[0, 0, -0.5])
    b.lights([{"type": "point", "intensity": 3 * 683}])
    b.node(translation=[0, 1, 2], extensions={"KHR_lights_punctual": {"light": 0}})
    b.gltf.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(yfov=math.radians(40), znear=0.1)))
    # Looking from (0, 0.5, 4) at the origin: a turn about +x by atan(0.5 / 4) downward.
    half = -math.atan2(0.5, 4) / 2
    b.node(camera=0, translation=[0, 0.5, 4], rotation=[math.sin(half), 0, 0, math.cos(half)])
    import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml", width=24, samples=4)
    (tmp_path / "hand.yaml").write_text(HAND_WRITTEN, encoding="utf-8")
    overrides = ["image.max_depth=4"]
    imported = np.asarray(rt.render(tmp_path / "m.yaml", kernel="general", seed=3, overrides=overrides).array)
    hand = np.asarray(rt.render(tmp_path / "hand.yaml", kernel="general", seed=3).array)
    assert imported.shape == hand.shape == (24, 24, 3)
    assert hand.mean() > 0.01  # the quad is lit and seen
    # Same geometry, material, light and seed; the camera's look_at differs only along the view
    # axis (and by float rounding), so the images agree to rounding.
    np.testing.assert_allclose(imported.mean(axis=(0, 1)), hand.mean(axis=(0, 1)), rtol=1e-6)
    np.testing.assert_allclose(imported, hand, atol=1e-6)


def _rich_document(tmp_path: Path) -> tuple[dict, bytes]:
    """The JSON and BIN chunk of a model that uses most of what rt import reads."""
    b = Builder()
    g = b.g
    t = b.image_texture(png(np.full((2, 2, 3), 100)))
    m = b.material(
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.5, 1, 1, 1], baseColorTexture=g.TextureInfo(index=t),
                                                    metallicRoughnessTexture=g.TextureInfo(index=t)),
        normalTexture=g.NormalMaterialTexture(index=t), emissiveFactor=[1, 0.5, 0], emissiveTexture=g.TextureInfo(index=t),
        extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatTexture": {"index": 0}},
                    "KHR_materials_transmission": {"transmissionFactor": 0.5, "transmissionTexture": {"index": 0}}})
    mesh = b.mesh(QUAD_POSITIONS, QUAD_INDICES, QUAD_NORMALS, QUAD_UVS, material=m)
    child = b.node(root=False, mesh=mesh, translation=[1, 0, 0])
    b.node(mesh=mesh, children=[child], rotation=[0, 0, 0, 1], scale=[1, 2, 1])
    b.lights([{"type": "spot", "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.3}}, {"type": "point"}])
    b.node(extensions={"KHR_lights_punctual": {"light": 0}})
    b.gltf.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(yfov=0.7, aspectRatio=1.2, znear=0.1)))
    b.node(camera=0, translation=[0, 0, 4])
    raw = b.save_glb(tmp_path / "rich.glb").read_bytes()
    size = struct.unpack_from("<I", raw, 12)[0]
    return json.loads(raw[20:20 + size]), raw[20 + size + 8:]


def test_damaged_documents_give_a_scene_that_validates_or_one_error(tmp_path):
    """Values of the wrong kind or range put anywhere in a document (a fixed-seed fuzz): the import
    either writes a scene that `rt validate` accepts or raises GltfProblem, never anything else."""
    import copy
    import random

    from scenefmt.diagnostics import SceneError

    doc, blob = _rich_document(tmp_path)

    def paths(x, at=()):
        if at:
            yield at
        items = x.items() if isinstance(x, dict) else enumerate(x) if isinstance(x, list) else ()
        for k, v in items:
            yield from paths(v, at + (k,))

    where = list(paths(doc))
    values = [None, -1, 0, 1, 2**40, 1.5, -1e300, "x", [], {}, [1, 2], True, {"index": 9}, [0, 0, 0, 0]]
    rng = random.Random(35)
    outcomes = Counter()
    for trial in range(60):
        damaged = copy.deepcopy(doc)
        for _ in range(rng.randint(1, 3)):
            path = rng.choice(where)
            try:
                target = damaged
                for k in path[:-1]:
                    target = target[k]
                target[path[-1]] = copy.deepcopy(rng.choice(values))
            except (KeyError, IndexError, TypeError):
                continue  # an earlier change removed the place
        model = tmp_path / f"d{trial}.glb"
        model.write_bytes(_glb(damaged, blob))
        try:
            import_gltf(model, tmp_path / f"d{trial}.yaml")
        except GltfProblem as exc:
            assert "\n" not in str(exc)
            outcomes["refused"] += 1
            continue
        try:
            validated(tmp_path / f"d{trial}.yaml")
        except SceneError as exc:
            pytest.fail(f"trial {trial}: the imported scene does not validate: {exc}")
        outcomes["imported"] += 1
    assert outcomes["refused"] > 5 and outcomes["imported"] > 5, outcomes


def test_image_files_beside_a_gltf_are_copied_as_they_are(tmp_path):
    from PIL import Image

    b = Builder()
    g = b.g
    buf = __import__("io").BytesIO()
    Image.fromarray(np.full((4, 4, 3), 90, np.uint8)).save(buf, format="JPEG")
    jpeg = buf.getvalue()
    (tmp_path / "maps").mkdir()
    (tmp_path / "maps" / "wood grain.jpg").write_bytes(jpeg)
    b.gltf.images.append(g.Image(uri="maps/wood%20grain.jpg", name="wood"))
    b.gltf.textures.append(g.Texture(source=0))
    mat = b.material(pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorTexture=g.TextureInfo(index=0)),
                     extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_volume": {}})
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, uvs=QUAD_UVS, material=mat))
    model = b.save_gltf(tmp_path / "m.gltf")
    import_gltf(model, tmp_path / "m.yaml")
    data = scene_of(tmp_path / "m.yaml")
    (texture,) = data["textures"].values()
    assert texture == {"type": "image", "file": "m_assets/wood.jpg", "colorspace": "srgb"}
    assert (tmp_path / texture["file"]).read_bytes() == jpeg
    (material,) = data["materials"].values()
    assert material["transmission"] == 1 and "thin_walled" not in material  # a solid: KHR_materials_volume
    validated(tmp_path / "m.yaml")


@pytest.mark.slow
def test_an_imported_texture_is_upright_in_the_render(tmp_path):
    """glTF's texture origin is the image's top-left: a quad whose top corners have v = 0 shows the
    image's top row at its top. The image is red above, blue below; so must the render be."""
    import rt

    image = np.zeros((8, 8, 3), np.uint8)
    image[:4, :, 0] = 255  # top half red
    image[4:, :, 2] = 255  # bottom half blue
    b = Builder()
    g = b.g
    t = b.image_texture(png(image))
    mat = b.material(pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorTexture=g.TextureInfo(index=t), metallicFactor=0.0,
                                                                  roughnessFactor=1.0), emissiveFactor=[0, 0, 0])
    b.node(mesh=b.mesh(QUAD_POSITIONS, QUAD_INDICES, uvs=QUAD_UVS, material=mat))
    b.gltf.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(yfov=math.radians(30), znear=0.1)))
    b.node(camera=0, translation=[0, 0, 3])
    import_gltf(b.save_glb(tmp_path / "m.glb"), tmp_path / "m.yaml", width=16, samples=4)
    img = np.asarray(rt.render(tmp_path / "m.yaml", kernel="general", seed=1).array)
    top, bottom = img[2:6].mean(axis=(0, 1)), img[10:14].mean(axis=(0, 1))
    assert top[0] > 5 * top[2] and bottom[2] > 5 * bottom[0], (top, bottom)
