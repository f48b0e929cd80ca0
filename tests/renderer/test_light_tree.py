"""The light tree (renderer/light_tree.py, light_bounds.py; its seam in lights.py) and the count
that decides it (scenefmt/many_lights.py).

- The build: every light in one leaf, every node's sphere and cone holding its lights', powers
  summed; a scene with few lights gets no tree (its images stay those of the power cdf).
- The selection: the tree's pmf over all lights sums to 1 at random shading points (with and
  without a normal, with a map beside the tree, inside lights' bounds); `select_light`'s choices
  follow it (chi-square); `light_pmf` gives what `select_light` gave; nothing is NaN.
- Images: a scene of 300 lights rendered with the tree and with the power cdf agree (block
  z-test); the tree's image is the same on 1 and 2 threads.
- The count and the flag: instanced emitters counted through their placements, the reason names
  the group; the memory estimate counts light rows and tree nodes and holds what 10,000+
  instanced emitters take.
"""

from __future__ import annotations

import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from renderer.light_tree import (LT_AXIS, LT_CENTER, LT_CHILD, LT_COS_O, LT_LIGHT, LT_PARENT, LT_POWER, LT_RADIUS, LT_SHARE,
                                 LT_TWO_SIDED, LightBounds, build_light_tree, full_sphere, join_cones)
from scenefmt.many_lights import LIGHT_TREE_THRESHOLD, count_lights, wants_light_tree
from scenefmt.validation import loads
from tests.renderer.stats import ALPHA, block_z, chi2_test, z_limit

ROOT = Path(__file__).resolve().parents[2]
SKY = ROOT / "scenes" / "sky.pfm"

# A group of 10 emitters of every family (two quads, a disk, a triangle, a box, a mesh of 2
# triangles, 3 spheres), placed 30 times: turned, one under a non-uniform scale: 330 light rows.
GROUP = """
groups:
  lamps:
    shapes:
      - {type: sphere, center: [0, 0.6, 0], radius: 0.05, material: warm}
      - {type: sphere, center: [0.4, 0.9, 0.1], radius: 0.03, material: blue}
      - {type: sphere, center: [-0.3, 0.4, 0.2], radius: 0.04, material: warm}
      - {type: quad, q: [-0.2, 1.2, -0.2], u: [0.2, 0, 0], v: [0, 0, 0.15], material: warm}
      - {type: quad, q: [0.3, 0.3, -0.3], u: [0.1, 0.05, 0], v: [0, 0.1, 0.1], material: blue}
      - {type: disk, center: [-0.4, 0.8, -0.3], normal: [0.3, -1, 0.2], radius: 0.06, material: warm}
      - {type: triangle, vertices: [[0.1, 0.2, 0.4], [0.25, 0.2, 0.4], [0.1, 0.35, 0.45]], material: blue}
      - {type: box, min: [0.5, 0.1, 0.5], max: [0.6, 0.2, 0.6], material: warm}
      - {type: mesh, vertices: [[-0.5, 0.5, 0.5], [-0.4, 0.5, 0.5], [-0.45, 0.6, 0.45], [-0.45, 0.5, 0.6]],
         faces: [[0, 1, 2], [0, 3, 1]], material: blue}
"""
HEAD = """
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
  warm: {type: diffuse_light, emit: [6, 4, 2]}
  blue: {type: diffuse_light, emit: [1, 2, 9]}
camera: {look_from: [0, 6, 7], look_at: [0, 0, 0], vfov: 50}
image: {width: 16, aspect_ratio: 1, max_depth: 3}
"""


def many_lights_text(background: str = "", placements: int = 30) -> str:
    rows = []
    for k in range(placements):
        x, z = -4.5 + 3.0 * (k % 4) + 0.1 * k, -4.0 + 2.2 * (k // 4) - 0.05 * k
        steps = f"[{{rotate: {{axis: y, degrees: {17 * k}}}}}, {{translate: [{x:.2f}, 0, {z:.2f}]}}]"
        if k == 5:
            steps = f"[{{scale: [1.5, 0.7, 1]}}, {{translate: [{x:.2f}, 0, {z:.2f}]}}]"
        rows.append(f"  - {{type: instance, group: lamps, transform: {steps}}}")
    return (HEAD + background + GROUP + "shapes:\n  - {type: quad, q: [-8, 0, -8], u: [16, 0, 0], v: [0, 0, 16], material: white}\n"
            + "\n".join(rows) + "\n")


def graph_of(text: str):
    return loads(text, allow_paths=[SKY.parent]).graph


def flat_of(text: str):
    from renderer.compile import compile_scene

    return compile_scene(graph_of(text))


MAP = f"background: {{type: image, file: '{SKY}', strength: 0.3}}\n"


# --- the build (numpy) ------------------------------------------------------------------------


def random_bounds(m: int, seed: int) -> LightBounds:
    rng = np.random.default_rng(seed)
    c = rng.uniform(-10, 10, (m, 3))
    r = rng.uniform(0.01, 0.3, (m, 1))
    axis = rng.normal(size=(m, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    theta_o = np.where(rng.random(m) < 0.3, math.pi, rng.uniform(0, 0.6, m))
    return LightBounds(c - r, c + r, axis, theta_o, np.full(m, 0.5 * math.pi), rng.random(m) < 0.5, rng.uniform(0.1, 2, m))


@pytest.mark.parametrize("m", [1, 2, 3, 17, 400])
def test_every_light_is_in_one_leaf_whose_ancestors_hold_it(m):
    b = random_bounds(m, m)
    ltree_f, ltree_i, leaf_of = build_light_tree(b)
    assert len(ltree_f) == 2 * m - 1
    lights = ltree_i[:, LT_LIGHT]
    assert sorted(lights[lights >= 0]) == list(range(m)) and np.array_equal(lights[leaf_of], np.arange(m))
    inner = ltree_i[:, LT_CHILD] >= 0
    children = ltree_i[inner, LT_CHILD]
    assert np.array_equal(ltree_i[children, LT_PARENT], np.flatnonzero(inner))
    assert np.array_equal(ltree_i[children + 1, LT_PARENT], np.flatnonzero(inner))
    assert np.allclose(ltree_f[inner, LT_POWER], ltree_f[children, LT_POWER] + ltree_f[children + 1, LT_POWER])
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    for k in range(m):
        box = b.lo[k] + corners * (b.hi[k] - b.lo[k])
        node = leaf_of[k]
        while node >= 0:
            centre, radius = ltree_f[node, LT_CENTER:LT_CENTER + 3], ltree_f[node, LT_RADIUS]
            assert np.linalg.norm(box - centre, axis=1).max() <= radius * (1 + 1e-12) + 1e-12
            theta = math.acos(np.clip(ltree_f[node, LT_COS_O], -1, 1))
            if theta < math.pi - 1e-9:
                off = math.acos(np.clip(b.axis[k] @ ltree_f[node, LT_AXIS:LT_AXIS + 3], -1, 1))
                assert off + b.theta_o[k] <= theta + 1e-6, "a light's normal outside its node's cone"
            assert ltree_i[node, LT_TWO_SIDED] >= b.two_sided[k]
            node = ltree_i[node, LT_PARENT]


def test_joined_cones_hold_both_and_opposite_ones_make_the_sphere():
    a = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    b = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    axis, theta = join_cones(a, np.array([0.1, 0.0, 0.3]), b, np.array([0.2, 0.0, 0.1]))
    assert theta[0] == pytest.approx((0.1 + math.pi / 2 + 0.2) / 2, abs=1e-6)
    for k in (0,):
        for v, t in ((a[k], 0.1), (b[k], 0.2)):
            assert math.acos(np.clip(axis[k] @ v, -1, 1)) + t <= theta[k] + 1e-9
    assert theta[1] == math.pi
    assert theta[2] == pytest.approx(0.3, abs=1e-6) and np.allclose(axis[2], a[2])


def test_a_full_sphere_is_every_direction():
    axis, theta_o, theta_e = full_sphere(3)
    assert np.allclose(np.linalg.norm(axis, axis=1), 1) and np.all(theta_o == math.pi) and np.all(theta_e == math.pi / 2)


# --- the count and the flag (pure Python) -----------------------------------------------------


def test_instanced_emitters_are_counted_through_their_placements_and_the_reason_names_the_group():
    graph = graph_of(many_lights_text())
    count = count_lights(graph)
    assert count.total == 30 * 10  # 9 shapes, the mesh's 2 triangles
    assert "300 lights" in count.reason and "group lamps (10 lights) placed 30 times" in count.reason
    assert wants_light_tree(graph)
    from scenefmt.effects import summarize

    effect = summarize(graph).effect("light_tree")
    assert effect.on and "group lamps" in effect.reason


def test_few_lights_keep_the_power_cdf_and_the_flag_off():
    from scenefmt.effects import summarize

    graph = loads((ROOT / "scenes" / "simple_light.yaml").read_text()).graph
    assert count_lights(graph).total == 2 < LIGHT_TREE_THRESHOLD and not wants_light_tree(graph)
    effect = summarize(graph).effect("light_tree")
    assert not effect.on and "chosen by power" in effect.reason
    # One group of 10 lamps placed once is past the threshold (8): the tree pays from there.
    assert count_lights(graph_of(many_lights_text(placements=1))).total == 10 >= LIGHT_TREE_THRESHOLD
    cornell = loads((ROOT / "scenes" / "cornell_box.yaml").read_text()).graph
    assert count_lights(cornell).total == 1 and not summarize(cornell).effect("light_tree").on


def test_the_path_integrator_never_wants_a_tree():
    text = many_lights_text().replace("max_depth: 3}", "max_depth: 3, integrator: path}")
    assert not wants_light_tree(graph_of(text))


@pytest.mark.slow
def test_the_memory_estimate_counts_light_rows_and_tree_nodes_for_ten_thousand_instanced_emitters():
    """12,000 lights (a group of 12 placed 1,000 times): the estimate's lights part holds what the
    light table, the tree and its build take at their peak (measured with tracemalloc)."""
    from renderer.compile import compile_scene
    from renderer.lights import light_tables
    from scenefmt.bounds import estimate_memory

    shapes = "\n".join(f"      - {{type: sphere, center: [{0.1 * k:.1f}, 0.5, 0], radius: 0.02, material: warm}}" for k in range(12))
    rows = "\n".join(f"  - {{type: instance, group: bulbs, transform: [{{translate: [{k % 40}, 0, {k // 40}]}}]}}" for k in range(1000))
    text = HEAD + "groups:\n  bulbs:\n    shapes:\n" + shapes + "\nshapes:\n" + rows + "\n"
    graph = graph_of(text)
    estimate = estimate_memory(graph)
    assert count_lights(graph).total == 12_000
    flat = compile_scene(graph)
    assert len(flat.ltree_i) == 2 * 12_000 - 1
    tracemalloc.start()
    try:
        tables = light_tables(flat._replace(ltree_f=flat.ltree_f[:0], ltree_i=flat.ltree_i[:0]), 0.0, graph)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    kept = sum(a.nbytes for a in tables.values())
    assert kept <= peak <= estimate.lights, (kept, peak, estimate.lights)


# --- the kernels ------------------------------------------------------------------------------


def shading_points(flat, count: int, seed: int):
    """Random points over the scene's lights (some inside their bounds), half with a random
    unit normal and half with none (a medium's), and the lights' own centres."""
    from renderer.lights import LIGHT_TREE_LEAF

    rng = np.random.default_rng(seed)
    points = np.c_[rng.uniform(-6, 6, count), rng.uniform(0, 1.5, count), rng.uniform(-5, 5, count)]
    leaves = flat.light_i[flat.light_i[:, LIGHT_TREE_LEAF] >= 0, LIGHT_TREE_LEAF]
    centres = flat.ltree_f[rng.choice(leaves, 8), LT_CENTER:LT_CENTER + 3]
    points = np.r_[points, centres]
    normals = rng.normal(size=points.shape)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    normals[::2] = 0.0
    return points, normals


@pytest.mark.slow
@pytest.mark.parametrize("background", ["", MAP], ids=["lamps", "map and lamps"])
def test_the_pmf_sums_to_one_over_all_lights_and_select_light_follows_it(background):
    from tests.renderer.light_tree_calls import choices, pmf_table

    flat = flat_of(many_lights_text(background))
    first = 1 if background else 0
    assert len(flat.light_i) == 300 + first and len(flat.ltree_i) == 2 * 300 - 1
    assert flat.ltree_f[0, LT_SHARE] == 1.0
    points, normals = shading_points(flat, 40, 3)
    table = pmf_table(flat, points, normals, first)
    assert np.all(np.isfinite(table)) and np.all(table >= 0)
    assert np.allclose(table.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    n = 200_000
    rng = np.random.default_rng(8)
    for k in (0, 1, len(points) - 1):
        out = choices(flat, np.repeat(points[k:k + 1], n, 0), np.repeat(normals[k:k + 1], n, 0), rng.random(n))
        tree = out[:, 0] >= first
        lights = out[tree, 0].astype(int) - first
        assert np.all(np.isfinite(out)) and np.all(out[tree, 2] > 0)
        assert np.allclose(out[tree, 2], table[k, lights], rtol=1e-12, atol=0), "select_light's pmf is not the table's"
        assert np.allclose(out[tree, 3], out[tree, 2], rtol=1e-12, atol=0), "light_pmf does not give what select_light gave"
        p_value, dof = chi2_test(np.bincount(lights, minlength=300), table[k])
        assert dof > 20 and p_value > ALPHA / 3, f"point {k}: chi-square p = {p_value:.2e}"
        if background:
            from renderer.lights import LIGHT_PMF

            share = flat.light_f[0, LIGHT_PMF]
            assert abs((~tree).mean() - share) <= z_limit(3) * math.sqrt(share * (1 - share) / n)


@pytest.mark.slow
def test_a_shading_point_inside_a_light_or_at_its_centre_gives_finite_importance():
    from tests.renderer.light_tree_calls import importances, pmf_table

    flat = flat_of(many_lights_text())
    centres = flat.ltree_f[:, LT_CENTER:LT_CENTER + 3]
    normals = np.tile([0.0, 1.0, 0.0], (len(centres), 1))
    values = importances(flat, centres[:50], normals[:50])
    assert np.all(np.isfinite(values)) and np.all(values >= 0)
    table = pmf_table(flat, centres[:50], normals[:50], 0)
    assert np.all(np.isfinite(table)) and np.allclose(table.sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.slow
def test_the_tree_and_the_power_cdf_render_the_same_image():
    """Unbiased: 300 lights, 16x16 pixels, block means of the two estimators within noise."""
    from renderer.light_tree import LTREE_F, LTREE_I
    from renderer.render import render

    graph = graph_of(many_lights_text())
    from renderer.compile import compile_scene

    flat = compile_scene(graph)
    assert len(flat.ltree_i) > 0
    power = flat._replace(ltree_f=LTREE_F.array(0), ltree_i=LTREE_I.array(0))
    tree_film = render(graph, flat=flat, samples=256, seed=5, kernel="general").film
    power_film = render(graph, flat=power, samples=256, seed=6, kernel="general").film
    z = block_z(tree_film, power_film, block=4)
    assert np.all(np.isfinite(tree_film.total)) and np.abs(z).max() <= z_limit(z.size), np.abs(z).max()


@pytest.mark.slow
def test_the_tree_image_is_the_same_on_one_and_two_threads():
    from renderer import target
    from renderer.render import render

    graph = graph_of(many_lights_text())
    before = target.thread_count()
    try:
        target.set_thread_count(1)
        one = render(graph, samples=8, seed=3, kernel="general", pass_seconds=0.02).film
        target.set_thread_count(min(2, target.max_thread_count()))
        two = render(graph, samples=8, seed=3, kernel="general", pass_seconds=0.05).film
    finally:
        target.set_thread_count(before)
    assert np.array_equal(one.total, two.total) and np.array_equal(one.total_sq, two.total_sq)


# --- lights that are no shape: points and spots in the tree, parallel light beside it ----------


def punctual_text() -> str:
    """The 300 area lights, 12 point lights, 12 spots pointing down and a directional light."""
    lights = ["lights:"]
    for k in range(12):
        x, z = -5 + k, 4 - 0.7 * k
        lights.append(f"  - {{type: point, position: [{x}, 1.5, {z}], intensity: {1 + k % 3}}}")
        lights.append(f"  - {{type: spot, position: [{z}, 2, {x}], look_at: [{z + 0.5}, 0, {x}], intensity: 4, cutoff_angle: 25}}")
    lights.append("  - {type: directional, direction: [0.3, -1, 0.2], irradiance: 0.5}")
    return many_lights_text() + "\n".join(lights) + "\n"


def test_point_and_spot_lights_count_toward_the_tree():
    graph = graph_of(punctual_text())
    assert count_lights(graph).total == 300 + 24


@pytest.mark.slow
def test_points_and_spots_go_into_the_tree_and_parallel_light_keeps_its_share_beside_it():
    from renderer.light_table import DIRECTIONAL_LIGHT, LIGHT_KIND, LIGHT_PMF, LIGHT_TREE_LEAF, POINT_LIGHT, SPOT_LIGHT
    from tests.renderer.light_tree_calls import choices, pmf_table

    flat = flat_of(punctual_text())
    kind = flat.light_i[:, LIGHT_KIND]
    leaf = flat.light_i[:, LIGHT_TREE_LEAF]
    assert np.all(leaf[(kind == POINT_LIGHT) | (kind == SPOT_LIGHT)] >= 0) and (kind == SPOT_LIGHT).sum() == 12
    parallel = np.flatnonzero(kind == DIRECTIONAL_LIGHT)
    assert len(parallel) == 1 and leaf[parallel[0]] == -1
    share = flat.ltree_f[0, LT_SHARE]
    assert share == pytest.approx(1.0 - flat.light_f[parallel[0], LIGHT_PMF], rel=1e-12) and share < 1.0
    points, normals = shading_points(flat, 30, 4)
    table = pmf_table(flat, points, normals, 0)
    assert np.all(np.isfinite(table)) and np.allclose(table.sum(axis=1), 1.0, atol=1e-12)
    assert np.allclose(table[:, parallel[0]], flat.light_f[parallel[0], LIGHT_PMF])
    n = 200_000
    rng = np.random.default_rng(9)
    for k in (0, 3):
        out = choices(flat, np.repeat(points[k:k + 1], n, 0), np.repeat(normals[k:k + 1], n, 0), rng.random(n))
        lights = out[:, 0].astype(int)
        assert np.allclose(out[:, 3], out[:, 2], rtol=1e-12, atol=0)
        assert np.allclose(out[:, 2], table[k, lights], rtol=1e-12, atol=0)
        p_value, _ = chi2_test(np.bincount(lights, minlength=len(kind)), table[k])
        assert p_value > ALPHA / 2, f"point {k}: chi-square p = {p_value:.2e}"
    # A spot sends nothing past its cut-off: from straight above it, at its own height, its pmf is 0.
    spots = np.flatnonzero(kind == SPOT_LIGHT)
    from renderer.light_table import LIGHT_POSITION

    above = flat.light_f[spots[:1], LIGHT_POSITION:LIGHT_POSITION + 3] + np.array([[0.0, 3.0, 0.0]])
    assert pmf_table(flat, above, np.zeros((1, 3)), 0)[0, spots[0]] == 0.0
