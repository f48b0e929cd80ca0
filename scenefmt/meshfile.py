"""Reading triangle meshes: Wavefront OBJ (our reader) and PLY (through plyfile).

`read_mesh(path)` returns a `MeshData`: vertex positions, triangles (polygons are cut into fans),
and the per-vertex normals and texture coordinates when the file has them for every corner.
Every problem is a `MeshProblem` saying what is wrong and, where the file format allows, at
which line (OBJ) or element (PLY): a line that does not parse, an index out of range, a NaN or
infinite coordinate, an empty mesh. Zero-area triangles are dropped and counted
(`MeshData.degenerate`), never passed on.

The OBJ reader is vectorised: it splits the file into lines once, classifies them with numpy,
and parses every `v` and every `f` line in one numpy call each. Only when that fast path meets
something it does not expect does a line-by-line pass run, to name the first bad line. A
10^6-triangle OBJ reads in about a second this way (docs/meshes.md); trimesh's OBJ loader took
2.5 s and reports no line numbers. PLY goes through plyfile (one small pure-Python module): with
the face list length declared it reads 10^6 binary triangles in 0.05 s.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from .files import FileProblem, open_regular_file, read_regular_file

# Largest mesh file read (a scene's memory estimate also counts its triangles).
MAX_MESH_BYTES = 4 << 30
# Two edges whose cross product is below this fraction of their lengths' product make a zero-area triangle.
DEGENERATE = 1e-12
# OBJ keywords that carry no surface and are skipped (materials, groups, curves, ...).
_OBJ_IGNORED = {
    b"vp", b"l", b"p", b"o", b"g", b"s", b"usemtl", b"mtllib", b"curv", b"curv2", b"surf", b"cstype", b"deg",
    b"bmat", b"step", b"parm", b"trim", b"hole", b"scrv", b"sp", b"end", b"con", b"mg", b"lod", b"bevel",
    b"c_interp", b"d_interp", b"ctech", b"stech", b"shadow_obj", b"trace_obj", b"maplib", b"usemap",
}
SUFFIXES = (".obj", ".ply")


class MeshProblem(Exception):
    """A mesh file cannot be used; `line` is the 1-based line (OBJ) where one is known."""

    def __init__(self, message: str, line: Optional[int] = None):
        super().__init__(message)
        self.message = message
        self.line = line

    def __str__(self) -> str:
        return f"line {self.line}: {self.message}" if self.line is not None else self.message


@dataclass
class MeshData:
    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (T, 3) int64, rows of `vertices`
    normals: Optional[np.ndarray] = None  # (V, 3) float64, per vertex
    uvs: Optional[np.ndarray] = None  # (V, 2) float64, per vertex
    polygons: int = 0  # faces in the file, before triangulation
    degenerate: int = 0  # zero-area triangles dropped


def read_mesh(path, drop_degenerate: bool = True) -> MeshData:
    """The mesh in an OBJ or PLY file, checked; raises MeshProblem (or FileProblem)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        mesh = read_obj(read_regular_file(path, MAX_MESH_BYTES))
    elif suffix == ".ply":
        mesh = read_ply(path)
    else:
        raise MeshProblem(f"unknown mesh format {suffix or '(no suffix)'!r}: expected a .obj or .ply file")
    return check_mesh(mesh, drop_degenerate)


def from_arrays(vertices, faces, normals=None, uvs=None, drop_degenerate: bool = True) -> MeshData:
    """A MeshData from arrays given inline (faces may be polygons of equal size, or lists)."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    if isinstance(faces, np.ndarray) and faces.ndim == 2:
        f, polygons = _fans(faces.astype(np.int64).reshape(-1), np.full(len(faces), faces.shape[1])), len(faces)
    else:
        counts = np.array([len(face) for face in faces], np.int64)
        flat = np.array([i for face in faces for i in face], np.int64)
        f, polygons = _fans(flat, counts), len(counts)
    mesh = MeshData(v, f, None if normals is None else np.asarray(normals, np.float64).reshape(-1, 3),
                    None if uvs is None else np.asarray(uvs, np.float64).reshape(-1, 2), polygons)
    return check_mesh(mesh, drop_degenerate)


def check_mesh(mesh: MeshData, drop_degenerate: bool = True) -> MeshData:
    """Reject what cannot be rendered; drop (and count) zero-area triangles."""
    v, f = mesh.vertices, mesh.faces
    if len(f) == 0:
        raise MeshProblem("the mesh has no faces")
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise MeshProblem(f"vertex {int(np.argmax(bad)) + 1} has a NaN or infinite coordinate")
    if f.min() < 0 or f.max() >= len(v):
        row = int(np.argmax((f < 0).any(axis=1) | (f >= len(v)).any(axis=1)))
        raise MeshProblem(f"triangle {row + 1} refers to vertex {int(f[row][(f[row] < 0) | (f[row] >= len(v))][0]) + 1} "
                          f"of {len(v)}")
    for name, values, width in (("normal", mesh.normals, 3), ("texture coordinate", mesh.uvs, 2)):
        if values is None:
            continue
        if values.shape != (len(v), width):
            raise MeshProblem(f"{len(values)} {name}s for {len(v)} vertices")
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():
            raise MeshProblem(f"{name} {int(np.argmax(bad)) + 1} has a NaN or infinite value")
    if drop_degenerate:
        p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        e1, e2 = p1 - p0, p2 - p0
        area = np.linalg.norm(np.cross(e1, e2), axis=1)
        keep = area > DEGENERATE * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
        mesh.degenerate = int(len(f) - keep.sum())
        if mesh.degenerate:
            mesh.faces = f[keep]
        if len(mesh.faces) == 0:
            raise MeshProblem(f"every one of the mesh's {len(f)} triangles has zero area")
    return mesh


def _fans(corners: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Triangles (c0, ck, ck+1) of polygons given as their corners, one after another."""
    counts = np.asarray(counts, np.int64)
    if len(counts) and counts.min() < 3:
        raise MeshProblem(f"face {int(np.argmax(counts < 3)) + 1} has {int(counts.min())} corners; at least 3 are needed")
    if len(counts) and counts.max() == 3 and counts.min() == 3:
        return corners.reshape(-1, 3)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    tris = counts - 2
    face = np.repeat(np.arange(len(counts)), tris)
    k = np.arange(len(face)) - np.repeat(np.concatenate([[0], np.cumsum(tris)[:-1]]), tris)
    first = start[face]
    return np.stack([corners[first], corners[first + k + 1], corners[first + k + 2]], 1)


# --- OBJ --------------------------------------------------------------------------------------


def read_obj(data: bytes) -> MeshData:
    """Parse OBJ text (v, vt, vn, f; everything else that carries no surface is skipped)."""
    try:
        return _obj_fast(data)
    except _NotSimple:
        pass
    return _obj_slow(data)


class _NotSimple(Exception):
    """The fast path met something it does not handle: the line-by-line reader decides."""


def _tokens_per_line(body: bytes) -> np.ndarray:
    """How many whitespace-separated tokens each newline-separated line of `body` has."""
    arr = np.frombuffer(body, np.uint8)
    newline = arr == 10
    space = (arr == 32) | (arr == 9) | (arr == 13) | newline
    start = ~space
    start[1:] &= space[:-1]
    # Token starts between consecutive line starts.
    bounds = np.concatenate([[0], np.flatnonzero(newline) + 1, [len(arr)]])
    return np.diff(np.searchsorted(np.flatnonzero(start), bounds))


def _obj_fast(data: bytes) -> MeshData:
    if b"\\" in data:  # line continuations
        raise _NotSimple
    lines = data.split(b"\n")
    arr = np.frombuffer(data, np.uint8)
    starts = np.concatenate([[0], np.flatnonzero(arr == 10) + 1])
    padded = np.concatenate([arr, np.zeros(3, np.uint8)])
    c0, c1 = padded[starts], padded[starts + 1]
    blank1 = (c1 == 32) | (c1 == 9)
    is_v = (c0 == ord("v")) & blank1
    is_vt = (c0 == ord("v")) & (c1 == ord("t")) & ((padded[starts + 2] == 32) | (padded[starts + 2] == 9))
    is_vn = (c0 == ord("v")) & (c1 == ord("n")) & ((padded[starts + 2] == 32) | (padded[starts + 2] == 9))
    is_f = (c0 == ord("f")) & blank1
    other = np.flatnonzero(~(is_v | is_vt | is_vn | is_f))
    for k in other.tolist():
        words = lines[k].split(None, 1)
        if words and not words[0].startswith(b"#") and words[0] not in _OBJ_IGNORED:
            raise _NotSimple
    v = _obj_rows(lines, np.flatnonzero(is_v), 2, 3)
    vt = _obj_rows(lines, np.flatnonzero(is_vt), 3, 2) if is_vt.any() else None
    vn = _obj_rows(lines, np.flatnonzero(is_vn), 3, 3) if is_vn.any() else None
    f_lines = np.flatnonzero(is_f)
    body = b"\n".join([lines[k][2:] for k in f_lines.tolist()])
    counts = _tokens_per_line(body)
    if len(counts) != len(f_lines) or (len(counts) and counts.min() < 3):
        raise _NotSimple
    first = body.split(None, 1)[0] if body.strip() else b""
    parts = first.count(b"/") + 1
    if parts > 3 or body.count(b"/") != (parts - 1) * int(counts.sum()):
        raise _NotSimple
    text = body.replace(b"//", b"/0/").replace(b"/", b" ") if parts > 1 else body
    values = _numbers(text, np.int64)
    if len(values) != parts * int(counts.sum()):
        raise _NotSimple
    values = values.reshape(-1, parts)
    # Negative indices count back from the elements defined before the face's line.
    per_corner_line = np.repeat(f_lines, counts)
    columns = []
    for col, (rows, mask) in enumerate(((v, is_v), (vt, is_vt), (vn, is_vn))[:parts]):
        idx = values[:, col]
        if col > 0 and (idx == 0).any():
            if (idx == 0).all():
                columns.append(None)
                continue
            raise _NotSimple  # some corners with, some without: let the slow path say where
        if (idx < 0).any():
            before = np.searchsorted(np.flatnonzero(mask), per_corner_line)
            idx = np.where(idx < 0, idx + before, idx - 1)
        else:
            idx = idx - 1
        n = 0 if rows is None else len(rows)
        if (idx < 0).any() or (idx >= n).any():
            raise _NotSimple
        columns.append(idx)
    while len(columns) < 3:
        columns.append(None)
    return _obj_assemble(v, vt, vn, columns, counts)


def _numbers(text: bytes, dtype) -> np.ndarray:
    """Every number in `text` (whitespace-separated), parsed in C; _NotSimple if one does not parse."""
    if not text.strip():
        return np.zeros(0, dtype)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return np.fromstring(text, dtype=dtype, sep=" ")
    except (ValueError, DeprecationWarning):
        raise _NotSimple from None


def _obj_rows(lines, which: np.ndarray, skip: int, width: int) -> np.ndarray:
    """The first `width` numbers of each of `lines[which]`, after the keyword (`skip` bytes)."""
    body = b"\n".join([lines[k][skip:] for k in which.tolist()])
    values = _numbers(body, np.float64)
    if len(values) == width * len(which):
        out = values.reshape(-1, width)
    else:
        counts = _tokens_per_line(body)
        if len(counts) != len(which) or counts.min() < width or len(values) != counts.sum():
            raise _NotSimple
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        out = values[first[:, None] + np.arange(width)[None, :]]
    if not np.isfinite(out).all():
        raise _NotSimple
    return out


def _obj_assemble(v, vt, vn, columns, counts) -> MeshData:
    iv, it, inn = columns
    use_uv = it is not None and vt is not None
    use_n = inn is not None and vn is not None
    if not (use_uv or use_n):
        return MeshData(v, _fans(iv, counts), polygons=len(counts))
    # A vertex is a distinct (position, uv, normal) combination.
    key = np.stack([iv] + ([it] if use_uv else []) + ([inn] if use_n else []), 1)
    unique, corner = np.unique(key, axis=0, return_inverse=True)
    corner = corner.reshape(-1)
    return MeshData(
        v[unique[:, 0]], _fans(corner, counts),
        normals=vn[unique[:, -1]] if use_n else None,
        uvs=vt[unique[:, 1]] if use_uv else None,
        polygons=len(counts),
    )


def _obj_slow(data: bytes) -> MeshData:
    """Line by line: the same result as the fast path, or a MeshProblem naming the first bad line."""
    v, vt, vn = [], [], []
    corners: list[tuple] = []
    counts = []
    pending = b""
    start_line = 0
    for number, raw in enumerate(data.split(b"\n"), 1):
        line = pending + raw.rstrip(b"\r")
        if line.endswith(b"\\"):
            if not pending:
                start_line = number
            pending = line[:-1] + b" "
            continue
        at = start_line if pending else number
        pending = b""
        words = line.split(b"#", 1)[0].split()
        if not words:
            continue
        key = words[0]
        try:
            text = [w.decode("ascii") for w in words[1:]]
        except UnicodeDecodeError:
            raise MeshProblem("the line is not ASCII text", at) from None
        if key in (b"v", b"vn", b"vt"):
            need = 2 if key == b"vt" else 3
            if len(text) < need:
                raise MeshProblem(f"'{key.decode()}' needs {need} numbers, found {len(text)}", at)
            try:
                nums = [float(x) for x in text[:need]]
            except ValueError:
                raise MeshProblem(f"'{key.decode()}' expects numbers, found {' '.join(text[:need])!r}", at) from None
            if not all(np.isfinite(nums)):
                raise MeshProblem(f"'{key.decode()}' has a NaN or infinite value", at)
            {b"v": v, b"vt": vt, b"vn": vn}[key].append(nums)
        elif key == b"f":
            if len(text) < 3:
                raise MeshProblem(f"a face needs at least 3 corners, found {len(text)}", at)
            face = []
            for word in text:
                parts = word.split("/")
                if len(parts) > 3 or parts[0] == "":
                    raise MeshProblem(f"a face corner must be v, v/vt, v//vn or v/vt/vn, found {word!r}", at)
                ids = []
                for part, table, what in zip(parts, (v, vt, vn), ("vertex", "texture coordinate", "normal")):
                    if part == "":
                        ids.append(None)
                        continue
                    try:
                        i = int(part)
                    except ValueError:
                        raise MeshProblem(f"a face corner must be whole numbers, found {word!r}", at) from None
                    j = i - 1 if i > 0 else len(table) + i
                    if i == 0 or not 0 <= j < len(table):
                        raise MeshProblem(f"{what} index {i} is out of range: {len(table)} defined before this line", at)
                    ids.append(j)
                ids += [None] * (3 - len(ids))
                face.append(tuple(ids))
            corners.extend(face)
            counts.append(len(face))
        elif key.startswith(b"#") or key in _OBJ_IGNORED:
            continue
        else:
            raise MeshProblem(f"unknown OBJ statement {key.decode('ascii', 'replace')!r}", at)
    vertices = np.array(v, np.float64).reshape(-1, 3)
    if not corners:
        return MeshData(vertices, np.zeros((0, 3), np.int64))
    iv = np.array([c[0] for c in corners], np.int64)
    columns = [iv]
    for k in (1, 2):
        have = [c[k] is not None for c in corners]
        columns.append(np.array([c[k] for c in corners], np.int64) if all(have) else None)
    return _obj_assemble(vertices, np.array(vt, np.float64).reshape(-1, 2), np.array(vn, np.float64).reshape(-1, 3),
                         columns, np.array(counts, np.int64))


# --- PLY --------------------------------------------------------------------------------------

_PLY_SIZES = {"char": 1, "uchar": 1, "short": 2, "ushort": 2, "int": 4, "uint": 4, "float": 4, "double": 8,
              "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4, "uint32": 4, "float32": 4, "float64": 8}


def _ply_header(fh) -> tuple[str, list[tuple[str, int, list]]]:
    """(format, [(element, count, [(property, type or ('list', count type, item type))])]) from a PLY header."""
    lines = []
    size = 0
    while True:
        line = fh.readline(4096)
        size += len(line)
        if not line or size > 1 << 20:
            raise MeshProblem("not a PLY file: no end_header line in its first MiB")
        text = line.decode("ascii", "replace").strip()
        lines.append(text)
        if text == "end_header":
            break
    if lines[0] != "ply":
        raise MeshProblem("not a PLY file: it does not start with 'ply'")
    fmt, elements = None, []
    for text in lines[1:-1]:
        words = text.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) >= 2:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) >= 3:
            elements[-1][2].append((words[-1], tuple(words[1:-1])))
        else:
            raise MeshProblem(f"PLY header line {text!r} is not understood")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise MeshProblem(f"PLY format {fmt!r} is not ascii, binary_little_endian or binary_big_endian")
    return fmt, elements


def _sizes_say_triangles(fh, elements, size: int, face_prop: str) -> bool:
    """Whether a binary file's size is exactly that of its elements with every face a triangle.

    plyfile reads a list of known length as fixed-size records (0.05 s for 10^6 triangles,
    against 2.7 s for lists read one by one) but cannot check the lengths; the file's size does.
    """
    _ply_header(fh)
    expected = fh.tell()
    for name, count, props in elements:
        each = 0
        for prop, kind in props:
            if kind[0] == "list":
                if len(kind) != 3 or kind[1] not in _PLY_SIZES or kind[2] not in _PLY_SIZES:
                    return False
                if not (name == "face" and prop == face_prop):
                    return False  # another list: records of unknown size
                each += _PLY_SIZES[kind[1]] + 3 * _PLY_SIZES[kind[2]]
            elif kind[0] in _PLY_SIZES:
                each += _PLY_SIZES[kind[0]]
            else:
                return False
        expected += count * each
    return expected == size


def read_ply(path) -> MeshData:
    """Parse a PLY file through plyfile: vertex x, y, z (nx, ny, nz; u, v or s, t) and face lists."""
    try:
        from plyfile import PlyData, PlyParseError
    except ImportError:  # a dependency, but an environment can still lack it: an error, not a traceback
        raise MeshProblem("reading PLY needs the plyfile package, which is not installed: pip install plyfile "
                          "(or convert the mesh to .obj)") from None

    try:
        with open_regular_file(path) as fh:
            fmt, elements = _ply_header(fh)
            fh.seek(0, 2)
            size = fh.tell()
            # A header cannot promise more elements than the file has bytes for.
            least = 0
            for name, count, props in elements:
                each = sum(2 if fmt == "ascii" else _PLY_SIZES.get(p[1][0] if p[1][0] != "list" else p[1][1], 1) for p in props)
                least += count * max(1, each)
            if least > size:
                raise MeshProblem(f"the header promises more elements than the file's {size:,} bytes can hold")
            names = {name: props for name, _, props in elements}
            if "vertex" not in names or "face" not in names:
                raise MeshProblem("a PLY mesh needs a 'vertex' and a 'face' element")
            face_prop = next((p for p, t in names["face"] if t and t[0] == "list" and p in ("vertex_indices", "vertex_index")), None)
            if face_prop is None:
                raise MeshProblem("the 'face' element has no 'vertex_indices' list")
            fh.seek(0)
            triangles = fmt != "ascii" and _sizes_say_triangles(fh, elements, size, face_prop)
            fh.seek(0)
            ply = PlyData.read(fh, known_list_len={"face": {face_prop: 3}}) if triangles else PlyData.read(fh)
            faces = ply["face"][face_prop]
    except (PlyParseError, ValueError, EOFError) as exc:
        raise MeshProblem(f"the PLY file does not parse: {exc}") from None
    vert = ply["vertex"].data
    fields = vert.dtype.names
    for axis in "xyz":
        if axis not in fields:
            raise MeshProblem(f"the PLY vertices have no '{axis}' property")
    vertices = np.stack([vert["x"], vert["y"], vert["z"]], 1).astype(np.float64)
    normals = np.stack([vert["nx"], vert["ny"], vert["nz"]], 1).astype(np.float64) if {"nx", "ny", "nz"} <= set(fields) else None
    uvs = None
    for u, v in (("u", "v"), ("s", "t"), ("texture_u", "texture_v")):
        if u in fields and v in fields:
            uvs = np.stack([vert[u], vert[v]], 1).astype(np.float64)
            break
    if faces.dtype != object:
        f = faces.astype(np.int64).reshape(-1, 3)
        return MeshData(vertices, f, normals, uvs, len(f))
    counts = np.array([len(face) for face in faces], np.int64)
    corners = np.concatenate(faces).astype(np.int64) if len(faces) else np.zeros(0, np.int64)
    return MeshData(vertices, _fans(corners, counts), normals, uvs, len(counts))


def describe(mesh: MeshData) -> str:
    """'1,000 vertices, 2,000 triangles (...)' for `rt validate`."""
    extras = [w for w, have in (("normals", mesh.normals is not None), ("texture coordinates", mesh.uvs is not None)) if have]
    text = f"{len(mesh.vertices):,} vertices, {len(mesh.faces):,} triangles"
    if mesh.polygons and mesh.polygons != len(mesh.faces) + mesh.degenerate:
        text += f" from {mesh.polygons:,} faces"
    if extras:
        text += " with " + " and ".join(extras)
    return text


__all__ = ["FileProblem", "MeshData", "MeshProblem", "from_arrays", "read_mesh", "read_obj", "read_ply", "SUFFIXES"]
