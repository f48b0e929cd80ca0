"""Every table layout the renderer declares, gathered from the categories that declare them.

Each category declares its own layouts with `renderer.columns` (the vocabulary, which imports no
category); this module is the one place that knows them all, in the order `docs/architecture.md`
lists them. It is read only by the docs printer and its test, so the categories it imports cost
nothing on the render path:

    python -m renderer.declared_tables   # the table between the markers in docs/architecture.md
"""

from __future__ import annotations

from . import (background, camera, caustic_targets, environment, grid_media, guide_records, guiding, light_emission, light_tree,
               lights, materials, media, motion, textures, trees)
from .columns import Layout, describe_all
from .shapes import PRIMITIVE_I, boxes, meshes, planar, spheres


def declared_layouts() -> list[Layout]:
    """Every table layout the renderer declares, in the order docs/architecture.md lists them."""
    return [
        PRIMITIVE_I, spheres.SPHERE_F, spheres.MOVING_SPHERE_F, planar.PLANAR_F, boxes.BOX_F, media.MEDIUM_F, grid_media.FIELD_F,
        meshes.TRIANGLE_I, meshes.MESH_I,
        materials.MATERIAL_I, materials.MATERIAL_F,
        textures.TEXTURE_I, textures.SOLID_F, textures.CHECKER_F, textures.IMAGE_F, textures.NOISE_F,
        trees.NODE_I, trees.INSTANCE_I, trees.INSTANCE_F, trees.TLAS_F, trees.TLAS_I, motion.MOTION_F,
        camera.CAMERA, background.SOLID_BACKGROUND, background.SKY_BACKGROUND, background.IMAGE_BACKGROUND,
        environment.ENV_ROW_F, environment.ENV_TEXEL_F,
        lights.LIGHT_I, lights.LIGHT_F, light_tree.LTREE_F, light_tree.LTREE_I,
        guiding.GUIDE_F_HEAD, guiding.GUIDE_F_NODE, guiding.GUIDE_F_QUAD,
        guiding.GUIDE_I_HEAD, guiding.GUIDE_I_NODE, guiding.GUIDE_I_QUAD, guide_records.GUIDE_RECORD,
        caustic_targets.CAUSTIC_F, light_emission.CAUSTIC_LIGHT_F,
    ]


if __name__ == "__main__":
    print(describe_all(declared_layouts()))
