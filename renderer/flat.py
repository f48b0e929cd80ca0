"""The flat scene: every table the kernels read, as one NamedTuple of numpy arrays.

Tables are few and wide on purpose: Numba passes each array to a function as a struct of
several words, so the hot functions take a handful of arrays rather than the whole tuple.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import numpy as np

    from scenefmt.graph import SceneGraph


class FlatScene(NamedTuple):
    # Primitives of every bottom-level tree, each tree's rows contiguous and in leaf order.
    prims_i: np.ndarray  # (P, 2) int32: kind, material (a medium's phase function for MEDIUM)
    prims_f: np.ndarray  # (P, 16) float64, see layout.py
    # Boundary rows of media (not in any tree), same row layout as primitives.
    bnd_i: np.ndarray  # (B,) int32 kind
    bnd_f: np.ndarray  # (B, 16) float64
    # Nodes of every bottom-level tree, four-wide (bvh.WideBvh); child and leaf offsets are absolute.
    nodes_f: np.ndarray  # (N, 24) float64: the four child boxes, by coordinate (lo x of 0..3, lo y, ... hi z)
    nodes_i: np.ndarray  # (N, 8) int64: per child, node or first primitive; then per child, primitive count
    #                      (0: an interior node, -1: an empty slot, whose box is nan)
    # Instances (the top level) and the tree over them (its leaves index instances directly).
    inst_i: np.ndarray  # (I, 3) int32: root node of the instance's tree, 1 if untransformed, serial number
    inst_f: np.ndarray  # (I, 24) float64: world_from_object then object_from_world, 3x4 row-major
    # Binary: node k's first child is k + 1, its second child the value in column 0.
    tlas_f: np.ndarray  # (K, 6) float64: box lo, hi
    tlas_i: np.ndarray  # (K, 3) int32: second child or first instance, instance count (0: interior), split axis
    # Materials and textures.
    mat_i: np.ndarray  # (M, 3) int32: kind, texture of albedo or emission, 1 if that texture reads (u, v)
    mat_f: np.ndarray  # (M, 2) float64: metal fuzz, dielectric ior
    tex_i: np.ndarray  # (T, 3) int32: kind, child textures (checker even, odd)
    tex_f: np.ndarray  # (T, 7) float64: colour, four parameters
    texels: np.ndarray  # (K, 3) float32 linear RGB of every image, row 0 at the top
    noise_perm: np.ndarray  # (Q, 3, 256) int32
    noise_vec: np.ndarray  # (Q, 256, 3) float64
    # Camera, background and shutter.
    camera: np.ndarray  # (21,) float64: origin, pixel00, du, dv, disk_u, disk_v, lens radius, open, close
    background: np.ndarray  # (7,) float64: kind, colour or bottom, top


class Frame(NamedTuple):
    """The image settings a render reads from a scene."""

    width: int
    height: int
    samples: int
    max_depth: int
    seed: int

    @classmethod
    def of(cls, graph: "SceneGraph") -> "Frame":
        image = graph.image
        return cls(image.width, image.pixel_height, image.samples_per_pixel, image.max_depth, image.seed)
