"""Issue 29, parsing: recursive aliases, a closed standard input, long and misspelt `--set` paths,
documents too big to build, and writing large scenes. Each is run as a user runs it, in a fresh
`rt` process, and must end in a one-line diagnostic and exit status, never a traceback."""

import subprocess
import sys
import time

import pytest

SCENE = """\
version: 1
camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}
image: {width: 16, samples_per_pixel: 1}
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: white}
"""
RECURSIVE = "description: &r [*r]\n"


def rt(*args, cwd, stdin=subprocess.DEVNULL, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "rt", *args], cwd=cwd, stdin=stdin, capture_output=True, text=True, timeout=timeout
    )


def clean_failure(result, status=1) -> str:
    assert result.returncode == status, result.stderr
    assert "Traceback" not in result.stderr
    return result.stderr


# ---------------------------------------------------------------------------------------------
# 1. Recursive aliases


RECURSIVE_MESSAGE = "the YAML alias *r refers to the node that contains it (recursive alias)"


@pytest.mark.parametrize("command", ["validate", "render"])
def test_a_recursive_alias_in_a_scene_file_is_placed_at_the_alias(tmp_path, command):
    (tmp_path / "scene.yaml").write_text(SCENE + RECURSIVE)
    err = clean_failure(rt(command, "scene.yaml", cwd=tmp_path))
    assert f"scene.yaml:8:18: error: description[0]: {RECURSIVE_MESSAGE}" in err
    assert not (tmp_path / "scene.png").exists()


def test_a_recursive_alias_in_an_included_file_names_that_file(tmp_path):
    (tmp_path / "lib.yaml").write_text("materials: {}\n" + RECURSIVE)
    (tmp_path / "scene.yaml").write_text(SCENE + "include: [lib.yaml]\n")
    err = clean_failure(rt("validate", "scene.yaml", cwd=tmp_path))
    assert f"lib.yaml:2:18: error: description[0]: {RECURSIVE_MESSAGE} (included from scene.yaml:8:11)" in err


def test_a_recursive_alias_in_a_set_value_is_placed_in_the_argument(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    err = clean_failure(rt("validate", "scene.yaml", "--set", "description=&r [*r]", cwd=tmp_path))
    assert f"--set description=&r [*r]:1:17: error: description: {RECURSIVE_MESSAGE}" in err


def test_an_alias_deeper_inside_its_own_anchor_is_recursive_too(tmp_path):
    text = "version: 1\ndescription: &a {x: [1, {y: *a}]}\n"
    err = clean_failure(_validate_stdin(tmp_path, text))
    assert "<stdin>:2:29: error: description.x[1].y: the YAML alias *a refers to the node that contains it" in err


def _validate_stdin(cwd, text):
    return subprocess.run(
        [sys.executable, "-m", "rt", "validate", "-"], cwd=cwd, input=text, capture_output=True, text=True, timeout=60
    )


def test_an_alias_bomb_is_refused_quickly_and_small(tmp_path):
    # Ten levels of ten aliases each: 10^10 values once expanded, a few hundred bytes written.
    lines = ["version: 1", "a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"]
    for level in range(1, 11):
        lines.append(f"a{level}: &a{level} [" + ", ".join([f"*a{level - 1}"] * 10) + "]")
    (tmp_path / "bomb.yaml").write_text("\n".join(lines) + "\n")
    probe = (
        "import resource, subprocess, sys, time; t = time.perf_counter(); "
        "r = subprocess.run([sys.executable, '-m', 'rt', 'validate', 'bomb.yaml'], capture_output=True, text=True); "
        "print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
        "sys.stderr.write(r.stderr); sys.exit(r.returncode)"
    )
    result = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    err = clean_failure(result)
    assert "values through its aliases" in err
    _, peak_kib = result.stdout.split()  # time is bounded by the run's timeout: an expanded bomb never ends
    assert int(peak_kib) < 400 * 1024


# ---------------------------------------------------------------------------------------------
# 2. Standard input closed


@pytest.mark.parametrize("command", ["validate", "render"])
def test_a_closed_standard_input_is_a_usage_error(tmp_path, command):
    # `rt validate - <&-`: the process starts with no file descriptor 0, so Python has no sys.stdin.
    result = subprocess.run(
        f"{sys.executable} -m rt {command} - <&-", shell=True, cwd=tmp_path, capture_output=True, text=True, timeout=60
    )
    err = clean_failure(result, status=2)
    assert err.startswith("error: standard input is closed")
    assert not (tmp_path / "stdin.png").exists()


def test_load_source_with_no_standard_input_raises_a_scene_error(monkeypatch):
    from scenefmt.diagnostics import SceneError
    from scenefmt.validation import load_source

    monkeypatch.setattr(sys, "stdin", None)
    with pytest.raises(SceneError, match="standard input is closed"):
        load_source("-")


# ---------------------------------------------------------------------------------------------
# 3 and 4. --set key paths: bounded, linear, and no new entries by misspelling


def test_a_set_path_of_sixteen_thousand_parts_is_refused_at_once(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    argument = "materials." + ".".join(["a"] * 16_000) + "=1"
    started = time.perf_counter()
    err = clean_failure(rt("validate", "scene.yaml", "--set", argument, cwd=tmp_path))
    assert time.perf_counter() - started < 20
    assert "--set materials.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a....:1:1: error: (top level): the key path is 32,009 characters long, " \
        "more than the 4,096 allowed" in err
    assert len(err) < 400  # the argument is not repeated whole


def test_a_set_path_of_too_many_parts_is_refused(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    argument = "materials." + ".".join(["a"] * 100) + "=1"
    err = clean_failure(rt("validate", "scene.yaml", "--set", argument, cwd=tmp_path))
    assert "the key path has more than 64 parts, deeper than a scene can nest" in err


def test_the_key_walk_is_not_quadratic():
    # 64 parts, each a name with dots in a mapping that holds dotted names: the longest runs are
    # tried from one joined string, not joined again for every length.
    from scenefmt.overrides import _tokens, _walk

    data = {"materials": {"a.b": {}, **{f"m{i}": {} for i in range(1000)}}}
    tokens = _tokens("materials." + ".".join(["a"] * 62) + ".x")
    started = time.perf_counter()
    for _ in range(100):
        with pytest.raises(Exception, match="no key 'a' here"):
            _walk(data, tokens)
    assert time.perf_counter() - started < 2


def test_a_misspelt_name_along_a_set_path_gets_a_did_you_mean(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    err = clean_failure(rt("validate", "scene.yaml", "--set", "materials.whit.albedo=[0.1, 0.1, 0.1]", cwd=tmp_path))
    assert (
        "--set materials.whit.albedo=[0.1, 0.1, 0.1]:1:1: error: materials: no key 'whit' here to set a value inside "
        "(only the last key of a --set path may be new); did you mean 'white'?"
    ) in err
    err = clean_failure(rt("validate", "scene.yaml", "--set", "imag.width=3", cwd=tmp_path))
    assert "error: (top level): no key 'imag' here" in err and "did you mean 'image'?" in err
    err = clean_failure(rt("validate", "scene.yaml", "--set", "shapes[0].centre.x=1", cwd=tmp_path))
    assert "error: shapes[0]: no key 'centre' here" in err and "did you mean 'center'?" in err


def test_a_list_index_out_of_range_is_refused(tmp_path):
    (tmp_path / "scene.yaml").write_text(SCENE)
    err = clean_failure(rt("validate", "scene.yaml", "--set", "shapes[99].radius=2", cwd=tmp_path))
    assert "--set shapes[99].radius=2:1:1: error: (top level): shapes has 1 item, so [99] names none of them" in err


def test_a_whole_new_entry_and_a_section_the_file_left_out_can_be_set():
    from scenefmt.validation import loads

    loaded = loads(
        SCENE.replace("camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\n", ""),
        overrides=["materials.glass={type: dielectric, ior: 1.5}", "camera.vfov=30", "materials.white.albedo=[0.2, 0.3, 0.4]"],
    )
    assert loaded.scene.materials["glass"].ior == 1.5
    assert loaded.scene.camera.vfov == 30
    assert loaded.scene.materials["white"].albedo == (0.2, 0.3, 0.4)


def test_a_set_argument_over_a_megabyte_is_refused_without_being_echoed():
    from scenefmt.diagnostics import SceneError
    from scenefmt.validation import loads

    with pytest.raises(SceneError) as info:
        loads(SCENE, overrides=["description=" + "x" * (1 << 20)])
    (diag,) = info.value.diagnostics
    assert diag.file == "--set description=xxxxxxxxxxxxxxxxxxxxxxxxxxxx..."
    assert diag.message == "the argument is 1,048,588 characters long, more than the 1,048,576 allowed"


# ---------------------------------------------------------------------------------------------
# 6. Writing a large scene as YAML


def _many_spheres(n):
    from scenefmt.scene import Scene

    spheres = [
        {"type": "sphere", "center": [i * 0.5, (i % 7) * 0.25, -1.0 - i % 3], "radius": 0.2 + (i % 5) * 0.01, "material": f"m{i % 3}"}
        for i in range(n)
    ]
    materials = {
        "m0": {"type": "lambertian", "albedo": [0.5, 0.5, 0.5]},
        "m1": {"type": "metal", "albedo": [0.8, 0.8, 0.8], "fuzz": 0.1},
        "m2": {"type": "dielectric", "ior": 1.5},
    }
    return Scene.model_validate({"version": 1, "materials": materials, "shapes": spheres})


def test_ten_thousand_spheres_are_written_as_yaml_and_read_back_equal(tmp_path):
    from scenefmt.validation import load
    from scenefmt.writing import dump

    scene = _many_spheres(10_000)
    dump(scene, tmp_path / "many.yaml")
    text = (tmp_path / "many.yaml").read_text()
    lines = text.splitlines()
    assert lines[:3] == ["version: 1", "materials:", "  m0: {type: lambertian, albedo: [0.5, 0.5, 0.5]}"]
    assert lines[5:8] == [
        "shapes:",
        "- {type: sphere, center: [0, 0, -1], radius: 0.2, material: m0}",
        "- {type: sphere, center: [0.5, 0.25, -2], radius: 0.21000000000000002, material: m1}",
    ]
    assert len(lines) == 6 + 10_000
    assert load(tmp_path / "many.yaml").scene == scene


@pytest.mark.parametrize("description", [
    "two\nlines", "a NEL\x85here", "a line separator\u2028here", "tab\tand 'quotes' and \"doubles\"", "0E0", "# not a comment",
    "a long description that goes on and on, " * 6,
])
def test_strings_that_yaml_could_misread_are_written_so_they_read_back(description):
    from scenefmt.scene import Scene
    from scenefmt.validation import loads
    from scenefmt.writing import dumps

    scene = Scene(description=description)
    text = dumps(scene, "yaml")
    assert loads(text).scene.description == description
    assert max(len(line) for line in text.splitlines()) <= 125  # a long one folded near 120 characters, as before


def test_the_generated_book_scenes_are_written_byte_for_byte_as_before():
    # scenes/generate.py --check compares the files in scenes/ with what the writer makes now.
    import pathlib

    root = pathlib.Path(__file__).resolve().parents[2]
    result = subprocess.run([sys.executable, str(root / "scenes" / "generate.py"), "--check"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


# ---------------------------------------------------------------------------------------------
# 5. Documents too big for this machine's memory are refused at the value past the limit

# Runs `rt validate` in a process that believes its machine has `memory` bytes, and prints the
# seconds it took and its peak resident size in KiB.
_SMALL_MACHINE = """
import resource, sys, time
import scenefmt.bounds
scenefmt.bounds.physical_memory = lambda: {memory}
from rt.cli import app
started = time.perf_counter()
try:
    app(["validate", "{file}"])
except SystemExit as exit:
    status = exit.code
# VmHWM, not ru_maxrss: this process's own peak (ru_maxrss keeps the forking pytest's, across exec)
peak_kib = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:"))
print(time.perf_counter() - started, peak_kib)
sys.exit(status)
"""


def test_the_value_limit_comes_from_the_memory_budget(monkeypatch):
    from scenefmt import bounds, loading

    monkeypatch.setattr(bounds, "physical_memory", lambda: 8 << 30)
    # 75% of 8 GiB is the budget, half of it for reading, at 300 bytes a value.
    assert loading.node_limit() == int(0.5 * int(0.75 * (8 << 30))) // 300 == 10_737_418
    monkeypatch.setattr(bounds, "physical_memory", lambda: 1 << 40)
    assert loading.node_limit() == loading.MAX_NODES


@pytest.mark.parametrize("syntax", ["yaml", "json"])
def test_a_document_past_the_memory_limit_is_refused_at_the_value_past_it(tmp_path, syntax):
    # A machine of 80 MB may read 100,000 values; this file holds 600,000 in one flow list.
    numbers = ",".join(str(i % 10) for i in range(600_000))  # 1.2 MB: JSON takes its fast path
    if syntax == "yaml":
        text, prefix = "version: 1\ndescription: [" + numbers + "]\n", "description: ["
        first_past = 100_001 - 5  # the mapping, its two keys, the version and the list come first
    else:
        text, prefix = '{"version": 1, "description": [' + numbers + "]}\n", '{"version": 1, "description": ['
        first_past = 100_001 - 3  # the mapping, its first value and the list come first
    (tmp_path / f"big.{syntax}").write_text(text)
    program = _SMALL_MACHINE.format(memory=80_000_000, file=f"big.{syntax}")
    result = subprocess.run([sys.executable, "-c", program], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    err = clean_failure(result)
    line = 2 if syntax == "yaml" else 1
    column = len(prefix) + 2 * (first_past - 1) + 1
    assert f"big.{syntax}:{line}:{column}: error: (top level): the document " in err
    assert "more than 100,000 values, as many as this machine's memory allows reading (about 300 bytes a value, 28.6 MiB " \
        "in all); refusing to load it" in err
    _, peak_kib = result.stdout.split()  # memory, not time: the machine may be shared
    assert int(peak_kib) < 200 * 1024
