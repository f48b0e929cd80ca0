"""Issue 29: what a scene may read, what a message may quote of it, and what a render may write.

A scene downloaded from elsewhere may name any file of the machine (`include: [/etc/shadow]`,
`../../.aws/credentials`, a texture given by --set, a symbolic link in its archive). By default it
reads only files inside its own folder (`--allow-path DIR` adds folders), and no message, on the
terminal, in `--json` or on `rt watch`'s page, ever quotes a file that is not a scene. Outputs
are compared with every input as files, links resolved, before anything renders.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from rt.cli import app
from scenefmt.diagnostics import SceneError
from scenefmt.validation import load, loads

runner = CliRunner()

MARK = "XYZZY"  # in every secret below, and in no file name: it must never be printed

SECRETS = {
    "shadow": f"root:$6${MARK}salt$hashhashhash:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\n"
    f"alice:$y$j9T${MARK}alice$morehash:19001:0:99999:7:::\n",
    "credentials": f"[default]\naws_access_key_id = AKIA{MARK}0000\naws_secret_access_key = {MARK}/abcdEFGH+ijkl\n",
    "dotenv": f"API_KEY={MARK}key\nDATABASE_URL=postgres://u:{MARK}pw@db/x\n",
    "config.json": json.dumps({"token": f"{MARK}token", f"{MARK}key": 1, "nested": {"camera": f"{MARK}cam"}}),
    "keys.yaml": f"password: {MARK}pw\nmaterials: {MARK}materials\n",
    "words": f"{MARK}word\n",
}

SCENE = """\
camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}
image: {width: 8, aspect_ratio: 1, samples_per_pixel: 1, max_depth: 2}
materials: {m: {type: lambertian, albedo: [0.5, 0.5, 0.5]}}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: m}
"""


def run_rt(*args, cwd, stdin=None):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, capture_output=True, text=True, input=stdin,
                          timeout=120)


@pytest.fixture
def secrets(tmp_path):
    """A folder of other people's files beside the scene's folder, which is returned."""
    home = tmp_path / "home"
    home.mkdir()
    for name, text in SECRETS.items():
        (home / name).write_text(text)
    project = tmp_path / "project"
    project.mkdir()
    (project / "scene.yaml").write_text(SCENE)
    return project


def assert_no_secret(*texts):
    for text in texts:
        assert MARK not in text, text


def scene_naming(project: Path, line: str) -> Path:
    path = project / "hostile.yaml"
    path.write_text(SCENE + line)
    return path


# --- 1. no file's contents in any message ---------------------------------------------------------

# Each way a scene can name a file: (the scene's extra text, the --set arguments).
ROUTES = {
    "include": ("include: [../home/{name}]\n", []),
    "include as one name": ("include: ../home/{name}\n", []),
    "texture": ("textures: {{t: {{type: image, file: ../home/{name}}}}}\n", []),
    "environment map": ("background: {{type: image, file: ../home/{name}}}\n", []),
    "texture by --set": ("textures: {{t: {{type: solid, color: [1, 1, 1]}}}}\n", ["--set", "textures.t={{type: image, file: {path}}}"]),
}


@pytest.mark.parametrize("route", list(ROUTES))
@pytest.mark.parametrize("name", list(SECRETS))
def test_no_secret_reaches_validate_or_its_json_whatever_names_the_file(secrets, route, name):
    text, extra = ROUTES[route]
    path = str(secrets.parent / "home" / name)
    scene = scene_naming(secrets, text.format(name=name))
    extra = [a.format(path=path) for a in extra]
    for allow in ([], ["--allow-path", str(secrets.parent / "home")]):  # refused as outside; read, and not quoted
        for json_flag in ([], ["--json"]):
            result = runner.invoke(app, ["validate", str(scene), *extra, *allow, *json_flag])
            assert result.exit_code == 1, result.output
            assert_no_secret(result.stdout, result.stderr)
        if not allow:
            assert "outside the folders this scene may read files from" in result.stdout
            assert "--allow-path" in result.stdout


def test_an_included_secret_gives_one_error_in_the_including_file(secrets):
    scene = scene_naming(secrets, "include: [../home/shadow, ../home/config.json, ../home/dotenv]\n")
    with pytest.raises(SceneError) as info:
        load(scene, allow_paths=[secrets.parent / "home"])
    shown = [str(d) for d in info.value.diagnostics]
    assert len(shown) == 3 and all(s.startswith(f"{scene}:6:") for s in shown), shown
    assert "include[0]: included file '../home/shadow' is not a scene file: 3 of its 3 top-level keys are not scene keys" in shown[0]
    assert "is not a scene file: 3 of its 3 top-level keys are not scene keys" in shown[1]
    assert "is not a scene file: its top level is text, not a mapping" in shown[2]
    assert_no_secret(*shown)


def test_a_secret_used_as_a_mesh_is_described_not_quoted(secrets):
    home = secrets.parent / "home"
    for name in ("shadow", "credentials", "dotenv", "words"):
        (home / f"{name}.obj").write_text(SECRETS[name])
        (home / f"{name}.ply").write_text("ply\n" + SECRETS[name])
        for suffix in (".obj", ".ply"):
            scene = scene_naming(secrets, f"  - {{type: mesh, file: ../home/{name}{suffix}, material: m}}\n")
            with pytest.raises(SceneError) as info:
                load(scene, allow_paths=[home])
            shown = "\n".join(str(d) for d in info.value.diagnostics)
            assert f"mesh file '../home/{name}{suffix}'" in shown
            assert_no_secret(shown)


def test_a_secret_through_standard_input_and_render_stays_unprinted(secrets):
    home = secrets.parent / "home"
    stdin = SCENE + f"include: [{home / 'shadow'}]\n"
    refused = run_rt("validate", "-", cwd=secrets, stdin=stdin)
    assert refused.returncode == 1 and "outside the folders this scene may read files from" in refused.stderr
    read = run_rt("validate", "--json", "--allow-path", str(home), "-", cwd=secrets, stdin=stdin)
    assert read.returncode == 1 and "is not a scene file" in read.stdout
    rendered = run_rt("render", "--allow-path", str(home), str(scene_naming(secrets, "include: [../home/credentials]\n")),
                      "--set", f"textures.t={{type: image, file: {home / 'config.json'}}}", cwd=secrets)
    assert rendered.returncode == 1 and not (secrets / "hostile.png").exists()
    for result in (refused, read, rendered):
        assert_no_secret(result.stdout, result.stderr)


def test_a_secret_named_as_the_scene_itself_is_one_error_without_its_line(secrets):
    from rt.watch import describe

    for name in ("shadow", "config.json", "words"):
        with pytest.raises(SceneError) as info:
            load(secrets.parent / "home" / name)
        (only,) = info.value.diagnostics
        assert "is not a scene file" in only.message
        event = json.dumps([describe(d) for d in info.value.diagnostics])
        assert_no_secret(str(only), event)


def test_the_watch_page_shows_no_line_of_a_named_file(secrets):
    """`rt watch` posts a scene's errors as events with the line each points at: never a line of a
    file that the scene only named (here the credentials, which do not parse, and the others)."""
    from rt.watch import Board, Previewer, WatchOptions

    home = secrets.parent / "home"
    for name in SECRETS:
        scene = scene_naming(secrets, f"include: [../home/{name}]\n")
        for allow in ((), (home,)):
            board = Board()
            Previewer(WatchOptions(scene, allow_paths=allow), board, say=lambda _: None)._render_once()
            _, kind, payload = board.latest["problems"]
            errors = json.loads(payload)["errors"]
            assert errors, payload
            assert_no_secret(payload)


def test_a_users_own_misspellings_are_still_quoted(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("materials: {m: {type: lambertian}}\nshapes: [{type: sphere, center: [0, 0, 0], radious: 1, material: m}]\n"
                    "camera: {vfov: 'wide'}\n")
    with pytest.raises(SceneError) as info:
        load(path)
    shown = "\n".join(str(d) for d in info.value.diagnostics)
    assert "shapes[0].radious: unknown key 'radious'; did you mean 'radius'?" in shown
    assert "found 'wide'" in shown
    # A key that is no identifier, and a long value, are described instead.
    with pytest.raises(SceneError) as info:
        loads("camera: {vfov: 'a:b$c/d', 'x=1 y': 2}\n")
    shown = "\n".join(str(d) for d in info.value.diagnostics)
    assert "unknown key (not shown: 5 characters)" in shown and "found a string of 7 characters" in shown
    assert "a:b$c/d" not in shown and "x=1 y" not in shown


# --- 2. files outside the scene's folder -----------------------------------------------------------


def test_files_outside_the_scenes_folder_are_refused_before_they_are_opened(secrets, tmp_path):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    os.mkfifo(outside / "pipe.yaml")  # opened, it would be refused as a FIFO; it is refused as outside first
    (outside / "lib.yaml").write_text("materials: {far: {type: metal}}\n")
    (secrets / "link.yaml").symlink_to(outside / "lib.yaml")  # a link inside to a file outside
    scene = scene_naming(secrets, "include: [../elsewhere/pipe.yaml, link.yaml]\n")
    result = run_rt("validate", str(scene), cwd=tmp_path)
    assert result.returncode == 1
    lines = result.stderr.splitlines()
    assert lines[0].startswith(f"{scene}:6:11: error: include[0]: included file '../elsewhere/pipe.yaml' is outside the folders "
                               f"this scene may read files from ({secrets})")
    assert "--allow-path" in lines[0]
    assert "FIFO" not in result.stderr
    assert lines[1].startswith(f"{scene}:6:35: error: include[1]: included file 'link.yaml' is outside the folders")
    assert f"through a symbolic link to {outside / 'lib.yaml'}" in lines[1]
    (outside / "pipe.yaml").unlink()
    scene.write_text(SCENE + "include: [link.yaml]\n")
    allowed = run_rt("validate", str(scene), "--allow-path", str(outside), cwd=tmp_path)
    assert allowed.returncode == 0, allowed.stderr
    assert "material 'far' is defined but never used" in allowed.stderr


def test_textures_meshes_and_environment_maps_outside_are_refused_with_their_key_path(tmp_path):
    from PIL import Image

    outside = tmp_path / "elsewhere"
    outside.mkdir()
    Image.new("RGB", (4, 2), (10, 20, 30)).save(outside / "wood.png")
    (outside / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    project = tmp_path / "project"
    project.mkdir()
    scene = project / "s.yaml"
    scene.write_text(SCENE + f"  - {{type: mesh, file: {outside / 'tri.obj'}, material: m}}\n"
                     "textures: {wood: {type: image, file: ../elsewhere/wood.png}}\n"
                     "background: {type: image, file: ../elsewhere/wood.png}\n")
    with pytest.raises(SceneError) as info:
        load(scene)
    found = {".".join(map(str, d.path)): d.message for d in info.value.diagnostics}
    assert set(found) == {"shapes.1.file", "textures.wood.file", "background.file"}, found
    assert all("outside the folders this scene may read files from" in m and "--allow-path" in m for m in found.values())
    loaded = load(scene, allow_paths=[str(outside)])
    assert loaded.graph.environment_path == (outside / "wood.png").resolve()


def test_standard_input_and_data_read_from_the_current_folder(tmp_path, monkeypatch):
    import rt

    (tmp_path / "lib.yaml").write_text("materials: {near: {type: metal}}\n")
    sub = tmp_path / "sub"
    sub.mkdir()
    inside = run_rt("validate", "-", cwd=tmp_path, stdin=SCENE + "include: lib.yaml\n")
    assert inside.returncode == 0, inside.stderr
    outside = run_rt("validate", "-", cwd=sub, stdin=SCENE + "include: ../lib.yaml\n")
    assert outside.returncode == 1 and f"outside the folders this scene may read files from ({sub})" in outside.stderr
    monkeypatch.chdir(sub)
    data = {"include": ["../lib.yaml"], "materials": {"m": {"type": "lambertian"}}}
    assert "outside the folders" in str(rt.validate(data))
    assert rt.validate(data, allow_paths=[tmp_path]).ok
    assert list(rt.load(data, allow_paths=[tmp_path]).scene.materials) == ["m", "near"]


def test_allow_path_is_an_option_of_render_validate_and_watch():
    for command in ("render", "validate", "watch"):
        result = runner.invoke(app, [command, "--help"], terminal_width=200)
        assert "--allow-path" in result.stdout, command


# --- 3. outputs never overwrite inputs -------------------------------------------------------------


@pytest.fixture
def earth(tmp_path):
    from PIL import Image

    Image.new("RGB", (8, 4), (200, 100, 50)).save(tmp_path / "earthmap.png")
    (tmp_path / "sky.pfm").write_bytes(b"PF\n2 1\n-1.0\n" + bytes(24))
    (tmp_path / "lib.png").write_text("materials: {spare: {type: metal}}\n")  # an included file, whatever its name
    scene = tmp_path / "earth.yaml"
    scene.write_text(SCENE.replace("albedo: [0.5, 0.5, 0.5]", "albedo: {type: image, file: earthmap.png}")
                     + "background: {type: image, file: sky.pfm}\ninclude: lib.png\n")
    return scene


def refused_before_rendering(result, input_path: Path, before: bytes, *words):
    assert result.returncode == 1, result.stdout + result.stderr
    assert input_path.read_bytes() == before
    assert "spp" not in result.stderr and "wrote" not in result.stdout  # no progress, nothing written
    for word in words:
        assert word in result.stderr, result.stderr


@pytest.mark.parametrize("args, victim", [
    (["-o", "earthmap.png"], "earthmap.png"),  # the texture
    (["--hdr", "sky.pfm"], "sky.pfm"),  # the environment map
    (["-o", "lib.png"], "lib.png"),  # an included file
    (["-o", "out.png", "--noise-map", "earth.png"], "earth.png"),  # a link to the texture, below
])
def test_an_output_that_is_an_input_is_refused_before_rendering(earth, args, victim):
    folder = earth.parent
    if victim == "earth.png":
        (folder / "earth.png").symlink_to(folder / "earthmap.png")
    before = (folder / victim).read_bytes()
    result = run_rt("render", "earth.yaml", *args, cwd=folder)
    refused_before_rendering(result, folder / victim, before, "a file the scene reads: rendering would overwrite it")
    assert str((folder / victim).resolve()) in result.stderr


def test_a_scene_is_not_replaced_by_its_own_image(tmp_path):
    scene = tmp_path / "scene.png"
    scene.write_text(SCENE)
    before = scene.read_bytes()
    single = run_rt("render", "scene.png", cwd=tmp_path)
    refused_before_rendering(single, scene, before, "error: the image scene.png is the scene file scene.png itself")
    (tmp_path / "other.yaml").write_text(SCENE)
    batch = run_rt("render", "other.yaml", "scene.png", "-o", ".", cwd=tmp_path)
    refused_before_rendering(batch, scene, before, "is the scene file scene.png of this batch")
    assert not (tmp_path / "other.png").exists()


def test_two_outputs_that_are_one_file_through_a_link_are_refused(tmp_path):
    (tmp_path / "s.yaml").write_text(SCENE)
    (tmp_path / "noise.png").symlink_to(tmp_path / "image.png")
    result = run_rt("render", "s.yaml", "-o", "image.png", "--noise-map", "noise.png", cwd=tmp_path)
    assert result.returncode == 1
    assert "error: noise.png: --noise-map and the image (image.png, through a link) name the same file" in result.stderr
    assert not (tmp_path / "image.png").exists()


def test_save_state_may_continue_the_state_it_resumes(tmp_path):
    from rt.outputs import input_problem
    from rt.render_job import RenderOptions

    state = tmp_path / "s.npz"
    state.write_bytes(b"")
    same = RenderOptions(scene=tmp_path / "s.yaml", output=tmp_path / "s.png", save_state=state, resume=state)
    assert input_problem(same, [str(tmp_path / "s.yaml")]) is None
    clash = RenderOptions(scene=tmp_path / "s.yaml", output=tmp_path / "s.png", hdr=tmp_path / "s.pfm", resume=tmp_path / "s.pfm")
    (tmp_path / "s.pfm").write_bytes(b"")
    assert "is the state --resume" in input_problem(clash, [])
