"""Mesh files and inline meshes: what is read, and the message for each kind of bad input."""

import numpy as np
import pytest

from scenefmt import meshgen
from scenefmt import models as m
from scenefmt.diagnostics import SceneError
from scenefmt.meshfile import MeshProblem, read_mesh, read_obj
from scenefmt.validation import loads

SCENE = """
camera: {{look_from: [0, 0, 5], look_at: [0, 0, 0]}}
materials: {{white: {{type: lambertian, albedo: [0.5, 0.5, 0.5]}}}}
shapes:
  - {{type: mesh, {mesh}, material: white}}
"""


def load_mesh_scene(tmp_path, mesh: str):
    return loads(SCENE.format(mesh=mesh), file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)


def errors_of(tmp_path, mesh: str) -> list[str]:
    with pytest.raises(SceneError) as info:
        load_mesh_scene(tmp_path, mesh)
    return [str(d) for d in info.value.diagnostics]


def test_obj_and_ply_of_a_mesh_read_to_the_same_arrays(tmp_path):
    v, f = meshgen.icosphere(5)
    a = read_mesh(meshgen.write_obj(tmp_path / "s.obj", v, f))
    b = read_mesh(meshgen.write_ply(tmp_path / "s.ply", v, f))
    c = read_mesh(meshgen.write_ply(tmp_path / "t.ply", v, f, binary=False))
    for mesh in (a, b, c):
        assert np.array_equal(mesh.vertices, v) and np.array_equal(mesh.faces, f)


def test_obj_polygons_are_cut_into_fans_and_negative_indices_count_back():
    mesh = read_obj(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\ng x\nf -5 -4 -1\n")
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 1, 4]]
    assert mesh.polygons == 2


def test_obj_corners_with_texture_coordinates_and_normals_become_vertices():
    mesh = read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nvn 0 0 1\n"
                    b"f 1/1/1 2/2/1 3/3/1\nf 1/4/1 3/3/1 2/2/1\n")
    # Vertex 1 has two texture coordinates: it becomes two vertices.
    assert len(mesh.vertices) == 4 and mesh.uvs.shape == (4, 2) and mesh.normals.shape == (4, 3)
    assert {tuple(mesh.uvs[i]) for i in mesh.faces[1]} == {(0.5, 0.5), (0.0, 1.0), (1.0, 0.0)}


@pytest.mark.parametrize("text, line, words", [
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 x 0\nf 1 2 3\n", 4, "expects numbers"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n", 5, "vertex index 4 is out of range"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "at least 3 corners"),
    (b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", 3, "NaN or infinite"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n", 3, "NaN or infinite"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "index 0 is out of range"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/2\n", 5, "texture coordinate index 2"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nbogus 1 2\nf 1 2 3\n", 4, "unknown OBJ statement (not shown: a word of 5"),
])
def test_a_broken_obj_line_is_reported_with_its_file_and_line(tmp_path, text, line, words):
    (tmp_path / "bad.obj").write_bytes(text)
    (message,) = errors_of(tmp_path, "file: bad.obj")
    assert f"mesh file 'bad.obj' line {line}: " in message and words in message
    assert "scene.yaml:5:" in message  # placed at the scene's file: key


@pytest.mark.parametrize("setup, words", [
    (lambda d: None, "not found"),
    (lambda d: (d / "bad.obj").mkdir(), "is a directory"),
    (lambda d: (d / "bad.obj").write_bytes(b"# nothing here\n"), "the mesh has no faces"),
    (lambda d: (d / "bad.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"), "every one of the mesh's 1 triangles has zero area"),
])
def test_missing_unreadable_and_empty_mesh_files_are_errors(tmp_path, setup, words):
    setup(tmp_path)
    (message,) = errors_of(tmp_path, "file: bad.obj")
    assert "mesh file 'bad.obj'" in message and words in message


def test_a_ply_that_promises_more_than_it_holds_or_points_outside_is_an_error(tmp_path):
    v, f = meshgen.icosphere(1)
    path = meshgen.write_ply(tmp_path / "s.ply", v, f)
    data = path.read_bytes().replace(b"element face 20", b"element face 2000000000")
    (tmp_path / "big.ply").write_bytes(data)
    (message,) = errors_of(tmp_path, "file: big.ply")
    assert "promises more elements" in message
    meshgen.write_ply(tmp_path / "oor.ply", v, np.concatenate([f, [[0, 1, 99]]]))
    (message,) = errors_of(tmp_path, "file: oor.ply")
    assert "triangle 21 refers to vertex 100 of 12" in message


def test_zero_area_triangles_are_dropped_and_counted_in_a_warning(tmp_path):
    (tmp_path / "d.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 3 3 3\n")
    loaded = load_mesh_scene(tmp_path, "file: d.obj")
    (warning,) = [str(w) for w in loaded.warnings]
    assert "2 of its 3 triangles have zero area and are left out" in warning
    (shape,) = loaded.graph.root.members
    assert shape.mesh.faces.tolist() == [[0, 1, 2]]


def test_inline_meshes_take_lists_or_numpy_arrays_and_check_their_indices(tmp_path):
    loaded = load_mesh_scene(tmp_path, "vertices: [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], faces: [[0, 1, 2, 3]]")
    assert loaded.graph.root.members[0].mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    mesh = m.Mesh(vertices=np.eye(3), faces=np.array([[0, 1, 2]], np.int32), material="white")
    assert mesh.vertices.dtype == np.float64 and not mesh.vertices.flags.writeable
    (message,) = errors_of(tmp_path, "vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces: [[0, 1, 3]]")
    assert "face 0 refers to vertex 3, but there are 3" in message
    (message,) = errors_of(tmp_path, "vertices: [[0, 0, 0], [1, 0, 0], [0, 1, .nan]], faces: [[0, 1, 2]]")
    assert "vertex 2 has a NaN or infinite coordinate" in message
    (message,) = errors_of(tmp_path, "file: a.obj, vertices: [[0, 0, 0]]")
    assert "either `file` or `vertices` and `faces`, not both" in message


def test_the_memory_estimate_counts_mesh_triangles(tmp_path):
    v, f = meshgen.icosphere(20)
    meshgen.write_ply(tmp_path / "s.ply", v, f)
    loaded = load_mesh_scene(tmp_path, "file: s.ply")
    from scenefmt.bounds import MESH_TRIANGLE_BYTES
    assert loaded.graph.memory.primitives == len(f) * MESH_TRIANGLE_BYTES


@pytest.mark.parametrize("closed", [lambda: meshgen.icosphere(5), lambda: meshgen.torus_knot(2, 3, 64, 8), lambda: meshgen.torus_knot(3, 2, 48, 6)])
def test_closed_meshes_made_here_wind_outward(closed):
    # A glass mesh is entered where u x v faces the ray: an inward winding turns it into a bubble.
    v, f = closed()
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    signed_volume = np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum() / 6
    assert signed_volume > 0
