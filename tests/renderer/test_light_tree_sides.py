"""One-sided area lights in the light tree (renderer/light_bounds.py, lights.front_only).

A `diffuse_light` with `sides: front` sends light only along its shape's normal, so its leaf must
bound it by the cone of that normal (theta_o 0, theta_e pi/2, not two-sided), and a shading point
behind it must get importance 0 from it: the tree then never spends a shadow ray on it there.
A two-sided light (the books' default) keeps both sides: the same importance in front and behind.

The importance is called through its Python body (`py_func`): the same code the kernels inline,
without compiling a kernel, so the file stays fast.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.light_table import LIGHT_TREE_LEAF
from renderer.light_tree import LT_AXIS, LT_CHILD, LT_COS_E, LT_COS_O, LT_LIGHT, LT_TWO_SIDED, importance
from renderer.lights import light_tree_tables
from scenefmt.validation import loads

# Two small squares facing down (u x v = (0, -1, 0)), one emitting from its front only, the
# other from both sides, far apart over a floor.
SCENE = """
materials:
  white: {type: lambertian, albedo: [0.5, 0.5, 0.5]}
  front: {type: diffuse_light, emit: [4, 4, 4], sides: front}
  both: {type: diffuse_light, emit: [4, 4, 4]}
camera: {look_from: [0, 8, 8], look_at: [0, 0, 0], vfov: 40}
image: {width: 8, aspect_ratio: 1, max_depth: 2}
shapes:
  - {type: quad, q: [-10, 0, -10], u: [20, 0, 0], v: [0, 0, 20], material: white}
  - {type: quad, q: [-3.1, 2, -0.1], u: [0.2, 0, 0], v: [0, 0, 0.2], material: front}
  - {type: quad, q: [2.9, 2, -0.1], u: [0.2, 0, 0], v: [0, 0, 0.2], material: both}
"""
FRONT_CENTRE = np.array([-3.0, 2.0, 0.0])
BOTH_CENTRE = np.array([3.0, 2.0, 0.0])
DOWN = np.array([0.0, -1.0, 0.0])
NO_NORMAL = (0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def tree():
    flat = compile_scene(loads(SCENE).graph)
    tables = light_tree_tables(flat)
    leaves = tables["light_i"][:, LIGHT_TREE_LEAF]
    ltree_f, ltree_i = tables["ltree_f"], tables["ltree_i"]
    # The leaf of each light, found by where its centre is: the front one at x < 0.
    by_side = {}
    for leaf in leaves[leaves >= 0]:
        centre_x = ltree_f[leaf, 0]
        by_side["front" if centre_x < 0.0 else "both"] = int(leaf)
    assert set(by_side) == {"front", "both"}
    assert all(ltree_i[leaf, LT_CHILD] == -1 and ltree_i[leaf, LT_LIGHT] >= 0 for leaf in by_side.values())
    return ltree_f, ltree_i, by_side


def node_importance(tree, node, p, n=NO_NORMAL) -> float:
    ltree_f, ltree_i, _ = tree
    return importance.py_func(ltree_f, ltree_i, node, tuple(float(c) for c in p), tuple(float(c) for c in n))


def test_a_one_sided_light_gets_the_cone_of_its_normal(tree):
    ltree_f, ltree_i, leaf = tree
    front = leaf["front"]
    np.testing.assert_allclose(ltree_f[front, LT_AXIS:LT_AXIS + 3], DOWN, atol=1e-12)
    assert ltree_f[front, LT_COS_O] == pytest.approx(1.0, abs=1e-12)  # theta_o 0
    assert ltree_f[front, LT_COS_E] == pytest.approx(math.cos(0.5 * math.pi), abs=1e-12)  # theta_e pi/2
    assert ltree_i[front, LT_TWO_SIDED] == 0


def test_a_two_sided_light_keeps_both_sides(tree):
    ltree_f, ltree_i, leaf = tree
    both = leaf["both"]
    # The axis's sign is the build's choice (toward +y here); the cone is the normal's line.
    assert abs(ltree_f[both, LT_AXIS + 1]) == pytest.approx(1.0, abs=1e-12)
    assert ltree_f[both, LT_COS_O] == pytest.approx(1.0, abs=1e-12)
    assert ltree_i[both, LT_TWO_SIDED] == 1


@pytest.mark.parametrize("offset", [(0.0, 1.0, 0.0), (0.3, 0.5, -0.2), (1.5, 0.5, 0.0)])
def test_a_point_behind_a_one_sided_light_gets_importance_zero_and_one_in_front_does_not(tree, offset):
    """Behind: above the downward-facing square (offset's y > 0, far enough above its plane that
    the sphere bounding it lies wholly behind as seen from p), importance exactly 0 with and
    without a normal at p; in front (the mirror point below), > 0."""
    _, _, leaf = tree
    behind = FRONT_CENTRE + np.array(offset)
    in_front = FRONT_CENTRE + np.array(offset) * np.array([1.0, -1.0, 1.0])
    for n in (NO_NORMAL, (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        assert node_importance(tree, leaf["front"], behind, n) == 0.0
        assert node_importance(tree, leaf["front"], in_front, n) > 0.0


@pytest.mark.parametrize("offset", [(0.0, 1.0, 0.0), (0.3, 0.5, -0.2)])
def test_a_two_sided_light_is_as_important_behind_as_in_front(tree, offset):
    _, _, leaf = tree
    above = BOTH_CENTRE + np.array(offset)
    below = BOTH_CENTRE + np.array(offset) * np.array([1.0, -1.0, 1.0])
    a = node_importance(tree, leaf["both"], above)
    b = node_importance(tree, leaf["both"], below)
    assert a > 0.0
    assert a == pytest.approx(b, rel=1e-12)
