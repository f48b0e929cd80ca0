"""The flat scene: every table the kernels read, as one NamedTuple of numpy arrays.

Each table's columns are declared once, beside the code that writes and reads them (see
`columns.py`; `python -m renderer.declared_tables` prints them all). Tables are few and wide on
purpose: Numba passes each array to a function as a struct of several words, so the hot
functions take a handful of arrays rather than the whole tuple.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import numpy as np

    from scenefmt.graph import SceneGraph


class FlatScene(NamedTuple):
    # Primitives of every bottom-level tree, each tree's rows contiguous and in leaf order.
    prims_i: np.ndarray  # shapes.PRIMITIVE_I
    prims_f: np.ndarray  # by kind: shapes/spheres.py, planar.py, boxes.py, media.py
    # Boundary rows of media (not in any tree), laid out as primitives are.
    bnd_i: np.ndarray  # (B,) int32 kind
    bnd_f: np.ndarray  # as prims_f
    # Mesh triangles (prims_i rows P.. with P = len(prims_f)) and the tables they index: shapes/meshes.py.
    tri_i: np.ndarray  # TRIANGLE_I, one row per mesh triangle
    mesh_i: np.ndarray  # MESH_I, one row per mesh placed in a tree
    verts_f: np.ndarray  # (V, 3) float64 vertex positions, in their tree's space
    verts_n: np.ndarray  # (Vn, 3) float64 unit vertex normals of smooth meshes
    verts_uv: np.ndarray  # (Vt, 2) float64 texture coordinates of meshes that have them
    # Nodes of every bottom-level tree, four-wide (bvh.WideBvh); child and leaf offsets are absolute.
    nodes_f: np.ndarray  # (N, 24) the four child boxes, by coordinate (bvh.WideBvh)
    nodes_i: np.ndarray  # trees.NODE_I
    # Instances (the top level) and the binary tree over them; tracing/traverse.py.
    inst_i: np.ndarray  # INSTANCE_I
    inst_f: np.ndarray  # INSTANCE_F
    tlas_f: np.ndarray  # TLAS_F
    tlas_i: np.ndarray  # TLAS_I
    # Keyframes of the placements that move over the shutter (motion.py): moving instances name
    # theirs in inst_i, a moving camera in its row; (0, MOTION_F.width) when nothing moves.
    motion_f: np.ndarray  # motion.MOTION_F
    # Materials and textures: materials.py, textures.py.
    mat_i: np.ndarray  # MATERIAL_I
    mat_f: np.ndarray  # MATERIAL_F
    tex_i: np.ndarray  # TEXTURE_I
    tex_f: np.ndarray  # by kind: SOLID_F, CHECKER_F, IMAGE_F, NOISE_F
    texels: np.ndarray  # (K, 3) float32 linear RGB of every image, row 0 at the top
    noise_perm: np.ndarray  # (Q, 3, 256) int32: Perlin permutations
    noise_vec: np.ndarray  # (Q, 256, 3) float64: Perlin gradients
    # Camera and background: camera.CAMERA, background.py.
    camera: np.ndarray
    background: np.ndarray
    # Lights (lights.py): every light by kind (the environment map first, when it sends light;
    # then the emitting shapes by (instance, primitive)), what chooses one, and the light row of
    # a hit on a shape: inst_light[instance] + prim_light[primitive].
    light_i: np.ndarray  # LIGHT_I
    light_f: np.ndarray  # LIGHT_F
    inst_light: np.ndarray  # (I,) int32
    prim_light: np.ndarray  # (P,) int32, -1 where the primitive does not emit
    # The light tree (light_tree.py): nodes over the lights' bounds, orientations and power, which
    # choose a light as seen from the shading point; empty (no rows) where the scene has too few
    # lights for a tree to pay, and the choice is by power alone.
    ltree_f: np.ndarray  # light_tree.LTREE_F
    ltree_i: np.ndarray  # light_tree.LTREE_I
    # Environment map (environment.py): its radiance by texel, row 0 at the top, and the tables
    # that sample it by brightness; empty unless the background is an image.
    env_rgb: np.ndarray  # (H * W, 3) float32 linear RGB, strength applied
    env_row_f: np.ndarray  # ENV_ROW_F, one row per image row
    env_texel_f: np.ndarray  # ENV_TEXEL_F, one row per texel
    # Path guiding (guiding.py): a spatial tree over the scene whose leaves hold distributions of
    # incident light over directions, learned by a training render (guide_training.py); empty
    # unless the integrator is `guided`, and empty while that training runs its first pass.
    guide_f: np.ndarray  # guiding.GUIDE_F
    guide_i: np.ndarray  # guiding.GUIDE_I
    # Light tracing of caustics (caustic_targets.py, light_emission.py): the specular spheres
    # photons aim at, which primitives are such targets, and the lights photons leave; empty
    # unless the integrator is `caustics`.
    caustic_f: np.ndarray  # caustic_targets.CAUSTIC_F
    caustic_prim: np.ndarray  # (P,) int32
    caustic_mat: np.ndarray  # (M,) int32: 1 for a material a photon passes through (the books' glass and metal)
    caustic_lf: np.ndarray  # light_emission.CAUSTIC_LIGHT_F


# The estimators (`image.integrator` in a scene file, `--integrator` on the command line), as the
# kernels' render passes take them (tracing/integrator.trace).
INTEGRATOR_PATH = 0
INTEGRATOR_MIS = 1
# `mis` with the bounce at each vertex with a density drawn from a learned guide or the BSDF (guiding.py).
INTEGRATOR_GUIDED = 2
# `mis` with the caustic paths a camera sees on matte surfaces traced from the lights (tracing/caustics.py).
INTEGRATOR_CAUSTICS = 3
INTEGRATORS = {"path": INTEGRATOR_PATH, "mis": INTEGRATOR_MIS, "guided": INTEGRATOR_GUIDED,
               "caustics": INTEGRATOR_CAUSTICS}


def integrator_choices(quote: bool = False) -> str:
    """The integrators' names for an error message: "guided, mis or path"."""
    names = [repr(n) if quote else n for n in sorted(INTEGRATORS)]
    return ", ".join(names[:-1]) + " or " + names[-1]


class Frame(NamedTuple):
    """The image settings a render reads from a scene."""

    width: int
    height: int
    samples: int
    max_depth: int
    seed: int
    integrator: str = "mis"  # a name of INTEGRATORS
    sampler: str = "independent"  # a name of sampling.SAMPLERS

    @property
    def estimator(self) -> int:
        """The integrator's code, as the render passes take it."""
        return INTEGRATORS[self.integrator]

    @classmethod
    def of(cls, graph: "SceneGraph") -> "Frame":
        image = graph.image
        return cls(image.width, image.pixel_height, image.samples_per_pixel, image.max_depth, image.seed, image.integrator,
                   image.sampler)
