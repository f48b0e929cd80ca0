"""A scene flattened into tables, all but its trees: what `compile` makes and `assemble` finishes.

Plain lists, tuples and numpy arrays, so the tables can be made in another process and pickled
across (rt/split.py), and their module needs neither pydantic nor Numba.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .layout import PRIM_WIDTH


@dataclass
class TreeTables:
    """The primitives of one bottom-level tree, in the order they were added: kind, row (see
    layout.py), material row, and bounds (lo, hi) over the shutter interval."""

    kind: list = field(default_factory=list)
    rows: list = field(default_factory=list)
    mat: list = field(default_factory=list)
    lo: list = field(default_factory=list)
    hi: list = field(default_factory=list)

    def packed(self) -> "TreeTables":
        """The same tables as numpy arrays: they pickle as raw bytes (a scene of a million
        spheres crosses the pipe in a fraction of a second) and are reordered by one indexing."""
        return TreeTables(
            np.array(self.kind, np.int32),
            np.array(self.rows, np.float64).reshape(-1, PRIM_WIDTH),
            np.array(self.mat, np.int32),
            np.array(self.lo, np.float64).reshape(-1, 3),
            np.array(self.hi, np.float64).reshape(-1, 3),
        )


@dataclass
class SceneTables:
    blas: list[TreeTables]  # packed
    # (tree, world_from_object as 3x4 rows, whether that is the identity), one per placement.
    instances: list[tuple[int, tuple, bool]]
    tex_rows: list[tuple]  # (kind, colour, four parameters, child textures)
    mat_rows: list[tuple]  # (kind, texture row, (fuzz, ior), whether the texture reads (u, v))
    texel_chunks: list[np.ndarray]  # each image's texels, (w * h, 3)
    noise: list[tuple[np.ndarray, np.ndarray]]  # per noise texture: permutations, gradients
    bnd_kind: list[int]  # media boundaries
    bnd_rows: list
    camera: np.ndarray
    background: np.ndarray
