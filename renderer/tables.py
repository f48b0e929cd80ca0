"""A scene flattened into tables, all but its trees: what `compile` makes and `assemble` finishes.

Plain Python values: lists, tuples and `array.array`s of doubles and 32-bit integers, so the
tables are made, and pickled across to the rendering process (rt/split.py), without numpy,
pydantic or Numba. The rendering process has numpy already; reading the front end's share of
it is 0.07 s of an `rt render` for a scene without images. An `array.array` pickles as raw bytes,
so a scene of a million spheres still crosses the pipe in a fraction of a second. Only what
needs numpy to be made at all stays numpy (image texels, decoded by Pillow).
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from .layout import PRIM_WIDTH

if TYPE_CHECKING:
    import numpy as np


def doubles() -> array:
    return array("d")


# A C int is 32 bits wherever numpy runs; a C long on the rest.
_INT32 = "i" if array("i").itemsize == 4 else "l"


def int32s() -> array:
    return array(_INT32)


@dataclass
class TreeTables:
    """The primitives of one bottom-level tree, in the order they were added: kind, row (see
    layout.py, PRIM_WIDTH values each, end to end), material row, and bounds (lo, hi) over the
    shutter interval (3 values each)."""

    kind: array = field(default_factory=int32s)
    rows: array = field(default_factory=doubles)
    mat: array = field(default_factory=int32s)
    lo: array = field(default_factory=doubles)
    hi: array = field(default_factory=doubles)

    def add(self, kind: int, row, mat: int, lo, hi) -> None:
        assert len(row) == PRIM_WIDTH and len(lo) == 3 and len(hi) == 3
        self.kind.append(kind)
        self.rows.extend(row)
        self.mat.append(mat)
        self.lo.extend(lo)
        self.hi.extend(hi)

    def __len__(self) -> int:
        return len(self.kind)

    def as_numpy(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(kind, rows, mat, lo, hi) as numpy arrays of shapes (n,), (n, PRIM_WIDTH), (n,), (n, 3), (n, 3)."""
        import numpy as np

        return (
            np.array(self.kind, np.int32),
            np.array(self.rows, np.float64).reshape(-1, PRIM_WIDTH),
            np.array(self.mat, np.int32),
            np.array(self.lo, np.float64).reshape(-1, 3),
            np.array(self.hi, np.float64).reshape(-1, 3),
        )


@dataclass
class SceneTables:
    blas: list[TreeTables]
    # (tree, world_from_object as 3x4 rows, whether that is the identity), one per placement.
    instances: list[tuple[int, tuple, bool]]
    tex_rows: list[tuple]  # (kind, colour, four parameters, child textures)
    mat_rows: list[tuple]  # (kind, texture row, (fuzz, ior), whether the texture reads (u, v))
    texel_chunks: list[Any]  # each image's texels, numpy (w * h, 3) float32
    noise_seeds: list[int]  # per noise texture: the seed of its lattice tables (textures.perlin_tables)
    bnd_kind: list[int]  # media boundaries
    bnd_rows: list  # PRIM_WIDTH values each
    camera: tuple  # 21 values, see compile.camera_values
    background: tuple  # 7 values, see compile.background_values
