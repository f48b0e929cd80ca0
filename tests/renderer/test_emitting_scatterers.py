"""An emitter that also scatters (issue 31: a principled surface with an emission).

The integrator adds an emitter's radiance and then asks the material interface whether it
`scatters`: the books' diffuse light does not (the path ends there, as before), every other
material does. The light category finds its area lights by asking `emits` (through
`emitting_rows`) and their radiance by asking `emitted`, so neither it nor the integrator names
a material kind, and a new kind that emits is a light, sampled and weighted by MIS, at once.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
from renderer import target

from renderer.materials import CODES, DIFFUSE_LIGHT, MATERIAL_I, emitting_rows, scatters
from tests.renderer.test_material_interface import kind_names, names_in

ROOT = Path(__file__).resolve().parents[2]


@target.kernel
def _scatters_of(mat_i):
    out = np.zeros(mat_i.shape[0], np.bool_)
    for mat in range(mat_i.shape[0]):
        out[mat] = scatters(mat_i, mat)
    return out


def every_kind():
    names = sorted(CODES)
    return names, np.array([MATERIAL_I.row(kind=CODES[n]) for n in names], np.int32)


def test_only_the_books_light_emits_and_does_not_scatter():
    names, mat_i = every_kind()
    emits = np.zeros(len(names), np.bool_)
    emitting_rows(mat_i, emits)
    assert dict(zip(names, emits)) == {n: CODES[n] == DIFFUSE_LIGHT for n in names}
    assert dict(zip(names, _scatters_of(mat_i))) == {n: CODES[n] != DIFFUSE_LIGHT for n in names}


def test_the_lights_name_no_material_kind():
    """renderer/lights.py asks `emits` and `emitted`, never which kind of material emits."""
    used = names_in((ROOT / "renderer" / "lights.py").read_text())
    assert {"emitting_rows", "emitted"} <= used
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
