"""An emitter that also scatters (issue 31: a principled surface with an emission).

The integrator adds an emitter's radiance and then asks the material interface whether it
`scatters`: the books' diffuse light does not (the path ends there, as before), every other
material does. The light category finds its area lights by asking `emits` (through
`emitting_rows`) and their radiance by asking `emitted_at`, so neither it nor the integrator names
a material kind, and a new kind that emits is a light, sampled and weighted by MIS, at once.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
from renderer import target

from renderer.materials import CODES, MATERIAL_I, emitting_rows, scatters
from tests.renderer.test_material_interface import kind_names, names_in

ROOT = Path(__file__).resolve().parents[2]


@target.kernel
def _scatters_of(mat_i):
    out = np.zeros(mat_i.shape[0], np.bool_)
    for mat in range(mat_i.shape[0]):
        out[mat] = scatters(mat_i, mat)
    return out


def every_kind():
    """Each kind's row as material_rows writes it when it sends no light (emission -1), and a
    principled one whose emission is texture row 0."""
    names = sorted(CODES)
    rows = [MATERIAL_I.row(kind=CODES[n], emission=-1) for n in names]
    rows.append(MATERIAL_I.row(kind=CODES["principled"], emission=0))
    return names + ["emitting principled"], np.array(rows, np.int32)


def test_which_rows_emit_and_which_scatter():
    names, mat_i = every_kind()
    emits = np.zeros(len(names), np.bool_)
    emitting_rows(mat_i, emits)
    assert [n for n, e in zip(names, emits) if e] == ["diffuse_light", "emitting principled"]
    assert [n for n, sc in zip(names, _scatters_of(mat_i)) if not sc] == ["diffuse_light"]


def test_a_black_or_weak_emission_is_no_light():
    """table.py writes an emission row only for a principled material that sends light."""
    from scenefmt.materials import Principled, emits
    from renderer.materials.table import MAT_EMISSION, material_rows

    def row(**kw):
        return material_rows(Principled(**kw), 0, {"emission": 5})[0][MAT_EMISSION]

    assert not emits(Principled()) and row() == -1
    assert not emits(Principled(emission=(2.0, 1.0, 0.0), emission_strength=0)) and row(emission_strength=0) == -1
    assert emits(Principled(emission=(2.0, 1.0, 0.0))) and row(emission=(2.0, 1.0, 0.0)) == 5


def test_the_lights_name_no_material_kind():
    """renderer/lights.py asks `emits` (emitting_rows) and `emission_source`, never which kind of material emits."""
    used = names_in((ROOT / "renderer" / "lights.py").read_text())
    assert {"emitting_rows", "emission_source"} <= used
    material_kinds = kind_names(MATERIAL_I) | {"CODES", "MAT_KIND"}
    assert "DIFFUSE_LIGHT" in material_kinds
    assert used & material_kinds == set()


def test_the_integrator_ends_a_path_only_at_an_emitter_that_does_not_scatter():
    """In `trace`, the branch taken at an emitter breaks out of the loop only under `not scatters(...)`."""
    tree = ast.parse((ROOT / "renderer" / "tracing" / "integrator.py").read_text())
    trace = next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "trace")
    at_emitter = next(n for n in ast.walk(trace) if isinstance(n, ast.If) and "emits" in names_in(ast.unparse(n.test)))
    breaks = [n for n in at_emitter.body if isinstance(n, ast.Break)]
    guarded = [n for n in at_emitter.body if isinstance(n, ast.If) and "scatters" in names_in(ast.unparse(n.test))]
    assert not breaks and len(guarded) == 1
    assert isinstance(guarded[0].body[-1], ast.Break)


def test_a_glowing_principled_surface_switches_the_emitters_and_lights_on():
    """`rt validate`'s effects (and so the kernel's flags) count a principled material that sends
    light as an emitter, and one whose emission is black as none."""
    from scenefmt import models as m
    from scenefmt.effects import summarize
    from scenefmt.graph import build_graph
    from scenefmt.materials import Principled

    def effects(material):
        scene = m.Scene(camera=m.Camera(look_from=(0, 1, 3), look_at=(0, 0, 0)), image=m.Image(width=8, height=8),
                        shapes=[m.Sphere(center=(0, 0, 0), radius=1, material=material)])
        return {e.key: e.on for e in summarize(build_graph(scene)).effects}

    glowing = effects(Principled(emission=(1.0, 0.5, 0.2), emission_strength=3.0))
    assert glowing["emitters"] and glowing["lights"] and glowing["principled"]
    dark = effects(Principled())
    assert not dark["emitters"] and not dark["lights"] and dark["principled"]
