"""Meshes made with numpy, for scenes built in Python, tests and benchmarks (nothing is downloaded).

Each generator returns (vertices (V, 3) float64, faces (T, 3) int64), faces wound so that
(p1 - p0) x (p2 - p0) points outward. `write_obj` and `write_ply` save a mesh as a file a
scene's `type: mesh` can name.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

_PHI = (1.0 + math.sqrt(5.0)) / 2.0
_ICOSAHEDRON_V = np.array([
    (-1, _PHI, 0), (1, _PHI, 0), (-1, -_PHI, 0), (1, -_PHI, 0),
    (0, -1, _PHI), (0, 1, _PHI), (0, -1, -_PHI), (0, 1, -_PHI),
    (_PHI, 0, -1), (_PHI, 0, 1), (-_PHI, 0, -1), (-_PHI, 0, 1),
], np.float64)
_ICOSAHEDRON_F = np.array([
    (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
    (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
    (8, 6, 7), (9, 8, 1),
], np.int64)


def icosphere(splits: int, radius: float = 1.0, center=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """An icosahedron whose faces are each cut into splits^2 triangles, pushed onto a sphere:
    20 splits^2 triangles (splits = 224 gives 1,003,520). Vertices on shared edges are shared,
    so the mesh is closed."""
    n = int(splits)
    if n < 1:
        raise ValueError("splits must be >= 1")
    # Lattice points (i, j) with i + j <= n of one face, and the two kinds of small triangles.
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    i, j = i[keep], j[keep]
    index = -np.ones((n + 1, n + 1), np.int64)
    index[i, j] = np.arange(len(i))
    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = a + b <= n - 1
    au, bu = a[up], b[up]
    tris = [np.stack([index[au, bu], index[au + 1, bu], index[au, bu + 1]], 1)]
    down = a + b <= n - 2
    ad, bd = a[down], b[down]
    tris.append(np.stack([index[ad + 1, bd], index[ad + 1, bd + 1], index[ad, bd + 1]], 1))
    local = np.concatenate(tris)
    # Every face's lattice, as exact integer barycentric weights (k, i, j) of its corners.
    corners = _ICOSAHEDRON_F
    k = n - i - j
    weights = np.stack([k, i, j], 1)  # (L, 3)
    # A point's key: the sorted (corner, weight) pairs with weight > 0, so shared points agree.
    ids = corners[:, None, :].repeat(len(i), 1)  # (20, L, 3)
    w = np.broadcast_to(weights, ids.shape)
    masked = np.where(w > 0, ids, 99)
    order = np.argsort(masked, axis=2, kind="stable")
    key_ids = np.take_along_axis(masked, order, 2)
    key_w = np.take_along_axis(np.where(w > 0, w, 0), order, 2)
    keys = np.concatenate([key_ids, key_w], 2).reshape(-1, 6)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    ids_u, w_u = unique[:, :3], unique[:, 3:]
    lookup = np.zeros((100, 3))  # row 99 stands for "no corner" (weight 0)
    lookup[:12] = _ICOSAHEDRON_V
    points = (lookup[ids_u] * w_u[:, :, None]).sum(1) / n
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    vertices = points * radius + np.asarray(center, np.float64)
    faces = inverse.reshape(20, len(i))[:, local].reshape(-1, 3)
    return vertices, faces.astype(np.int64)


def torus_knot(p: int = 2, q: int = 3, segments: int = 256, sides: int = 16, radius: float = 1.0,
               tube: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """A (p, q) torus knot swept by a circle of radius `tube`: 2 segments sides triangles, closed."""
    t = np.arange(segments) * 2.0 * math.pi / segments

    def curve(t):
        r = radius * (2.0 + np.cos(q * t)) / 3.0
        return np.stack([r * np.cos(p * t), r * np.sin(p * t), -radius * np.sin(q * t) / 3.0], 1)

    c = curve(t)
    tangent = curve(t + 1e-4) - curve(t - 1e-4)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = curve(t + 1e-4) + curve(t - 1e-4) - 2 * c
    normal -= (normal * tangent).sum(1, keepdims=True) * tangent
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangent, normal)
    s = np.arange(sides) * 2.0 * math.pi / sides
    ring = np.cos(s)[None, :, None] * normal[:, None, :] + np.sin(s)[None, :, None] * binormal[:, None, :]
    vertices = (c[:, None, :] + tube * ring).reshape(-1, 3)
    a = np.arange(segments)[:, None]
    b = np.arange(sides)[None, :]
    v00 = a * sides + b
    v10 = ((a + 1) % segments) * sides + b
    v01 = a * sides + (b + 1) % sides
    v11 = ((a + 1) % segments) * sides + (b + 1) % sides
    # Wound so that u x v points out of the tube (as every closed mesh here): a glass knot is then
    # entered from outside.
    faces = np.concatenate([np.stack([v00, v11, v10], -1).reshape(-1, 3), np.stack([v00, v01, v11], -1).reshape(-1, 3)])
    return vertices, faces.astype(np.int64)


def terrain(cells: int, size: float = 10.0, height: float = 1.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A height field over a square of side `size` (y up), cells^2 squares of two triangles, from
    a sum of random sine waves: smooth, deterministic, open."""
    rng = np.random.default_rng(seed)
    x = np.linspace(-size / 2, size / 2, cells + 1)
    gx, gz = np.meshgrid(x, x, indexing="ij")
    y = np.zeros_like(gx)
    for octave in range(6):
        f = (2.0 ** octave) * 2.0 * math.pi / size
        ang = rng.uniform(0, 2 * math.pi)
        y += height * 0.5 ** octave * np.sin(f * (gx * math.cos(ang) + gz * math.sin(ang)) + rng.uniform(0, 6.3))
    vertices = np.stack([gx, y, gz], -1).reshape(-1, 3)
    a = np.arange(cells)[:, None] * (cells + 1)
    b = np.arange(cells)[None, :]
    v00, v10, v01, v11 = a + b, a + cells + 1 + b, a + b + 1, a + cells + 2 + b
    # Wound so the normals point up (+y).
    faces = np.concatenate([np.stack([v00, v01, v11], -1).reshape(-1, 3), np.stack([v00, v11, v10], -1).reshape(-1, 3)])
    return vertices, faces.astype(np.int64)


def write_obj(path, vertices, faces, normals=None, uvs=None) -> Path:
    """Save a mesh as Wavefront OBJ (1-based indices; v/vt/vn when uvs or normals are given)."""
    path = Path(path)
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64) + 1
    parts = ["# written by rt (scenefmt.meshgen)\n", _rows("v", vertices)]
    if uvs is not None:
        parts.append(_rows("vt", np.asarray(uvs, np.float64)))
    if normals is not None:
        parts.append(_rows("vn", np.asarray(normals, np.float64)))
    if uvs is not None and normals is not None:
        corner = np.repeat(faces, 3, axis=1).reshape(-1, 3, 3)
        text = "\n".join("f " + " ".join("/".join(map(str, c)) for c in f) for f in corner.tolist())
    elif uvs is not None:
        text = "\n".join("f " + " ".join(f"{c}/{c}" for c in f) for f in faces.tolist())
    elif normals is not None:
        text = "\n".join("f " + " ".join(f"{c}//{c}" for c in f) for f in faces.tolist())
    else:
        text = _rows("f", faces).rstrip("\n")
    parts.append(text + "\n")
    path.write_text("".join(parts))
    return path


def _rows(tag: str, values: np.ndarray) -> str:
    if values.dtype.kind == "f":
        body = "\n".join(f"{tag} " + " ".join(repr(float(x)) for x in row) for row in values.tolist())
    else:
        body = "\n".join(f"{tag} " + " ".join(str(int(x)) for x in row) for row in values.tolist())
    return body + "\n"


def write_ply(path, vertices, faces, normals=None, uvs=None, binary: bool = True) -> Path:
    """Save a mesh as PLY (binary little-endian unless `binary` is False), float64 coordinates."""
    from plyfile import PlyData, PlyElement

    vertices = np.asarray(vertices, np.float64)
    fields = [("x", "f8"), ("y", "f8"), ("z", "f8")]
    if normals is not None:
        fields += [("nx", "f8"), ("ny", "f8"), ("nz", "f8")]
    if uvs is not None:
        fields += [("u", "f8"), ("v", "f8")]
    vert = np.empty(len(vertices), fields)
    vert["x"], vert["y"], vert["z"] = vertices.T
    if normals is not None:
        vert["nx"], vert["ny"], vert["nz"] = np.asarray(normals, np.float64).T
    if uvs is not None:
        vert["u"], vert["v"] = np.asarray(uvs, np.float64).T
    faces = np.asarray(faces, np.int32)
    face = np.empty(len(faces), [("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = faces
    ply = PlyData([PlyElement.describe(vert, "vertex"), PlyElement.describe(face, "face", len_types={"vertex_indices": "u1"})],
                  text=not binary)
    ply.write(str(path))
    return Path(path)
