"""Writing a triangle mesh as a binary PLY file that `meshfile.read_ply` reads back exactly."""

from __future__ import annotations

from typing import BinaryIO, Optional

import numpy as np


def ply_bytes_header(vertices: int, triangles: int, normals: bool, uvs: bool) -> bytes:
    """The header of a little-endian binary PLY: float x, y, z (nx, ny, nz; u, v) and int face lists."""
    lines = ["ply", "format binary_little_endian 1.0", "comment written by rt import", f"element vertex {vertices}",
             "property float x", "property float y", "property float z"]
    if normals:
        lines += ["property float nx", "property float ny", "property float nz"]
    if uvs:
        lines += ["property float u", "property float v"]
    lines += [f"element face {triangles}", "property list uchar int vertex_indices", "end_header"]
    return ("\n".join(lines) + "\n").encode("ascii")


def write_ply(fh: BinaryIO, positions: np.ndarray, faces: np.ndarray, normals: Optional[np.ndarray] = None,
              uvs: Optional[np.ndarray] = None) -> None:
    """Write float32 positions (V, 3), optional normals (V, 3) and (u, v) (V, 2), and int32 triangles
    (T, 3) to an open binary file, in one structured array per element (no Python loop)."""
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if normals is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if uvs is not None:
        fields += [("u", "<f4"), ("v", "<f4")]
    vert = np.empty(len(positions), np.dtype(fields))
    vert["x"], vert["y"], vert["z"] = positions[:, 0], positions[:, 1], positions[:, 2]
    if normals is not None:
        vert["nx"], vert["ny"], vert["nz"] = normals[:, 0], normals[:, 1], normals[:, 2]
    if uvs is not None:
        vert["u"], vert["v"] = uvs[:, 0], uvs[:, 1]
    face = np.empty(len(faces), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    face["n"] = 3
    face["i"] = faces
    fh.write(ply_bytes_header(len(positions), len(faces), normals is not None, uvs is not None))
    fh.write(vert.tobytes())
    fh.write(face.tobytes())
