"""Runs of plain spheres are flattened in numpy (shapes/spheres.sphere_run_rows): the tables must be
those of flattening one sphere at a time, value for value."""

import numpy as np

from renderer import compile as compile_module
from renderer.compile import compile_scene
from scenefmt.validation import loads

SCENE = """
camera: {look_from: [0, 0, 30], look_at: [0, 0, 0], vfov: 45}
image: {width: 8, aspect_ratio: 1, samples_per_pixel: 1, max_depth: 4}
materials:
  a: {type: lambertian, albedo: [0.7, 0.2, 0.2]}
  b: {type: metal, albedo: [0.7, 0.7, 0.7], fuzz: 0.1}
  t: {type: lambertian, albedo: {type: checker, scale: 0.5, even: [0.1, 0.1, 0.1], odd: [0.9, 0.9, 0.9]}}
media:
  fog: {type: constant, density: 0.2, albedo: [0.5, 0.5, 0.5]}
groups:
  cluster:
    shapes:
      - {type: sphere, center: [0, 0, 0], radius: 1, material: a}
      - {type: sphere, center: [1, 2, -0.0], radius: 0.5, material: b, transform: [{rotate: {axis: y, degrees: 30}}, {scale: 2}]}
      - {type: sphere, center: [1, 2, 0], radius: 0.5, material: b, transform: [{scale: [1, 2, 1]}]}
shapes:
  - {type: sphere, center: [-0.0, 1, 2], radius: 1, material: a}
  - {type: sphere, center: [3, 1, 2], radius: 2, material: b}
  - {type: quad, q: [0, 0, 0], u: [1, 0, 0], v: [0, 1, 0], material: t}
  - {type: sphere, center: [5, 1, 2], radius: 0.3, material: t, transform: [{translate: [0.1, 0.2, 0.3]}]}
  - {type: sphere, center: [5.5, 1, 2], radius: 0.3, material: t, transform: [{translate: [0.1, 0.2, 0.3]}]}
  - {type: sphere, center: [6, 1, 2], radius: 0.3, material: a, interior: fog}
  - {type: moving_sphere, center0: [6, 1, 2], center1: [6, 2, 2], radius: 0.3, material: a}
  - {type: sphere, center: [7, 1, 2], radius: 0.3, material: b, transform: [{rotate: {axis: x, degrees: 17}}, {scale: 3}, {translate: [1e-3, 7, 9]}]}
  - {type: instance, group: cluster, transform: [{translate: [1, 1, 1]}]}
  - {type: sphere, center: [1.1, 1.3, -2.7], radius: 1e-3, material: a, transform: [{scale: [1, 1, 3]}]}
  - {type: sphere, center: [8, 1, 2], radius: 0.3, material: a}
"""


def test_runs_of_spheres_flatten_to_the_tables_of_one_sphere_at_a_time(monkeypatch):
    rng = np.random.default_rng(3)
    many = "".join(f"  - {{type: sphere, center: [{x!r}, {y!r}, {z!r}], radius: {r!r}, material: {'ab'[k % 2] if k % 7 else 'a'}}}\n"
                   for k, (x, y, z, r) in enumerate(zip(*rng.uniform(-9, 9, (3, 200)).tolist(), rng.uniform(0.01, 1, 200).tolist())))
    graph = loads(SCENE + many).graph
    runs = compile_scene(graph)
    monkeypatch.setattr(compile_module._Walk, "plain_sphere", lambda self, member: False)
    one_by_one = compile_scene(graph)
    for name, table in runs._asdict().items():
        other = getattr(one_by_one, name)
        assert table.dtype == other.dtype and table.shape == other.shape, name
        assert table.tobytes() == other.tobytes(), name


def test_a_run_of_plain_spheres_in_the_graph_gives_the_tables_summary_and_memory_of_one_node_each(monkeypatch):
    from scenefmt import graph as graph_module
    from scenefmt import shapes
    from scenefmt.effects import summarize

    rng = np.random.default_rng(5)
    many = "".join(f"  - {{type: sphere, center: [{x!r}, {y!r}, {z!r}], radius: {r!r}, material: {'abl'[k % 3]}}}\n"
                   for k, (x, y, z, r) in enumerate(zip(*rng.uniform(-9, 9, (3, 300)).tolist(), rng.uniform(0.01, 1, 300).tolist())))
    text = SCENE.replace("materials:\n", "materials:\n  l: {type: diffuse_light, emit: [4, 4, 4]}\n") + many
    text = text.replace("shapes:\n      -", f"shapes:\n{many.replace('  - ', '      - ')}      -", 1)  # a run in the group too
    monkeypatch.setattr(graph_module, "SPHERE_RUN_MIN", 2)
    monkeypatch.setattr(shapes, "PLAIN_SPHERES_AT_ONCE", 1)  # runs made from the columns validated in bulk
    runs = loads(text).graph
    assert sum(m.kind == "sphere_run" for g in [runs.root, *runs.groups] for m in g.members) >= 2
    from_models = graph_module.build_graph(loads(text).scene)  # runs made from the models
    assert [len(m) for m in from_models.root.members if m.kind == "sphere_run"] == [len(m) for m in runs.root.members if m.kind == "sphere_run"]
    compiled_runs, compiled_from_models = compile_scene(runs), compile_scene(from_models)
    for name, table in compiled_runs._asdict().items():
        assert table.tobytes() == getattr(compiled_from_models, name).tobytes(), name
    monkeypatch.setattr(graph_module, "SPHERE_RUN_MIN", 10**9)
    nodes = loads(text).graph
    assert not any(m.kind == "sphere_run" for g in [nodes.root, *nodes.groups] for m in g.members)
    compiled_nodes = compile_scene(nodes)
    for name, table in compiled_runs._asdict().items():
        other = getattr(compiled_nodes, name)
        assert table.dtype == other.dtype and table.shape == other.shape and table.tobytes() == other.tobytes(), name
    assert summarize(runs) == summarize(nodes)
    assert "and 199 more" in summarize(runs).effect("emitters").reason  # 100 emitting spheres in each run
    assert runs.memory == nodes.memory
