"""The instance and tree tables: their declared layouts, and the walk that lists a tree's rows.

A flat scene places its bottom-level trees by instances (`inst_i`, `inst_f`: a tree's root and
the affine map that puts it in the world), finds instances through a binary top-level tree
(`tlas_f`, `tlas_i`) and primitives through four-wide bottom-level trees (`nodes_f`, `nodes_i`:
bvh.WideBvh builds them). Flattening (compile.py), the light category (which walks a tree for its
emitters) and the tracing layer (traverse.py, shadow.py) all read these tables, so they are
declared here, below all of them, rather than in the traversal that is only one of their readers.
"""

import numpy as np

from . import target
from .columns import Column, Layout

# The top level: instances, and the binary tree over them (its leaves index instances directly).
INSTANCE_I = Layout("inst_i", "int32", [
    Column("root", 1, "root node of the instance's bottom-level tree in nodes_f and nodes_i"),
    Column("untransformed", 1, "1 if the instance's transform is the identity (rays need no transforming)"),
    Column("serial", 1, "the instance's number, independent of row order: keys the random numbers of its media"),
    Column("first_key", 1, "a moving instance: row of its first keyframe in motion_f (motion.py); -1 for one that stands still"),
    Column("keys", 1, "a moving instance: how many keyframes (at least 2); 0 for one that stands still (inst_f's maps then hold)"),
])
INSTANCE_F = Layout("inst_f", "float64", [
    Column("world_from_object", 12, "3x4 row-major affine map (a moving instance's: where it is when the shutter opens)"),
    Column("object_from_world", 12, "its inverse"),
])
TLAS_F = Layout("tlas_f", "float64", [Column("lo", 3, "box corner"), Column("hi", 3, "box corner")])
TLAS_I = Layout("tlas_i", "int32", [
    Column("next", 1, "interior: the second child (the first is the next row); leaf: the first instance"),
    Column("count", 1, "leaf: how many instances; 0 for an interior node"),
    Column("axis", 1, "interior: the split axis, whose sign of the ray's direction picks the near child"),
])
# Bottom-level trees are four wide (bvh.WideBvh): a node's four child boxes are nodes_f's row,
# laid out by coordinate for one vector test (simd.slab4); nodes_i says where each child leads.
NODE_I = Layout("nodes_i", "int64", [
    Column("child", 4, "per child: its node, or its first primitive row if its count is above 0"),
    Column("count", 4, "per child: primitives in the leaf, 0 for an interior node, -1 for an empty slot"),
])
NODE_CHILD, NODE_COUNT = NODE_I.offsets("child", "count")
INST_ROOT, INST_UNTRANSFORMED, INST_SERIAL = INSTANCE_I.offsets("root", "untransformed", "serial")
INST_FIRST_KEY, INST_KEYS = INSTANCE_I.offsets("first_key", "keys")
INST_WORLD_FROM_OBJECT, INST_OBJECT_FROM_WORLD = INSTANCE_F.offsets("world_from_object", "object_from_world")
TLAS_LO, TLAS_HI = TLAS_F.offsets("lo", "hi")
TLAS_NEXT, TLAS_COUNT, TLAS_AXIS = TLAS_I.offsets("next", "count", "axis")


@target.kernel
def tree_prims(nodes_i, root):
    """The rows of every primitive in the leaves of the wide tree at `root`, in row order (a tree
    with surfaces and mesh triangles has two runs of rows, not one)."""
    rows = []
    stack = [root]
    while len(stack) > 0:
        node = stack.pop()
        for c in range(4):
            code, count = nodes_i[node, NODE_CHILD + c], nodes_i[node, NODE_COUNT + c]
            if count > 0:
                for prim in range(code, code + count):
                    rows.append(prim)
            elif count == 0:
                stack.append(code)
    out = np.array(rows, np.int64)
    out.sort()
    return out
