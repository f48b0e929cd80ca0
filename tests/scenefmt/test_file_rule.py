"""One rule for every file a scene names (scenefmt/named_files.py): relative to the file that names
it, inside the allowed folders, recorded for `rt watch` and a cluster's package.

The scene under test keeps its mesh and its image texture beside the file that names them,
`parts/part.yaml`, which the main scene includes from its own folder; nothing of that name lies
beside the main scene, so a rule that looked there (as meshes once did) fails every test here.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from rt.cli import app
from scenefmt.diagnostics import SceneError
from scenefmt.files import recording_reads
from scenefmt.validation import load

runner = CliRunner()

MAIN = """\
camera: {look_from: [0, 0, 3], look_at: [0, 0, 0], vfov: 40}
image: {width: 16, aspect_ratio: 1, samples_per_pixel: 4, max_depth: 3}
background: {type: sky, bottom: [1, 1, 1], top: [1, 1, 1]}
include: [parts/part.yaml]
"""
# A red image texture on a triangle that fills the middle of the view, both named as the
# included file's neighbours.
PART = """\
textures:
  paint: {type: image, file: red.png}
materials:
  painted: {type: lambertian, albedo: paint}
shapes:
  - {type: mesh, file: wall.obj, material: painted}
"""
WALL = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n"


@pytest.fixture
def project(tmp_path) -> Path:
    """tmp/project/main.yaml including parts/part.yaml, whose wall.obj and red.png lie in parts/."""
    project = tmp_path / "project"
    parts = project / "parts"
    parts.mkdir(parents=True)
    (project / "main.yaml").write_text(MAIN)
    (parts / "part.yaml").write_text(PART)
    (parts / "wall.obj").write_text(WALL)
    Image.fromarray(np.full((2, 2, 3), (255, 0, 0), np.uint8)).save(parts / "red.png")
    return project


def test_a_mesh_and_an_image_in_an_included_file_resolve_beside_it(project):
    with recording_reads() as reads:
        loaded = load(project / "main.yaml")
    parts = (project / "parts").resolve()
    (shape,) = loaded.graph.root.members
    assert shape.mesh.faces.shape == (1, 3)  # wall.obj's one triangle
    (texture,) = [t for t in loaded.graph.textures if t.kind == "image"]
    assert texture.image_path == parts / "red.png"
    assert {str(parts / "part.yaml"), str(parts / "wall.obj"), str(parts / "red.png")} <= set(reads)


def test_rt_validate_finds_them_beside_the_included_file(project):
    result = runner.invoke(app, ["validate", str(project / "main.yaml")])
    assert result.exit_code == 0, result.output
    # Moved beside the main scene, where meshes were once looked for, they are not found.
    for name in ("wall.obj", "red.png"):
        (project / "parts" / name).rename(project / name)
    result = runner.invoke(app, ["validate", str(project / "main.yaml")])
    assert result.exit_code == 1
    assert f"mesh file 'wall.obj' not found (looked for {(project / 'parts' / 'wall.obj').resolve()})" in result.output
    assert f"image file 'red.png' not found (looked for {(project / 'parts' / 'red.png').resolve()})" in result.output


def test_a_name_in_an_included_file_may_reach_the_main_folder_but_not_past_it(project):
    (project / "parts" / "wall.obj").rename(project / "wall.obj")
    (project / "parts" / "part.yaml").write_text(PART.replace("file: wall.obj", "file: ../wall.obj"))
    assert load(project / "main.yaml").graph.root.members[0].mesh.faces.shape == (1, 3)
    (project.parent / "wall.obj").write_text(WALL)
    (project / "parts" / "part.yaml").write_text(PART.replace("file: wall.obj", "file: ../../wall.obj"))
    with pytest.raises(SceneError) as info:
        load(project / "main.yaml")
    (problem,) = info.value.diagnostics
    assert problem.file.endswith("part.yaml") and problem.path == ("shapes", 0, "file")
    assert problem.message.startswith("mesh file '../../wall.obj' is outside the folders this scene may read files from")
    assert load(project / "main.yaml", allow_paths=[project.parent]).graph.root.members[0].mesh.faces.shape == (1, 3)


# How each kind of file is named, with {name} for the name: (the main scene's extra text, the kind).
KINDS = {
    "include": ("include: [{name}.yaml]\n", "included file"),
    "image texture": ("textures: {{t: {{type: image, file: {name}.png}}}}\nmaterials: {{m: {{type: lambertian, albedo: t}}}}\n",
                      "image file"),
    "environment map": ("background: {{type: image, file: {name}.png}}\n", "image file"),
    "mesh": ("materials: {{m: {{type: lambertian, albedo: [0.5, 0.5, 0.5]}}}}\n"
             "shapes: [{{type: mesh, file: {name}.obj, material: m}}]\n", "mesh file"),
}
BASE = "camera: {look_from: [0, 0, 3], look_at: [0, 0, 0]}\nimage: {width: 8, aspect_ratio: 1}\n"


@pytest.fixture
def outside(tmp_path) -> Path:
    """tmp/outside holding x.yaml, x.png and x.obj, all usable; tmp/project/link leads there."""
    folder = tmp_path / "outside"
    folder.mkdir()
    (folder / "x.yaml").write_text("materials: {}\n")
    (folder / "x.obj").write_text(WALL)
    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(folder / "x.png")
    project = tmp_path / "project"
    project.mkdir()
    (project / "link").symlink_to(folder)
    return folder


def refusal(project: Path, text: str, allow=()) -> str:
    (project / "scene.yaml").write_text(BASE + text)
    with pytest.raises(SceneError) as info:
        load(project / "scene.yaml", allow_paths=allow)
    (problem,) = [d for d in info.value.diagnostics if d.severity == "error"]
    return problem.message


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_of_file_outside_the_allowed_folders_is_refused_in_one_sentence(outside, kind):
    project = outside.parent / "project"
    text, what = KINDS[kind]
    tail = (rf"is outside the folders this scene may read files from \({re.escape(str(project.resolve()))}\)"
            r"{through}; to read it, allow its folder with --allow-path DIR \(allow_paths=\[\.\.\.\] in Python\)$")
    suffix = {"include": ".yaml", "mesh": ".obj"}.get(kind, ".png")
    by_name = refusal(project, text.format(name="../outside/x"))
    assert re.match(rf"{what} '\.\./outside/x{suffix}' " + tail.format(through=""), by_name), by_name
    through = f", through a symbolic link to {re.escape(str((outside / ('x' + suffix)).resolve()))}"
    by_link = refusal(project, text.format(name="link/x"))
    assert re.match(rf"{what} 'link/x{suffix}' " + tail.format(through=through), by_link), by_link
    # Allowed, the same names are read.
    (project / "scene.yaml").write_text(BASE + text.format(name="../outside/x"))
    load(project / "scene.yaml", allow_paths=[outside])


def test_the_refusal_is_the_same_sentence_for_every_kind(outside):
    project = outside.parent / "project"
    tails = set()
    for text, what in KINDS.values():
        message = refusal(project, text.format(name="../outside/x"))
        assert message.startswith(f"{what} '../outside/x.")
        tails.add(message.split("' ", 1)[1])
    assert len(tails) == 1, tails


# --- what uses the recorded files: a render in a fresh process, rt watch, a cluster's workers --------

@pytest.mark.slow
def test_rt_render_in_a_fresh_process_renders_the_included_mesh_with_its_texture(project):
    result = subprocess.run([sys.executable, "-m", "rt", "render", "main.yaml", "-o", "out.png", "--kernel", "general"],
                            cwd=project, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    pixels = np.asarray(Image.open(project / "out.png").convert("RGB"), np.float64)
    red, green, blue = pixels[6:10, 6:10].reshape(-1, 3).mean(axis=0)
    # The middle is the red wall lit by a white sky: red, with green and blue near zero (a
    # missing texture or mesh would leave white sky or a grey default there).
    assert red > 100 and green < 10 and blue < 10, (red, green, blue)
    corner = pixels[0, 0]
    assert corner.min() > 200  # the sky beside the triangle


@pytest.mark.slow
def test_rt_watch_polls_the_mesh_and_the_texture_beside_the_included_file(project):
    from rt.watch import Watch, WatchOptions
    from tests.test_watch import Events

    watch = Watch(WatchOptions(project / "main.yaml"), port=0, say=lambda m: None).start()
    try:
        events = Events(watch.port)
        events.until(lambda name, data: name == "problems" and data["errors"] == [])  # posted once the files are watched
        events.close()
        polled = set(watch.previewer.watched)
    finally:
        watch.close()
    parts = project / "parts"
    assert {str(project / "main.yaml"), str(parts / "part.yaml"), str(parts / "wall.obj"), str(parts / "red.png")} <= polled


@pytest.mark.slow
def test_a_cluster_package_holds_the_mesh_and_a_worker_builds_the_scene_from_it(project):
    pytest.importorskip("distributed")
    from renderer.compile import compile_scene
    from renderer.variants import GENERAL
    from rt import chunks
    from rt.cluster import package_scene

    with recording_reads() as reads:
        loaded = load(project / "main.yaml")
        flat = compile_scene(loaded.graph)
    package = package_scene(str(project / "main.yaml"), reads, loaded, flat)
    parts = project / "parts"
    sent = dict(package.files)
    assert sent[str(parts / "wall.obj")] == WALL.encode()
    assert str(parts / "red.png") in sent and str(parts / "part.yaml") in sent
    # The worker's side: the scene rebuilt from those bytes alone, in a folder of its own.
    built = chunks.build(package, GENERAL)
    assert chunks.flat_digest(built.flat) == package.digest
