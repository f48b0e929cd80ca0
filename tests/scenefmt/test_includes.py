"""`include:`: definitions and shapes merged from other files, and errors placed in the file they are in."""

from pathlib import Path

import pytest

from scenefmt import includes
from scenefmt.diagnostics import SceneError
from scenefmt.validation import load, loads

MAIN = """\
version: 1
include: [parts/materials.yaml, parts/shapes.yaml]
camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}
materials:
  red: {type: lambertian, albedo: [1, 0, 0]}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: red}
"""

MATERIALS = """\
materials:
  glass: {type: dielectric, ior: 1.5}
textures:
  earth: {type: image, file: ../earth.png}
"""

SHAPES = """\
include: [materials.yaml]
shapes:
  - {type: sphere, center: [2, 0, 0], radius: 1, material: glass}
  - {type: sphere, center: [4, 0, 0], radius: 1, material: {type: lambertian, albedo: earth}}
"""


def tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return tmp_path / next(iter(files))


def errors(path, **kw) -> list[str]:
    with pytest.raises(SceneError) as info:
        load(path, **kw)
    return [str(d) for d in info.value.diagnostics]


@pytest.fixture
def scene(tmp_path):
    from PIL import Image

    Image.new("RGB", (4, 2), (10, 20, 30)).save(tmp_path / "earth.png")
    return tree(tmp_path, {"main.yaml": MAIN, "parts/materials.yaml": MATERIALS, "parts/shapes.yaml": SHAPES})


def test_definitions_and_shapes_of_included_files_are_merged(scene, tmp_path):
    loaded = load(scene)
    assert set(loaded.scene.materials) == {"red", "glass"}
    assert set(loaded.scene.textures) == {"earth"}
    # The main file's shapes first, then each included file's, in include order.
    assert [s.center for s in loaded.scene.shapes] == [(0, 0, 0), (2, 0, 0), (4, 0, 0)]
    # A file included twice (by main.yaml and by shapes.yaml) is merged once, without a clash.
    assert loaded.scene.include == ["parts/materials.yaml", "parts/shapes.yaml"]
    # An image named in an included file is relative to that file's folder.
    (earth,) = [t for t in loaded.graph.textures if t.name == "earth"]
    assert earth.image_path == (tmp_path / "earth.png").resolve()


def test_an_error_in_an_included_file_names_that_file_its_position_and_the_includer(scene, tmp_path):
    (tmp_path / "parts/shapes.yaml").write_text(SHAPES.replace("radius: 1, material: glass", "radius: -1, material: glas"))
    found = errors(scene)
    shapes = str(tmp_path / "parts" / "shapes.yaml")
    assert found == [
        f"{shapes}:3:47: error: shapes[0].radius: a sphere's radius must be > 0; the old book's negative-radius "
        "'hollow glass' trick is not supported: model the air bubble as a second, smaller sphere of dielectric with "
        f"ior 1/1.5 (included from {scene}:2:33)",
    ]
    (tmp_path / "parts/shapes.yaml").write_text(SHAPES.replace("material: glass", "material: glas"))
    assert errors(scene) == [
        f"{shapes}:3:60: error: shapes[0].material: undefined material 'glas'; did you mean 'glass'? "
        f"(included from {scene}:2:33)"
    ]


def test_nested_includes_name_every_includer(scene, tmp_path):
    (tmp_path / "parts/materials.yaml").write_text(MATERIALS.replace("ior: 1.5", "ior: -2"))
    materials = str(tmp_path / "parts" / "materials.yaml")
    # Reached first through main.yaml, which includes it directly.
    assert errors(scene) == [
        f"{materials}:2:34: error: materials.glass.ior: expected a number > 0, found -2 (included from {scene}:2:11)"
    ]
    (tmp_path / "main.yaml").write_text(MAIN.replace("parts/materials.yaml, ", ""))
    assert errors(scene) == [
        f"{materials}:2:34: error: materials.glass.ior: expected a number > 0, found -2 "
        f"(included from {tmp_path / 'parts' / 'shapes.yaml'}:1:11, included from {scene}:2:11)"
    ]


def test_a_name_defined_twice_is_an_error_naming_both_places(scene, tmp_path):
    (tmp_path / "parts/materials.yaml").write_text(MATERIALS.replace("materials:\n", "materials:\n  red: {type: metal}\n"))
    assert errors(scene) == [
        f"{tmp_path / 'parts' / 'materials.yaml'}:2:3: error: materials.red: material 'red' is defined twice: "
        f"here and at {scene}:5:3 (included from {scene}:2:11)"
    ]


def test_include_cycles_are_errors(tmp_path):
    main = tree(tmp_path, {"a.yaml": "include: [b.yaml]\n", "b.yaml": "include: [c.yaml]\n", "c.yaml": "include: [a.yaml]\n"})
    (only,) = errors(main)
    assert "error: include[0]: include cycle: a.yaml -> b.yaml -> c.yaml -> a.yaml" in only
    assert only.startswith(f"{tmp_path / 'c.yaml'}:1:11:")
    selfish = tree(tmp_path, {"self.yaml": "include: [self.yaml]\n"})
    assert errors(selfish) == [f"{selfish}:1:11: error: include[0]: include cycle: self.yaml -> self.yaml"]


def test_hostile_includes_are_refused_where_they_are_named(tmp_path):
    (tmp_path / "dir").mkdir()
    main = tree(tmp_path, {"m.yaml": "include: [/dev/zero, dir, missing.yaml, \"a\\0b\"]\n"})
    found = errors(main, allow_paths=["/dev"])  # else /dev/zero is refused as outside the scene's folder
    assert [f.split(": error: ")[0] for f in found] == [f"{main}:1:11", f"{main}:1:22", f"{main}:1:27", f"{main}:1:41"]
    assert "included file '/dev/zero': is a character device, not a regular file" in found[0]
    assert "included file 'dir': is a directory" in found[1]
    assert f"included file 'missing.yaml' not found (looked for {tmp_path / 'missing.yaml'})" in found[2]
    assert "the file name contains a NUL byte" in found[3]


def test_included_files_are_checked_like_the_main_one(tmp_path):
    bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [{', '.join(['*' + p] * 10)}]\n" for p, c in zip("abcdefgh", "bcdefghi")
    )
    main = tree(tmp_path, {"m.yaml": "include: [bomb.yaml, syntax.yaml]\n", "bomb.yaml": bomb, "syntax.yaml": "shapes: [1, 2\n"})
    found = errors(main)
    assert len(found) == 2
    assert "refusing to load it (included from" in found[0] and found[0].startswith(str(tmp_path / "bomb.yaml"))
    assert found[1].startswith(f"{tmp_path / 'syntax.yaml'}:1:9: error: (top level): YAML syntax error: this '[' is never closed")


def test_an_included_file_holds_only_definitions_and_shapes(tmp_path):
    main = tree(tmp_path, {"m.yaml": "include: [cam.yaml]\n", "cam.yaml": "camera: {vfov: 30}\nversion: 2\nmaterials: [1]\n"})
    found = errors(main)
    assert "cam.yaml:1:1: error: camera: 'camera' cannot be given in an included file" in found[0]
    assert "cam.yaml:2:10: error: version: unsupported scene format version 2" in found[1]
    assert "cam.yaml:3:12: error: materials: expected a mapping of names to materials" in found[2]


def test_include_depth_and_count_are_bounded(tmp_path, monkeypatch):
    monkeypatch.setattr(includes, "MAX_INCLUDE_DEPTH", 3)
    files = {f"f{i}.yaml": f"include: [f{i + 1}.yaml]\n" for i in range(5)}
    main = tree(tmp_path, files | {"f5.yaml": "{}\n"})
    (only,) = errors(main)
    assert only.startswith(f"{tmp_path / 'f3.yaml'}:1:11: error: include[0]: includes nested deeper than 3 levels")
    monkeypatch.setattr(includes, "MAX_INCLUDE_DEPTH", 16)
    monkeypatch.setattr(includes, "MAX_INCLUDED_FILES", 2)
    (only,) = errors(main)
    assert only.startswith(f"{tmp_path / 'f2.yaml'}:1:11: error: include[0]: more than 2 included files in all")


def test_includes_share_the_size_limit_of_one_file(tmp_path, monkeypatch):
    monkeypatch.setattr(includes, "MAX_FILE_BYTES", 100)
    main = tree(tmp_path, {"m.yaml": "include: [a.yaml]\n", "a.yaml": "description: " + "x" * 100 + "\n"})
    (only,) = errors(main)
    assert "included file 'a.yaml': the file is larger than the 82 bytes allowed" in only
    assert "(a scene and all its includes share 100 bytes)" in only


def test_includes_from_text_are_relative_to_the_given_folder(tmp_path):
    tree(tmp_path, {"lib.yaml": "materials: {m: {type: metal}}\n"})
    loaded = loads("include: [lib.yaml]\nshapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: m}]\n", base_dir=tmp_path)
    assert list(loaded.scene.materials) == ["m"]


def test_include_may_be_one_name_or_a_list_of_names(tmp_path):
    main = tree(tmp_path, {"m.yaml": "include: lib.yaml\n", "lib.yaml": "materials: {m: {type: metal}}\n"})
    assert list(load(main).scene.materials) == ["m"]
    main.write_text("include: 7\n")
    (only,) = errors(main)
    assert "m.yaml:1:10: error: include: expected a file name or a list of file names, found a number" in only
