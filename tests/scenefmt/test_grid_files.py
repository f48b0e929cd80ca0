"""A grid medium's file: read as the scene names it, checked before use, refused in one sentence."""

from __future__ import annotations

import subprocess
import sys
import zipfile

import numpy as np
import pytest

from scenefmt.bounds import estimate_memory
from scenefmt.diagnostics import SceneError
from scenefmt.gridfile import GridProblem, read_grid
from scenefmt.validation import load

SCENE = """
camera: {{look_from: [0, 0, 5], look_at: [0, 0, 0]}}
media:
  cloud: {{type: grid, file: {file}, {key}bounds: [[0, 0, 0], [1, 1, 1]], interpolation: nearest}}
shapes:
  - {{type: box, min: [0, 0, 0], max: [1, 1, 1], interior: cloud}}
"""


def scene(tmp_path, file: str, key: str | None = None):
    path = tmp_path / "scene.yaml"
    path.write_text(SCENE.format(file=file, key=f"key: {key}, " if key else ""))
    return path


def problem(tmp_path, file: str, key: str | None = None) -> str:
    with pytest.raises(SceneError) as info:
        load(scene(tmp_path, file, key))
    return str(info.value)


def test_an_npy_and_an_npz_grid_are_read_as_float64_in_their_axes_order(tmp_path):
    values = np.arange(24, dtype=np.float32).reshape(2, 3, 4)
    np.save(tmp_path / "a.npy", values)
    np.savez_compressed(tmp_path / "b.npz", other=np.zeros(3), density=values)
    for name, key in (("a.npy", None), ("b.npz", "density")):
        medium = load(scene(tmp_path, name, key)).graph.media[0]
        assert medium.grid.dtype == np.float64 and medium.grid.shape == (2, 3, 4)
        assert np.array_equal(medium.grid, values)
    fortran = np.asfortranarray(values.astype(np.float64))
    np.save(tmp_path / "f.npy", fortran)
    assert np.array_equal(read_grid(tmp_path / "f.npy", None), values)


@pytest.mark.parametrize("values, words", [
    (np.array([[[1.0, np.nan]]]), "1 of its values are not finite"),
    (np.array([[[1.0, -0.5]]]), "1 of its values are negative"),
    (np.zeros((3, 3)), "has 2 dimensions, not 3"),
    (np.zeros((2, 0, 2)), "is empty"),
    (np.array([[["a"]]]), "not numbers"),
])
def test_bad_values_are_refused_with_the_reason(tmp_path, values, words):
    np.save(tmp_path / "g.npy", values)
    message = problem(tmp_path, "g.npy")
    assert "grid file 'g.npy'" in message and words in message


def test_a_pickled_array_is_never_unpickled(tmp_path):
    np.save(tmp_path / "g.npy", np.array([[[{"x": 1}]]], dtype=object), allow_pickle=True)
    assert "not numbers" in problem(tmp_path, "g.npy")


def test_a_huge_shape_is_refused_from_its_header_before_any_value_is_read(tmp_path):
    path = tmp_path / "g.npy"
    with open(path, "wb") as fh:
        np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False, "shape": (4096, 4096, 4096)})
    with pytest.raises(GridProblem, match="larger than allowed"):
        read_grid(path, None)


def test_a_short_file_a_missing_key_and_a_broken_archive_are_refused(tmp_path):
    np.save(tmp_path / "g.npy", np.ones((4, 4, 4)))
    (tmp_path / "short.npy").write_bytes((tmp_path / "g.npy").read_bytes()[:-100])
    assert "ends before" in problem(tmp_path, "short.npy")
    np.savez(tmp_path / "h.npz", density=np.ones((2, 2, 2)))
    assert "holds no array 'smoke' (it holds 'density')" in problem(tmp_path, "h.npz", "smoke")
    (tmp_path / "bad.npz").write_bytes(b"not a zip at all")
    assert "not a readable .npz archive" in problem(tmp_path, "bad.npz", "density")
    with zipfile.ZipFile(tmp_path / "odd.npz", "w") as archive:
        archive.writestr("density.npy", b"\x93NUMPY garbage")
    assert "grid file 'odd.npz'" in problem(tmp_path, "odd.npz", "density")


def test_the_file_is_found_by_the_one_rule_for_named_files(tmp_path):
    assert "not found" in problem(tmp_path, "missing.npy")
    outside = tmp_path.parent / f"{tmp_path.name}_outside.npy"
    np.save(outside, np.ones((2, 2, 2)))
    assert "outside" in problem(tmp_path, f"../{outside.name}")


@pytest.mark.parametrize("text, words", [
    ("{type: grid, file: g.txt, bounds: [[0, 0, 0], [1, 1, 1]], interpolation: nearest}", "a .npy or .npz file"),
    ("{type: grid, file: g.npz, bounds: [[0, 0, 0], [1, 1, 1]], interpolation: nearest}", "name the grid's with `key`"),
    ("{type: grid, file: g.npy, key: d, bounds: [[0, 0, 0], [1, 1, 1]], interpolation: nearest}", "only for .npz"),
    ("{type: grid, file: g.npy, bounds: [[0, 0, 0], [1, 0, 1]], interpolation: nearest}", "no positive size along y"),
    ("{type: grid, file: g.npy, bounds: [[0, 0, 0], [1, 1, 1]]}", "interpolation"),
    ("{type: constant, density: 1, phase: {type: henyey_greenstein, g: 1}}", "g"),
])
def test_the_model_refuses_what_cannot_be_a_grid(tmp_path, text, words):
    path = tmp_path / "s.yaml"
    path.write_text(f"camera: {{look_from: [0, 0, 5], look_at: [0, 0, 0]}}\nmedia:\n  m: {text}\n"
                    "shapes:\n  - {type: box, min: [0, 0, 0], max: [1, 1, 1], interior: m}\n")
    with pytest.raises(SceneError) as info:
        load(path)
    assert words in str(info.value)


def test_the_memory_estimate_counts_the_grid(tmp_path):
    np.save(tmp_path / "g.npy", np.ones((64, 64, 64)))
    estimate = estimate_memory(load(scene(tmp_path, "g.npy")).graph)
    assert estimate.media >= 64 ** 3 * 16 and "media" in estimate.describe()


def test_rt_validate_refuses_a_bad_grid_in_one_sentence(tmp_path):
    np.save(tmp_path / "g.npy", np.array([[[1.0, np.inf]]]))
    out = subprocess.run([sys.executable, "-m", "rt", "validate", str(scene(tmp_path, "g.npy"))],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    assert "grid file 'g.npy': 1 of its values are not finite" in out.stdout + out.stderr
    assert "Traceback" not in out.stdout + out.stderr
