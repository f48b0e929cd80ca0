"""OBJ materials: the .mtl reader, its mapping to our materials and what it drops, the OBJ's
`usemtl` per face, and a mesh cut by material in the graph (docs/meshes.md, "Materials from a
.mtl file")."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from scenefmt import mtl
from scenefmt.diagnostics import SceneError
from scenefmt.meshfile import read_obj, split_by_material
from scenefmt.mtl import MtlProblem, alpha_of_exponent, material_of, parse_mtl, read_mtl
from scenefmt.validation import loads


def one(text: str, maps=None):
    """(model, warnings) of the only entry of library `text`; maps resolve to 'ABS/<name>'."""
    library = parse_mtl(text.encode())
    (entry,) = library.materials.values()
    return material_of(entry, lambda key, ref: f"/abs/{ref.file}" if maps is None else maps(key, ref))


# --- the mapping -------------------------------------------------------------------------------


def test_each_rule_of_the_mapping_gives_its_material():
    model, warnings = one("newmtl a\nKd 0.8 0.1 0.1\nKs 0 0 0\nNs 250\nNi 1.45\nillum 2\n")
    assert model.type == "lambertian" and model.albedo == (0.8, 0.1, 0.1) and warnings == []

    model, _ = one("newmtl a\nKd 0.1 0.2 0.3\nKs 0.5 0.5 0.5\nNs 100\nNi 1.45\n")
    assert model.type == "plastic" and model.albedo == (0.1, 0.2, 0.3)
    assert model.alpha == pytest.approx(math.sqrt(2 / 102)) and model.ior == 1.45

    model, _ = one("newmtl a\nKd 0.1 0.2 0.3\nKs 0.5 0.5 0.5\nNs 100\nillum 1\n")
    assert model.type == "lambertian"  # illum 1: no highlight asked for

    model, _ = one("newmtl a\nKd 0.5 0.5 0.5\nKs 0.9 0.8 0.7\nNs 1000\nillum 3\n")
    assert model.type == "metal" and model.albedo == (0.9, 0.8, 0.7)
    assert model.fuzz == pytest.approx(math.sqrt(2 / 1002))

    model, warnings = one("newmtl a\nKd 1 1 1\nNi 1.33\nd 0.5\n")
    assert model.type == "dielectric" and model.ior == 1.33
    assert (4, "partial opacity (d 0.5) has no equivalent: the surface is clear glass") in warnings

    model, warnings = one("newmtl a\nillum 7\nNi 1\nTr 0\n")
    assert model.type == "dielectric" and model.ior == 1.5
    assert (1, "a transparent material without Ni above 1 gets ior 1.5") in warnings

    model, _ = one("newmtl a\nKd 0 0 0\nKe 10 8 6\n")
    assert model.type == "diffuse_light" and model.emit == (10, 8, 6)

    model, _ = one("newmtl a\nKd 0.5 0.4 0.3\nKe 2 2 2\n")
    assert model.type == "principled" and model.emission == (2, 2, 2) and model.base_color == (0.5, 0.4, 0.3)

    model, _ = one("newmtl a\nKd 0.9 0.6 0.2\nPr 0.3\nPm 1\nPc 0.5\nPcr 0.1\nNi 1.6\n")
    assert model.type == "principled" and (model.metallic, model.roughness, model.clearcoat, model.clearcoat_roughness) == (1, 0.3, 0.5, 0.1)
    assert model.ior == 1.6


def test_maps_become_image_textures_in_their_colour_spaces():
    model, warnings = one("newmtl a\nKd 1 1 1\nmap_Kd -s 2 2 1 tex\\wood grain.png\nnorm n.png\n")
    assert model.albedo.type == "image" and model.albedo.colorspace == "srgb"
    assert model.albedo.file == "/abs/tex/wood grain.png"  # a Windows exporter's \ read as /, spaces kept
    assert model.normal_map.file == "/abs/n.png" and model.normal_map.colorspace == "linear"
    assert warnings == [(3, "map_Kd: option -s has no equivalent and is dropped")]

    model, warnings = one("newmtl a\nbump b.png\n")
    assert model.bump_map is None
    assert warnings[0][0] == 2 and "without -bm gives no height" in warnings[0][1]
    model, warnings = one("newmtl a\nmap_bump -bm 0.02 b.png\n")
    assert model.bump_map.file == "/abs/b.png" and model.bump_height == 0.02 and warnings == []


def test_what_has_no_equivalent_is_named_with_its_line_once_per_keyword():
    library = parse_mtl(b"Kd 1 1 1\nnewmtl a\nKa 1 1 1\nKd 2 0.5 0.5\nfoo 1\nnewmtl b\nKa 0 0 0\nTf 1 1 1\nnewmtl a\n")
    assert library.warnings == [
        (1, "Kd before any newmtl has no equivalent and is dropped"),
        (3, "Ka (ambient colour: a path tracer has no ambient term) has no equivalent and is dropped (and 1 more line)"),
        (5, "unknown statement 'foo' has no equivalent and is dropped"),
        (8, "Tf (transmission filter colour) has no equivalent and is dropped"),
        (9, "material 'a' is defined again (first on line 2); the first definition is used"),
    ]
    model, warnings = material_of(library.materials["a"], lambda key, ref: None)
    assert model.albedo == (1.0, 0.5, 0.5)
    assert warnings == [(4, "Kd 2 is above 1, the most a surface reflects: clamped to 1")]
    # A statement of a hostile file is never quoted unless it looks like a word.
    library = parse_mtl(b"newmtl a\nsecret:hunter2/xyz 1\n")
    assert library.warnings == [(2, "unknown statement a word of 18 characters (not shown) has no equivalent and is dropped")]


def test_the_phong_exponent_conversion_is_bounded():
    assert alpha_of_exponent(0) == 1.0
    assert alpha_of_exponent(1e12) == 1e-3
    assert alpha_of_exponent(98) == pytest.approx(math.sqrt(0.02))


# --- hostile libraries -------------------------------------------------------------------------


@pytest.mark.parametrize("text, message", [
    (b"newmtl a\nKd 1 x 1\n", "line 2: Kd expects numbers: 'x' is not one"),
    (b"newmtl a\nKd 1 1\n", "line 2: Kd needs 1 or 3 numbers, found 2"),
    (b"newmtl a\nNs nan\n", "line 2: Ns has a NaN or infinite value"),
    (b"newmtl a\nKd -1 0 0\n", "line 2: Kd must not be negative, found -1"),
    (b"newmtl a\nillum 11\n", "line 2: illum must be a whole number from 0 to 10, found 11"),
    (b"newmtl\n", "line 1: newmtl needs a name"),
    (b"newmtl " + b"x" * 2000 + b"\n", "line 1: a material name of 2,000 characters, more than the 1,024 allowed"),
    (b"newmtl a\nmap_Kd -zz 1 a.png\n", "line 2: map_Kd: unknown option '-zz'"),
    (b"newmtl a\nmap_Kd -s 1\n", "line 2: map_Kd names no file"),
    (b"newmtl a\nbump -bm nan b.png\n", "line 2: bump: option -bm has a NaN or infinite value"),
    (b"newmtl a\n\x00\x01binary", "not a material library text file: byte 10 is a NUL byte"),
])
def test_a_malformed_library_is_a_clear_error_naming_its_line(text, message):
    with pytest.raises(MtlProblem) as info:
        parse_mtl(text)
    assert str(info.value) == message


def test_a_library_is_bounded_in_size_and_entries(tmp_path, monkeypatch):
    big = tmp_path / "big.mtl"
    with open(big, "wb") as fh:
        fh.truncate(mtl.MAX_MTL_BYTES + 1)  # sparse: nothing of it is written
    with pytest.raises(MtlProblem, match="larger than the 8,388,608 bytes allowed"):
        read_mtl(big)
    with pytest.raises(MtlProblem, match="a directory"):
        read_mtl(tmp_path)
    monkeypatch.setattr(mtl, "MAX_MTL_MATERIALS", 3)
    with pytest.raises(MtlProblem, match="line 4: more than the 3 materials allowed"):
        parse_mtl(b"newmtl a\nnewmtl b\nnewmtl c\nnewmtl d\n")


# --- the OBJ's usemtl --------------------------------------------------------------------------

OBJ = (b"mtllib two.mtl\nv -1 0 0\nv 0 0 0\nv 0 1 0\nv -1 1 0\nv 1 0 0\nv 1 1 0\n"
       b"usemtl red\nf 1 2 3 4\nusemtl blue # a comment\nf 2 5 6 3\n")


def test_each_triangle_keeps_its_usemtl_in_both_readers():
    fast = read_obj(OBJ + b"f 1 1 2\nusemtl red\nf 1 2 3\n")  # a repeated corner: dropped with its label
    slow = read_obj(OBJ + b"f 1 1 2\nusemtl red\nf 1 2 \\\n 3\n")  # a continuation: the line-by-line reader
    for mesh in (fast, slow):
        assert mesh.mtllibs == ((1, "two.mtl"),) and mesh.material_names == ("red", "blue")
        assert mesh.face_material.tolist() == [0, 0, 1, 1, 0] and len(mesh.faces) == 5 and mesh.degenerate == 1
    assert np.array_equal(fast.faces, slow.faces)
    before = read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl a\nf 1 2 3\n")
    assert before.face_material.tolist() == [-1, 0]
    assert read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").face_material is None


def test_a_mesh_is_split_into_the_meshes_its_materials_make():
    parts = split_by_material(read_obj(OBJ))
    assert [label for label, _ in parts] == [0, 1]
    red, blue = parts[0][1], parts[1][1]
    assert red.vertices.tolist() == [[-1, 0, 0], [0, 0, 0], [0, 1, 0], [-1, 1, 0]] and red.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert blue.vertices.tolist() == [[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]] and blue.faces.tolist() == [[0, 2, 3], [0, 3, 1]]
    # Smooth without normals: each part gets the whole mesh's (the seam's vertices point the same way).
    smooth = split_by_material(read_obj(OBJ), smooth=True)
    assert np.allclose(smooth[0][1].normals, [0, 0, 1]) and np.allclose(smooth[1][1].normals, [0, 0, 1])


# --- through the graph -------------------------------------------------------------------------

MTL = b"newmtl red\nKd 0.8 0.1 0.1\nKa 1 1 1\nnewmtl blue\nKd 0.1 0.1 0.8\nKs 0.5 0.5 0.5\nNs 100\n"


def scene(tmp_path, shapes: str, obj: bytes = OBJ, library: bytes = MTL) -> str:
    (tmp_path / "two.obj").write_bytes(obj)
    if library is not None:
        (tmp_path / "two.mtl").write_bytes(library)
    return "materials: {m: {type: lambertian}}\nshapes:\n" + shapes


def load(tmp_path, text):
    return loads(text, file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)


def errors(tmp_path, text) -> list:
    with pytest.raises(SceneError) as info:
        load(tmp_path, text)
    return [d.message for d in info.value.diagnostics]


def test_an_obj_without_a_material_gets_its_librarys_materials_and_warnings_once(tmp_path):
    text = scene(tmp_path, "  - {type: mesh, file: two.obj}\n  - {type: mesh, file: two.obj, transform: [{translate: [3, 0, 0]}]}\n"
                 "  - {type: sphere, center: [0, 0, 0], radius: 1, material: m}\n")
    loaded = load(tmp_path, text)
    meshes = [n for n in loaded.graph.root.members if n.kind == "mesh"]
    assert [n.material.model.type for n in meshes] == ["lambertian", "plastic"] * 2
    assert meshes[0].material is meshes[2].material  # one material row per library entry
    assert meshes[0].material.model.albedo == (0.8, 0.1, 0.1) and len(meshes[0].mesh.faces) == 2
    said = [(d.path, d.message) for d in loaded.warnings]
    assert said == [(("shapes", 0, "file"), "material library 'two.mtl' line 3: Ka (ambient colour: a path tracer has no "
                                             "ambient term) has no equivalent and is dropped")]


def test_a_material_given_replaces_the_librarys_with_a_note(tmp_path):
    loaded = load(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj, material: m}\n", library=None))
    (node,) = loaded.graph.root.members
    assert node.material.model.type == "lambertian" and len(node.mesh.faces) == 4
    assert [d.message for d in loaded.warnings] == [
        "mesh file 'two.obj' names a material library (mtllib, line 1): the OBJ's materials are not read; the shape's "
        "material: is used for every face"]


def test_an_obj_without_a_library_or_material_is_an_error(tmp_path):
    assert errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", obj=OBJ.replace(b"mtllib two.mtl\n", b""))) == [
        "mesh file 'two.obj' names no material library (mtllib), so the shape needs a `material`"]
    assert errors(tmp_path, "shapes: [{type: mesh, file: a.ply}]\n") == [
        "missing required key 'material' (only a mesh from an .obj file with a material library may leave it out)"]


def test_libraries_and_maps_resolve_inside_the_allowed_folders(tmp_path):
    inner = tmp_path / "inner"
    inner.mkdir()
    (tmp_path / "outside.mtl").write_bytes(MTL)
    (inner / "s.obj").write_bytes(OBJ.replace(b"two.mtl", b"../outside.mtl"))
    found = errors(inner, "shapes: [{type: mesh, file: s.obj}]\n")
    assert len(found) == 1 and found[0].startswith("mesh file 's.obj' line 1: material library '../outside.mtl' is outside")
    found = errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=None))
    assert found == [f"mesh file 'two.obj' line 1: material library 'two.mtl' not found (looked for {tmp_path / 'two.mtl'})"]
    found = errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=MTL + b"map_Kd /etc/passwd\n"))
    assert found == ["mesh file 'two.obj': material library 'two.mtl' line 8: map_Kd: image file '/etc/passwd' is "
                     f"outside the folders this scene may read files from ({tmp_path}); to read it, allow its folder with "
                     "--allow-path DIR (allow_paths=[...] in Python)"]
    found = errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=MTL + b"map_Kd ../x\x1b[2Jy.png\n"))
    assert len(found) == 1 and "\x1b" not in found[0] and "map_Kd: image file (a name of 13 characters, not shown) is outside" in found[0]
    found = errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=MTL + b"map_Kd missing.png\n"))
    assert found == ["mesh file 'two.obj': material library 'two.mtl' line 8: map_Kd: image file 'missing.png' not found "
                     f"(looked for {tmp_path / 'missing.png'})"]
    found = errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=b"newmtl red\nKd 1 q 1\n"))
    assert found == ["mesh file 'two.obj' line 1: material library 'two.mtl' line 2: Kd expects numbers: 'q' is not one"]


def test_a_map_is_read_relative_to_its_library(tmp_path):
    from PIL import Image

    (tmp_path / "lib").mkdir()
    Image.new("RGB", (4, 4), (200, 10, 10)).save(tmp_path / "lib" / "red.png")
    obj = OBJ.replace(b"mtllib two.mtl", b"mtllib lib/two.mtl")
    (tmp_path / "lib" / "two.mtl").write_bytes(MTL + b"map_Kd red.png\n")
    loaded = load(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", obj=obj, library=None))
    blue = loaded.graph.root.members[1].material
    assert blue.model.albedo.file == os.path.abspath(tmp_path / "lib" / "red.png")
    assert blue.textures["albedo"].image_size == (4, 4)


def test_usemtl_naming_nothing_gets_a_grey_lambertian_with_a_warning(tmp_path):
    obj = OBJ.replace(b"usemtl blue", b"usemtl green")
    loaded = load(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", obj=obj))
    assert [n.material.model.type for n in loaded.graph.root.members] == ["lambertian", "lambertian"]
    assert loaded.graph.root.members[1].material.model.albedo == (0.8, 0.8, 0.8)
    assert ("mesh file 'two.obj': usemtl 'green' names no material of its libraries (2 triangles): they get a grey "
            "lambertian (albedo 0.8)") in [d.message for d in loaded.warnings]


def test_rt_validate_shows_the_warnings_in_a_fresh_process(tmp_path):
    (tmp_path / "s.yaml").write_text(scene(tmp_path, "  - {type: mesh, file: two.obj}\n  - {type: sphere, center: [0, 0, 0], "
                                                      "radius: 1, material: m}\n"))
    result = subprocess.run([sys.executable, "-m", "rt", "validate", "s.yaml"], cwd=tmp_path, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert "s.yaml: valid" in result.stdout and "shapes: 3 (2 mesh, 1 sphere)" in result.stdout
    assert "mesh at shapes[0]: 4 vertices, 2 triangles; usemtl 'red': lambertian (from 'two.mtl')" in result.stdout
    assert "mesh at shapes[0]: 4 vertices, 2 triangles; usemtl 'blue': plastic (from 'two.mtl')" in result.stdout
    assert ("warning: shapes[0].file: material library 'two.mtl' line 3: Ka (ambient colour: a path tracer has no ambient "
            "term) has no equivalent and is dropped") in result.stderr
    assert "Traceback" not in result.stderr


def test_rt_validate_says_a_binary_library_is_not_one(tmp_path):
    from typer.testing import CliRunner

    from rt.cli import app

    (tmp_path / "s.yaml").write_text(scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=b"\x00" * 64))
    result = CliRunner().invoke(app, ["validate", str(tmp_path / "s.yaml")])
    assert result.exit_code == 1 and (result.exception is None or isinstance(result.exception, SystemExit))
    assert ("error: shapes[0].file: mesh file 'two.obj' line 1: material library 'two.mtl' not a material library text file: "
            "byte 1 is a NUL byte") in result.stderr


def test_mangled_libraries_give_a_material_or_a_clear_error_never_anything_else():
    import random

    rng = random.Random(35)
    base = MTL + (b"newmtl c\nKd 0.5 0.5 0.5\nKs 1 1 1\nNs 10\nd 0.5\nNi 1.3\nmap_Kd -s 1 1 a.png\nmap_bump -bm 0.1 b.png\n"
                  b"newmtl d\nPr 0.5\nPm 1\nKe 1 2 3\nillum 7\nnorm n.png\n")
    words = [b"Kd", b"Ks", b"Ke", b"Ns", b"Ni", b"d", b"Tr", b"illum", b"Pr", b"Pm", b"map_Kd", b"bump", b"-bm", b"-s", b"nan",
             b"1e999", b"-1", b"2", b"0", b"newmtl", b"\xff\xfe", b"\\", b"#", b"x" * 300]
    for _ in range(400):
        lines = base.split(b"\n")
        for _ in range(rng.randint(1, 4)):
            k = rng.randrange(len(lines))
            action = rng.random()
            if action < 0.4:
                lines[k] = b" ".join(rng.choice(words) for _ in range(rng.randint(1, 5)))
            elif action < 0.7:
                line = bytearray(lines[k] or b" ")
                line[rng.randrange(len(line))] = rng.randrange(1, 256)
                lines[k] = bytes(line)
            else:
                lines.insert(k, rng.choice(lines))
        try:
            library = parse_mtl(b"\n".join(lines))
        except MtlProblem as exc:
            assert exc.line is None or 1 <= exc.line <= len(lines)
            continue
        for entry in library.materials.values():
            model, warnings = material_of(entry, lambda key, ref: "/abs/x.png")
            assert model.type in ("lambertian", "plastic", "metal", "dielectric", "diffuse_light", "principled")
            assert all(isinstance(line, int) and isinstance(text, str) for line, text in warnings)


def test_a_materials_own_checks_are_said_of_its_library_entry(tmp_path):
    (tmp_path / "not_an_image.png").write_bytes(b"hello")
    library = b"newmtl red\nKe 1e13 1 1\nnewmtl blue\nKd 0.1 0.1 0.8\nmap_Kd not_an_image.png\n"
    found = errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=library))
    assert found == [
        "mesh file 'two.obj': material library 'two.mtl' line 1: material 'red': an emitted radiance must be at most 1e+12 "
        "per channel, found 1e+13",
        "mesh file 'two.obj': material library 'two.mtl' line 3: material 'blue': image file 'not_an_image.png' is not a "
        "readable image (not a format Pillow can identify)",
    ]


def test_an_obj_is_bounded_in_libraries_and_materials(tmp_path, monkeypatch):
    monkeypatch.setattr("scenefmt.mesh_materials.MAX_OBJ_MATERIALS", 1)
    assert errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n")) == [
        "mesh file 'two.obj' uses 2 materials (usemtl names), more than the 1 allowed: each becomes a mesh of its own"]
    many = b"mtllib " + b" ".join(b"m%d.mtl" % k for k in range(65)) + b"\n"
    assert errors(tmp_path, scene(tmp_path, "  - {type: mesh, file: two.obj}\n", obj=many + OBJ)) == [
        "mesh file 'two.obj' names 66 material libraries, more than the 64 allowed"]


def test_both_ways_of_renumbering_a_part_give_the_numbers_of_a_sort():
    from scenefmt import meshgen
    from scenefmt.meshfile import MeshData

    vertices, faces = meshgen.icosphere(4)
    labels = np.zeros(len(faces), np.int32)
    labels[[3, 17, 40]] = 1  # a small part (sorted) beside a large one (marked and counted)
    for label, part in split_by_material(MeshData(vertices, faces, face_material=labels)):
        used, renumbered = np.unique(faces[labels == label], return_inverse=True)
        assert np.array_equal(part.vertices, vertices[used]) and np.array_equal(part.faces, renumbered.reshape(-1, 3))
    assert 8 * 9 < len(vertices) < 8 * 3 * (len(faces) - 3)  # so both ways ran


def test_the_library_and_its_maps_are_files_the_scene_reads(tmp_path):
    """What `rt watch` polls and a cluster client sends: the library and its maps are recorded."""
    from PIL import Image

    from scenefmt.files import recording_reads

    Image.new("RGB", (2, 2)).save(tmp_path / "red.png")
    text = scene(tmp_path, "  - {type: mesh, file: two.obj}\n", library=MTL + b"map_Kd red.png\n")
    with recording_reads() as reads:
        load(tmp_path, text)
    assert str(tmp_path / "two.mtl") in reads and str(tmp_path / "red.png") in reads
