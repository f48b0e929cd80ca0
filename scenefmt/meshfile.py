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

import dataclasses
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from .diagnostics import did_you_mean, key_shown, quote_key, quote_text  # never a line of the file: it may be anything
from .files import FileProblem, LineProblem, open_regular_file

# Largest mesh file read, whatever the memory: beyond it the budget below decides first anyway.
MAX_MESH_BYTES = 4 << 30
# Peak memory while reading, per byte of an OBJ file (measured: 8 for v and f lines, 11 with
# v/vt/vn corners, from the lines split apart and the numbers parsed in bulk), and per triangle
# (its three indices, the fan's temporaries, one chunk of the zero-area test aside).
OBJ_BYTES_PER_FILE_BYTE = 12
READ_TRIANGLE_BYTES = 100
# A face of more corners is refused: a fan of a million triangles around one corner is no
# surface anyone models, and the file that asks for it is 2 bytes a corner.
MAX_FACE_CORNERS = 1_000_000
# Triangles whose area is tested at a time (each costs about 250 bytes of temporaries).
_CHUNK_TRIANGLES = 1 << 20
# Two edges whose cross product is below this fraction of their lengths' product make a zero-area triangle.
DEGENERATE = 1e-12
# OBJ keywords that carry no surface and are skipped (materials, groups, curves, ...).
_OBJ_IGNORED = {
    b"vp", b"l", b"p", b"o", b"g", b"s", b"usemtl", b"mtllib", b"curv", b"curv2", b"surf", b"cstype", b"deg",
    b"bmat", b"step", b"parm", b"trim", b"hole", b"scrv", b"sp", b"end", b"con", b"mg", b"lod", b"bevel",
    b"c_interp", b"d_interp", b"ctech", b"stech", b"shadow_obj", b"trace_obj", b"maplib", b"usemap",
}
SUFFIXES = (".obj", ".ply")


class MeshProblem(LineProblem):
    """A mesh file cannot be used; `line` is the 1-based line (OBJ) where one is known."""


@dataclass
class MeshData:
    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (T, 3) int64, rows of `vertices`
    normals: Optional[np.ndarray] = None  # (V, 3) float64, per vertex
    uvs: Optional[np.ndarray] = None  # (V, 2) float64, per vertex
    polygons: int = 0  # faces in the file, before triangulation
    degenerate: int = 0  # zero-area triangles dropped
    mtllib_line: Optional[int] = None  # an OBJ's first `mtllib` line
    mtllibs: tuple = ()  # an OBJ's material libraries: (line, file name as written), in file order
    material_names: tuple = ()  # the names `usemtl` gives, in the order first used
    face_material: Optional[np.ndarray] = None  # (T,) int32 per triangle: its `usemtl` in material_names, -1 before any
    extent_and_size: Optional[tuple] = None  # (largest coordinate, least triangle size), measured once by scenefmt.bounds
    material_note: Optional[str] = None  # a part of an OBJ cut by material: which, for `rt validate` ("usemtl 'red': plastic")


def read_mesh(path, drop_degenerate: bool = True) -> MeshData:
    """The mesh in an OBJ or PLY file, checked; raises MeshProblem (or FileProblem)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".obj":
        mesh = read_obj(_read_obj_file(path), drop_degenerate)
    elif suffix == ".ply":
        mesh = read_ply(path, drop_degenerate)
    else:
        raise MeshProblem(f"unknown mesh format {suffix or '(no suffix)'!r}: expected a .obj or .ply file")
    return check_mesh(mesh, drop_degenerate)


def read_estimate(path) -> Optional[int]:
    """About the most memory reading the mesh file takes (for an OBJ, from its size), or None."""
    try:
        size = os.stat(path).st_size
    except (OSError, ValueError):
        return None
    return size * OBJ_BYTES_PER_FILE_BYTE if Path(path).suffix.lower() == ".obj" else None


def _budget_problem(need: int, what: str) -> Optional[str]:
    """Why `need` bytes for `what` cannot be had (bounds.memory_limit), or None."""
    from .bounds import gib, memory_limit, memory_limit_text

    if need <= memory_limit():
        return None
    return f"{what} needs about {gib(need)}, more than {memory_limit_text()}"


def _read_obj_file(path) -> bytes:
    """The bytes of an OBJ file, after checking from its size that reading it fits the memory
    budget; read in chunks, each checked for NUL bytes (text has none: a sparse or binary file
    is refused at its first chunk, not after reading it all)."""
    with open_regular_file(path) as fh:
        size = os.fstat(fh.fileno()).st_size
        if size > MAX_MESH_BYTES:
            raise MeshProblem(f"the file is larger than the {MAX_MESH_BYTES:,} bytes allowed ({size:,} bytes)")
        problem = _budget_problem(size * OBJ_BYTES_PER_FILE_BYTE, f"reading this {size:,}-byte OBJ file")
        if problem:
            raise MeshProblem(problem)
        chunks, total = [], 0
        while total <= size:
            chunk = fh.read(min(8 << 20, size + 1 - total))
            if not chunk:
                break
            nul = chunk.find(b"\0")
            if nul >= 0:
                raise MeshProblem(f"not an OBJ text file: byte {total + nul + 1:,} is a NUL byte (a binary or sparse file)")
            chunks.append(chunk)
            total += len(chunk)
        if total > size:
            raise MeshProblem("the file grew while it was read")
    return b"".join(chunks)


def from_arrays(vertices, faces, normals=None, uvs=None, drop_degenerate: bool = True) -> MeshData:
    """A MeshData from arrays given inline (faces may be polygons of equal size, or lists)."""
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    vertex_count = len(v) if drop_degenerate else None  # None: _fans keeps repeated corners
    if isinstance(faces, np.ndarray) and faces.ndim == 2:
        counts = np.full(len(faces), faces.shape[1])
        f, dropped, _ = _fans(faces.astype(np.int64).reshape(-1), counts, vertex_count)
    else:
        counts = np.array([len(face) for face in faces], np.int64)
        flat = np.array([i for face in faces for i in face], np.int64)
        f, dropped, _ = _fans(flat, counts, vertex_count)
    polygons = len(counts)
    mesh = MeshData(v, f, None if normals is None else np.asarray(normals, np.float64).reshape(-1, 3),
                    None if uvs is None else np.asarray(uvs, np.float64).reshape(-1, 2), polygons, dropped)
    return check_mesh(mesh, drop_degenerate)


def check_mesh(mesh: MeshData, drop_degenerate: bool = True) -> MeshData:
    """Reject what cannot be rendered; drop (and count) zero-area triangles."""
    v, f = mesh.vertices, mesh.faces
    if len(f) == 0:
        if mesh.degenerate:  # every triangle repeated a corner and was left out
            raise MeshProblem(f"every one of the mesh's {mesh.degenerate:,} triangles has zero area")
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
        keep = np.empty(len(f), bool)
        for lo in range(0, len(f), _CHUNK_TRIANGLES):  # a chunk at a time: the temporaries stay bounded
            keep[lo:lo + _CHUNK_TRIANGLES] = _has_area(v, f[lo:lo + _CHUNK_TRIANGLES])
        dropped = int(len(f) - keep.sum())
        if dropped:
            mesh.faces = f[keep]
            if mesh.face_material is not None:
                mesh.face_material = mesh.face_material[keep]
        mesh.degenerate += dropped  # with those the fans left out (repeated corners)
        if len(mesh.faces) == 0:
            raise MeshProblem(f"every one of the mesh's {len(mesh.faces) + mesh.degenerate:,} triangles has zero area")
    return mesh


def _has_area(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Which triangles `f` (rows of `v`) have an area above DEGENERATE of their edges' product."""
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    area = np.linalg.norm(np.cross(e1, e2), axis=1)
    return area > DEGENERATE * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)


def _fans(corners: np.ndarray, counts: np.ndarray, vertex_count: Optional[int] = None,
          labels: Optional[np.ndarray] = None) -> tuple[np.ndarray, int, Optional[np.ndarray]]:
    """Triangles (c0, ck, ck+1) of polygons given as their corners, one after another, how
    many were left out for repeating a corner (only when `vertex_count` is given and every corner
    is below it: an index out of range is left for check_mesh to report), and, when `labels`
    gives one per polygon (an OBJ's `usemtl`), the label of each triangle kept.

    The number of triangles is checked against the memory budget before any is made, and the
    fans are cut a chunk of polygons at a time, each chunk's repeated-corner triangles dropped
    before the next: a face of a million repeated corners never exists as a million triangles."""
    counts = np.asarray(counts, np.int64)
    if len(counts) and counts.min() < 3:
        raise MeshProblem(f"face {int(np.argmax(counts < 3)) + 1} has {int(counts.min())} corners; at least 3 are needed")
    if len(counts) and counts.max() > MAX_FACE_CORNERS:
        raise MeshProblem(f"face {int(np.argmax(counts > MAX_FACE_CORNERS)) + 1} has {int(counts.max()):,} corners, "
                          f"more than the {MAX_FACE_CORNERS:,} allowed")
    triangles = int(counts.sum()) - 2 * len(counts)
    problem = _budget_problem(triangles * READ_TRIANGLE_BYTES, f"cutting its {len(counts):,} faces into {triangles:,} triangles")
    if problem:
        raise MeshProblem(problem)
    drop = vertex_count is not None and (len(corners) == 0 or (corners.min() >= 0 and corners.max() < vertex_count))
    if len(counts) and counts.max() == 3 and counts.min() == 3:
        tris = corners.reshape(-1, 3)
        if not drop:
            return tris, 0, labels
        keep = _distinct_corners(tris)
        if keep.all():
            return tris, 0, labels
        return tris[keep], int(len(tris) - keep.sum()), None if labels is None else labels[keep]
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    # Polygons in chunks of about _CHUNK_TRIANGLES triangles (a chunk holds one polygon at least).
    ends = np.searchsorted(np.cumsum(counts - 2), np.arange(_CHUNK_TRIANGLES, triangles + _CHUNK_TRIANGLES, _CHUNK_TRIANGLES),
                           side="right")
    parts, part_labels, dropped, lo = [], [], 0, 0
    for hi in ends.tolist() + [len(counts)]:  # the last: guards the chunking, every polygon is cut
        hi = max(hi, lo + 1) if lo < len(counts) else lo
        if hi <= lo:
            continue
        part = _fan_chunk(corners, start[lo:hi], counts[lo:hi])
        label = None if labels is None else np.repeat(labels[lo:hi], counts[lo:hi] - 2)
        if drop:
            keep = _distinct_corners(part)
            dropped += int(len(part) - keep.sum())
            part = part[keep]
            label = None if label is None else label[keep]
        parts.append(part)
        part_labels.append(label)
        lo = hi
    tris = np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)
    if labels is None:
        return tris, dropped, None
    return tris, dropped, (np.concatenate(part_labels) if part_labels else np.zeros(0, np.int32))


def _distinct_corners(tris: np.ndarray) -> np.ndarray:
    """Which triangles have three different corners (one that repeats a corner has no area)."""
    return (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])


def _fan_chunk(corners: np.ndarray, start: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The fan triangles of the polygons with corners from `start` (counts of each)."""
    tris = counts - 2
    face = np.repeat(np.arange(len(counts)), tris)
    k = np.arange(len(face)) - np.repeat(np.concatenate([[0], np.cumsum(tris)[:-1]]), tris)
    first = start[face]
    return np.stack([corners[first], corners[first + k + 1], corners[first + k + 2]], 1)


# --- OBJ --------------------------------------------------------------------------------------


def read_obj(data: bytes, drop_degenerate: bool = True) -> MeshData:
    """Parse OBJ text (v, vt, vn, f; everything else that carries no surface is skipped).
    With `drop_degenerate`, triangles that repeat a corner are left out as the fans are cut."""
    try:
        return _obj_fast(data, drop_degenerate)
    except _NotSimple:
        pass
    return _obj_slow(data, drop_degenerate)


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


def _obj_fast(data: bytes, drop_degenerate: bool = True) -> MeshData:
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
    materials = _MaterialStatements()
    for k in other.tolist():
        words = lines[k].split(None, 1)
        if words and not words[0].startswith(b"#") and words[0] not in _OBJ_IGNORED:
            raise _NotSimple
        if words and words[0] in (b"mtllib", b"usemtl"):
            materials.read(words, k)
    v = _obj_rows(lines, np.flatnonzero(is_v), 2, 3)
    vt = _obj_rows(lines, np.flatnonzero(is_vt), 3, 2) if is_vt.any() else None
    vn = _obj_rows(lines, np.flatnonzero(is_vn), 3, 3) if is_vn.any() else None
    f_lines = np.flatnonzero(is_f)
    body = b"\n".join([lines[k][2:] for k in f_lines.tolist()])
    counts = _tokens_per_line(body)
    if len(counts) != len(f_lines) or (len(counts) and counts.min() < 3):
        raise _NotSimple
    if len(counts) and counts.max() > MAX_FACE_CORNERS:  # said before a number of it is parsed
        worst = int(np.argmax(counts))
        raise MeshProblem(f"a face has {int(counts[worst]):,} corners, more than the {MAX_FACE_CORNERS:,} allowed",
                          int(f_lines[worst]) + 1)
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
    per_corner_line = None
    columns = []
    for col, (rows, mask) in enumerate(((v, is_v), (vt, is_vt), (vn, is_vn))[:parts]):
        idx = values[:, col]
        if col > 0 and (idx == 0).any():
            if (idx == 0).all():
                columns.append(None)
                continue
            raise _NotSimple  # some corners with, some without: let the slow path say where
        if (idx < 0).any():
            if per_corner_line is None:  # made only when needed: 8 bytes a corner
                per_corner_line = np.repeat(f_lines, counts)
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
    mesh = _obj_assemble(v, vt, vn, columns, counts, drop_degenerate, materials.face_labels(f_lines))
    materials.describe(mesh)
    return mesh


class _MaterialStatements:
    """An OBJ's `mtllib` and `usemtl` lines, gathered as either reader meets them (0-based line
    indices), and what they make of each face: the `usemtl` in force on its line."""

    def __init__(self):
        self.libraries: list = []  # (1-based line, file name)
        self.use_lines: list = []  # 0-based line of each usemtl
        self.use_codes: list = []  # its name's place in self.names
        self.names: dict = {}  # name -> place, in the order first used

    def read(self, words: list, k: int) -> None:
        """Note statement `words` (keyword and the rest of the line) of 0-based line `k`."""
        rest = words[1].split(b"#", 1)[0].strip() if len(words) > 1 else b""
        if words[0] == b"mtllib":
            # Several libraries may share a line; a name with spaces cannot be told from two.
            self.libraries += [(k + 1, w.decode("utf-8", "replace")) for w in rest.split()]
        else:
            name = rest.decode("utf-8", "replace")
            self.use_lines.append(k)
            self.use_codes.append(self.names.setdefault(name, len(self.names)))

    def face_labels(self, f_lines: np.ndarray) -> Optional[np.ndarray]:
        """Each face's material (a place in the names; -1 before any usemtl), from the 0-based
        lines of the faces; None when the file has no usemtl (nothing is made then)."""
        if not self.use_lines:
            return None
        codes = np.array([-1] + self.use_codes, np.int32)
        return codes[np.searchsorted(np.array(self.use_lines, np.int64), f_lines, side="right")]

    def describe(self, mesh: MeshData) -> None:
        mesh.mtllibs = tuple(self.libraries)
        mesh.mtllib_line = self.libraries[0][0] if self.libraries else None
        mesh.material_names = tuple(self.names)


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


def _obj_assemble(v, vt, vn, columns, counts, drop_degenerate: bool = True, labels=None) -> MeshData:
    iv, it, inn = columns
    use_uv = it is not None and vt is not None
    use_n = inn is not None and vn is not None
    if not (use_uv or use_n):
        faces, dropped, labels = _fans(iv, counts, len(v) if drop_degenerate else None, labels)
        return MeshData(v, faces, polygons=len(counts), degenerate=dropped, face_material=labels)
    # A vertex is a distinct (position, uv, normal) combination.
    key = np.stack([iv] + ([it] if use_uv else []) + ([inn] if use_n else []), 1)
    unique, corner = np.unique(key, axis=0, return_inverse=True)
    corner = corner.reshape(-1)
    faces, dropped, labels = _fans(corner, counts, len(unique) if drop_degenerate else None, labels)
    return MeshData(
        v[unique[:, 0]], faces,
        normals=vn[unique[:, -1]] if use_n else None,
        uvs=vt[unique[:, 1]] if use_uv else None,
        polygons=len(counts),
        degenerate=dropped,
        face_material=labels,
    )


def _obj_slow(data: bytes, drop_degenerate: bool = True) -> MeshData:
    """Line by line: the same result as the fast path, or a MeshProblem naming the first bad line."""
    v, vt, vn = [], [], []
    corners: list[tuple] = []
    counts = []
    pending = b""
    start_line = 0
    materials = _MaterialStatements()
    face_lines = []  # 0-based line of each face, for its usemtl
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
                raise MeshProblem(f"'{key.decode()}' expects numbers: not all of its first {need} values are", at) from None
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
                    raise MeshProblem(f"a face corner must be v, v/vt, v//vn or v/vt/vn, found {quote_text(word)}", at)
                ids = []
                for part, table, what in zip(parts, (v, vt, vn), ("vertex", "texture coordinate", "normal")):
                    if part == "":
                        ids.append(None)
                        continue
                    try:
                        i = int(part)
                    except ValueError:
                        raise MeshProblem(f"a face corner must be whole numbers, found {quote_text(word)}", at) from None
                    j = i - 1 if i > 0 else len(table) + i
                    if i == 0 or not 0 <= j < len(table):
                        raise MeshProblem(f"{what} index {i} is out of range: {len(table)} defined before this line", at)
                    ids.append(j)
                ids += [None] * (3 - len(ids))
                face.append(tuple(ids))
            corners.extend(face)
            counts.append(len(face))
            face_lines.append(at - 1)
        elif key.startswith(b"#") or key in _OBJ_IGNORED:
            if key in (b"mtllib", b"usemtl"):
                materials.read(line.split(None, 1), at - 1)
            continue
        else:
            raise MeshProblem(f"unknown OBJ statement {_statement(key)}", at)
    vertices = np.array(v, np.float64).reshape(-1, 3)
    if not corners:
        mesh = MeshData(vertices, np.zeros((0, 3), np.int64))
        materials.describe(mesh)
        return mesh
    iv = np.array([c[0] for c in corners], np.int64)
    columns = [iv]
    for k in (1, 2):
        have = [c[k] is not None for c in corners]
        columns.append(np.array([c[k] for c in corners], np.int64) if all(have) else None)
    mesh = _obj_assemble(vertices, np.array(vt, np.float64).reshape(-1, 2), np.array(vn, np.float64).reshape(-1, 3),
                         columns, np.array(counts, np.int64), drop_degenerate,
                         materials.face_labels(np.array(face_lines, np.int64)))
    materials.describe(mesh)
    return mesh


def _statement(key: bytes) -> str:
    """An unknown OBJ keyword as a message may show it: quoted only when it is a near miss of a
    known one (`vx`, `usemtl2`); any other word may be a line of a file that is no OBJ at all."""
    word = key.decode("ascii", "replace")
    known = [k.decode() for k in _OBJ_IGNORED] + ["v", "vn", "vt", "f"]
    if did_you_mean(word, known) and key_shown(word):
        return f"'{word}'{did_you_mean(word, known)}"
    return f"(not shown: a word of {len(word)} characters)"


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
            raise MeshProblem(f"PLY header line {lines.index(text) + 1} is not understood")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise MeshProblem(f"PLY format {quote_key(fmt) if fmt else '(none)'} is not ascii, binary_little_endian or binary_big_endian")
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


# Bytes per item once read, beside each record's own: positions and the like become float64
# (8 bytes a value), a face read as a list of unknown length is a numpy array of its own (about
# 100 bytes of object), and each triangle costs what READ_TRIANGLE_BYTES says.
_PLY_LIST_OBJECT_BYTES = 112


def _ply_read_bytes(fmt: str, elements, triangles_known: bool) -> int:
    """The most memory reading these elements takes (plyfile's records, then our arrays)."""
    need = 0
    for name, count, props in elements:
        record = sum(_PLY_SIZES.get(kind[0], 8) if kind[0] != "list" else 0 for _, kind in props)
        lists = sum(1 for _, kind in props if kind[0] == "list")
        each = record + 8 * len(props)  # the record, and a float64 copy of its values
        if lists:
            each += 3 * 8 + (0 if triangles_known else lists * _PLY_LIST_OBJECT_BYTES) + READ_TRIANGLE_BYTES
        need += count * each
    return need


def _ply_failure(exc: BaseException) -> str:
    """Why plyfile could not read a file, in words that quote none of its contents."""
    from plyfile import PlyElementParseError, PlyHeaderParseError

    if isinstance(exc, PlyElementParseError):
        # plyfile's message is one of a few fixed phrases; the element's name is quoted by the key rule
        element = getattr(exc, "element", None)
        where = f"element {quote_key(element.name)}" if element is not None else "the data"
        if getattr(exc, "row", None) is not None:
            where += f", row {exc.row + 1}"
        return f"{where}: {exc.message}"
    if isinstance(exc, PlyHeaderParseError):  # its message may hold a header line: the line number only
        return f"header line {exc.line} is not understood" if getattr(exc, "line", None) else "the header is not understood"
    if isinstance(exc, OverflowError):
        return "a count or value is out of range for its type"
    if isinstance(exc, (EOFError,)):
        return "the file ends before the data its header declares"
    return f"the data does not match its header ({type(exc).__name__})"


def read_ply(path, drop_degenerate: bool = True) -> MeshData:
    """Parse a PLY file through plyfile: vertex x, y, z (nx, ny, nz; u, v or s, t) and face lists.

    The header is read first: its counts must fit the file's size (a sparse file of zeros can
    declare anything) and the memory budget before plyfile allocates a record. Whatever plyfile
    raises on a malformed file becomes a MeshProblem."""
    try:
        from plyfile import PlyData
    except ImportError:  # a dependency, but an environment can still lack it: an error, not a traceback
        raise MeshProblem("reading PLY needs the plyfile package, which is not installed: pip install plyfile "
                          "(or convert the mesh to .obj)") from None

    with open_regular_file(path) as fh:
        fmt, elements = _ply_header(fh)
        size = os.fstat(fh.fileno()).st_size
        if size > MAX_MESH_BYTES:
            raise MeshProblem(f"the file is larger than the {MAX_MESH_BYTES:,} bytes allowed ({size:,} bytes)")
        # A header cannot promise more elements than the file has bytes for: a binary value takes
        # its type's size, an ASCII one at least a digit and a separator.
        least = 0
        for name, count, props in elements:
            each = sum(2 if fmt == "ascii" else _PLY_SIZES.get(kind[0] if kind[0] != "list" else kind[1], 1) for _, kind in props)
            least += count * max(1, each)
        if least > size:
            raise MeshProblem(f"the header promises more elements than the file's {size:,} bytes can hold "
                              f"(they need at least {least:,})")
        names = {name: props for name, _, props in elements}
        if "vertex" not in names or "face" not in names:
            raise MeshProblem("a PLY mesh needs a 'vertex' and a 'face' element")
        face_prop = next((p for p, t in names["face"] if t and t[0] == "list" and p in ("vertex_indices", "vertex_index")), None)
        if face_prop is None:
            raise MeshProblem("the 'face' element has no 'vertex_indices' list")
        fh.seek(0)
        triangles = fmt != "ascii" and _sizes_say_triangles(fh, elements, size, face_prop)
        problem = _budget_problem(_ply_read_bytes(fmt, elements, triangles), "reading the elements its header declares")
        if problem:
            raise MeshProblem(problem)
        fh.seek(0)
        try:
            ply = PlyData.read(fh, known_list_len={"face": {face_prop: 3}}) if triangles else PlyData.read(fh)
            mesh = _ply_mesh(ply, face_prop, drop_degenerate)
        except MeshProblem:
            raise
        except MemoryError:
            raise
        except Exception as exc:  # noqa: BLE001 - plyfile raises what numpy and struct raise on bad data
            raise MeshProblem(f"the PLY file does not parse: {_ply_failure(exc)}") from None
    return mesh


def _ply_mesh(ply, face_prop: str, drop_degenerate: bool) -> MeshData:
    """The MeshData of a PlyData: vertex x, y, z (nx, ny, nz; u, v or s, t) and its faces."""
    faces = ply["face"][face_prop]
    vert = ply["vertex"].data
    fields = vert.dtype.names or ()
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
    vertex_count = len(vertices) if drop_degenerate else None
    if faces.dtype != object:
        corners = faces.astype(np.int64).reshape(-1)
        f, dropped, _ = _fans(corners, np.full(len(corners) // 3, 3), vertex_count)
        return MeshData(vertices, f, normals, uvs, len(corners) // 3, dropped)
    counts = np.array([len(face) for face in faces], np.int64)
    corners = np.concatenate(faces).astype(np.int64) if len(faces) else np.zeros(0, np.int64)
    f, dropped, _ = _fans(corners, counts, vertex_count)
    return MeshData(vertices, f, normals, uvs, len(counts), dropped)


def split_by_material(mesh: MeshData, smooth: bool = False) -> list:
    """[(label, MeshData)]: the mesh cut into one mesh per `usemtl` (label -1: faces before any),
    in the order of the labels, each with only the vertices its triangles use (renumbered in
    their order in the file), so that each part is the mesh the same faces would make alone.
    With `smooth` and no normals in the file, every part gets the area-weighted vertex normals
    of the whole mesh, so that shading stays smooth across the seams between materials."""
    labels = mesh.face_material
    if labels is None or len(labels) == 0 or labels.min() == labels.max():
        # A copy of the record (the arrays shared): the part is annotated, the mesh read stays as read.
        return [(-1 if labels is None or len(labels) == 0 else int(labels[0]), dataclasses.replace(mesh))]
    normals = mesh.normals
    if smooth and normals is None:
        normals = _area_weighted_normals(mesh.vertices, mesh.faces)
    order = np.argsort(labels, kind="stable")
    sorted_labels = labels[order]
    cuts = np.flatnonzero(np.diff(sorted_labels)) + 1
    parts = []
    used_mark = np.zeros(len(mesh.vertices), bool)
    for rows in np.split(order, cuts):
        faces = mesh.faces[rows]
        corners = faces.reshape(-1)
        # The vertices used, in file order; a vertex's new number is its place among them. A part
        # much smaller than the mesh sorts its corners (its own size); a large one marks them and
        # counts (the mesh's size, without a sort): the same numbers either way.
        if 8 * len(corners) < len(mesh.vertices):
            used, renumber = np.unique(corners, return_inverse=True)
        else:
            used_mark[corners] = True
            used = np.flatnonzero(used_mark)
            renumber = (np.cumsum(used_mark, dtype=np.int64) - 1)[corners]
            used_mark[used] = False
        part = MeshData(mesh.vertices[used], renumber.reshape(-1, 3).astype(np.int64),
                        None if normals is None else normals[used], None if mesh.uvs is None else mesh.uvs[used],
                        polygons=len(rows))
        parts.append((int(labels[rows[0]]), part))
    return parts


def _area_weighted_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each vertex's normal: the sum of the faces' normals around it, each as long as twice its area
    (as the renderer makes them for a smooth mesh without normals); 0 where they cancel."""
    p0, p1, p2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    face_n = np.cross(p1 - p0, p2 - p0)
    out = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(out, faces[:, k], face_n)
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.where(length > 0, out / np.where(length > 0, length, 1.0), 0.0)


def describe(mesh: MeshData) -> str:
    """'1,000 vertices, 2,000 triangles (...)' for `rt validate`."""
    extras = [w for w, have in (("normals", mesh.normals is not None), ("texture coordinates", mesh.uvs is not None)) if have]
    text = f"{len(mesh.vertices):,} vertices, {len(mesh.faces):,} triangles"
    if mesh.polygons and mesh.polygons != len(mesh.faces) + mesh.degenerate:
        text += f" from {mesh.polygons:,} faces"
    if extras:
        text += " with " + " and ".join(extras)
    if mesh.material_note:
        text += f"; {mesh.material_note}"
    return text


__all__ = ["FileProblem", "MeshData", "MeshProblem", "from_arrays", "read_mesh", "read_obj", "read_ply", "split_by_material",
           "SUFFIXES"]
