"""Plain spheres validated in bulk (shapes.plain_spheres) give the models, and the errors, that
pydantic gives one sphere at a time."""

import math

import pytest

from scenefmt import shapes
from scenefmt.diagnostics import SceneError
from scenefmt.scene import Scene
from scenefmt.shapes import Sphere, plain_spheres
from scenefmt.validation import loads

ODD = [0, -0.0, 1, -7, 2.5, 1e-50, -1e-50, 1e50, 1e-51, 1e51, 1e300, 5e-324, math.inf, -math.inf, math.nan, True, False,
       "1", None, 10**20, 10**400, [1]]
NAMES = ["white", "_x", "a.b-c_9", "9lives", "", "a b", "x" * 64, "x" * 65, "white\n", 3, None, {"type": "lambertian"}]


def cases():
    out = []
    for k, value in enumerate(ODD):
        out.append({"type": "sphere", "center": [value, 0.5, -1], "radius": 1, "material": "white"})
        out.append({"type": "sphere", "center": [0, 1, 2], "radius": value, "material": "white"})
    for name in NAMES:
        out.append({"type": "sphere", "center": [0, 1, 2], "radius": 0.5, "material": name})
    out += [
        {"type": "sphere", "center": [0, 1], "radius": 1, "material": "white"},
        {"type": "sphere", "center": [0, 1, 2, 3], "radius": 1, "material": "white"},
        {"type": "sphere", "center": (0, 1, 2), "radius": 1, "material": "white"},
        {"type": "sphere", "center": [0, 1, 2], "radius": 1, "material": "white", "interior": None},
        {"type": "sphere", "center": [0, 1, 2], "radius": 1},
        {"type": "box", "center": [0, 1, 2], "radius": 1, "material": "white"},
        {"center": [0, 1, 2], "radius": 1, "material": "white", "tpye": "sphere"},
    ]
    return out


def validated(item):
    try:
        return Sphere.model_validate(item)
    except Exception:  # noqa: BLE001 - refused: pydantic must see it
        return None


@pytest.fixture
def at_once(monkeypatch):
    monkeypatch.setattr(shapes, "PLAIN_SPHERES_AT_ONCE", 1)


def test_each_case_is_built_as_pydantic_builds_it_or_left_to_pydantic(at_once):
    items = cases()
    fast, _ = plain_spheres(items)
    assert len(fast) == len(items)
    for item, got in zip(items, fast):
        want = validated(item)
        if got is item:
            continue  # left to pydantic
        assert want is not None, f"accepted in bulk, refused by pydantic: {item!r}"
        assert type(got) is Sphere
        assert repr(got) == repr(want) and got == want
        assert got.model_fields_set == want.model_fields_set
        assert got.model_dump() == want.model_dump()
        assert [math.copysign(1, v) for v in got.center] == [math.copysign(1, v) for v in want.center]
    assert sum(got is not item for item, got in zip(items, fast)) == 18  # every valid one but the tuple


SCENE = """
camera: {look_from: [0, 0, 30], look_at: [0, 0, 0]}
materials: {white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}}
groups:
  g:
    shapes:
      - {type: sphere, center: [0, 0, 0], radius: 1, material: white}
shapes:
  - {type: instance, group: g}
"""


def test_a_scene_reads_the_same_and_reports_the_same_errors(monkeypatch):
    bulk = "".join(f"  - {{type: sphere, center: [{k}, {k / 3!r}, -1.5], radius: 0.25, material: white}}\n" for k in range(40))
    good = SCENE + bulk
    bad = good.replace("center: [7, ", "center: [.nan, ").replace("radius: 0.25, material: white}\n  - {type: sphere, center: [9,",
                                                                  "radius: -2, material: white}\n  - {type: sphere, center: [9,")
    one_by_one = {text: (loads(text).scene if text is good else None) for text in (good,)}
    errors = {}
    with pytest.raises(SceneError) as excinfo:
        loads(bad)
    errors["one"] = [str(d) for d in excinfo.value.diagnostics]
    monkeypatch.setattr(shapes, "PLAIN_SPHERES_AT_ONCE", 1)
    assert loads(good).scene == one_by_one[good]
    assert repr(loads(good).scene) == repr(one_by_one[good])
    with pytest.raises(SceneError) as excinfo:
        loads(bad)
    assert [str(d) for d in excinfo.value.diagnostics] == errors["one"]
    assert len(errors["one"]) == 2 and "shapes[8].center" in errors["one"][0] and "shapes[9].radius" in errors["one"][1]


def test_columns_name_each_spheres_material_when_some_names_are_not_valid(at_once):
    items = [{"type": "sphere", "center": [k, 0, 0], "radius": 1, "material": ["a", "bad name", "b", "c"][k % 4]} for k in range(8)]
    out, columns = plain_spheres(items)
    assert [columns.names[c] for c in columns.material_code] == [out[i].material for i in columns.index]
    assert [items[i]["material"] for i in columns.index] == ["a", "b", "c", "a", "b", "c"]


def test_a_plain_sphere_the_bulk_check_leaves_to_pydantic_joins_its_run_as_it_does_from_the_models(at_once, monkeypatch):
    """`transform: []` and `interior: null` are plain by the graph's one rule (shapes.is_plain_sphere);
    the bulk check leaves such a sphere to pydantic, and the graph reads it from its model."""
    import numpy as np

    from scenefmt import graph as graph_module
    from scenefmt.graph import build_graph

    monkeypatch.setattr(graph_module, "SPHERE_RUN_MIN", 2)
    spheres = [f"  - {{type: sphere, center: [{k}, 0, 0], radius: 0.5, material: {'ab'[k % 3 % 2]}}}" for k in range(7)]
    spheres[3] = "  - {type: sphere, center: [3, 0, 0], radius: 0.25, material: c, transform: []}"
    spheres[5] = "  - {type: sphere, center: [5, 0, 0], radius: 0.75, material: a, interior: null}"
    text = "materials:\n  a: {type: lambertian}\n  b: {type: metal}\n  c: {type: dielectric}\nshapes:\n" + "\n".join(spheres) + "\n"
    loaded = loads(text)
    (run,) = loaded.graph.root.members
    (same,) = build_graph(loaded.scene).root.members  # no columns from the bulk check
    for got in (run, same):
        assert got.kind == "sphere_run" and len(got) == 7
        assert got.centers[:, 0].tolist() == list(range(7)) and got.radii[[3, 5]].tolist() == [0.25, 0.75]
        assert [got.materials[j].name for j in got.material_index] == ["a", "b", "a", "c", "b", "a", "a"]
    assert np.array_equal(run.material_index, same.material_index) and run.centers.tobytes() == same.centers.tobytes()
