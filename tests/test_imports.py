"""Import hygiene, read from the source (benchmarks/imports.py): no import circle, imports run one way
(scenefmt -> renderer -> rt, never back), and Numba stays out of the scene format and the tables.

Every import counts, at the top of a module or inside a function: a function-level import that
closes a circle still ties the modules together, it only postpones the failure to a call.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import imports  # noqa: E402

# Circles tolerated, each the set of modules tied together: none since issue 30's render session
# took the steps of `rt render` out of rt/render_job.py (the cluster workers imported it, and it
# imported the cluster). Never add one; the last test below says when an entry has gone stale.
ALLOWED_CIRCLES: list[frozenset] = []

# Renderer modules that declare tables or hold images and must not need Numba: the docs printer,
# `rt validate`'s effects and the film's statistics import them without compiling anything.
NUMBA_FREE_RENDERER = frozenset({
    "renderer", "renderer.columns", "renderer.config", "renderer.kernel_flags", "renderer.flat", "renderer.film",
    "renderer.state",
})
COMPILERS = frozenset({"numba", "llvmlite"})


@pytest.fixture(scope="module")
def arrows():
    return imports.import_arrows()


@pytest.fixture(scope="module")
def outside():
    return imports.external_imports()


def shown(arrows) -> str:
    return "\n".join(str(a) for a in arrows)


def test_the_graph_reader_sees_module_and_function_level_imports(arrows):
    pairs = {(a.source, a.target): a for a in arrows}
    # `from .columns import Column` at the top of a category, and a package import resolved to its module
    assert not pairs[("renderer.materials.table", "renderer.columns")].in_function
    assert ("renderer.compile", "renderer.bvh") in pairs
    # `from renderer.compile import ...` inside a function of render.py
    assert pairs[("renderer.render", "renderer.compile")].in_function
    # `if TYPE_CHECKING:` imports never run: flat.py names the graph only for its annotations
    assert ("renderer.flat", "scenefmt.graph") not in pairs


def test_the_circle_finder_finds_circles_through_function_level_imports():
    a = imports.Arrow
    made = [a("p.a", "p.b", 1, False), a("p.b", "p.c", 1, True), a("p.c", "p.a", 1, False), a("p.c", "p.d", 1, False),
            a("p.e", "p.e", 1, True)]
    assert imports.circles(made) == [["p.a", "p.b", "p.c"], ["p.e"]]
    assert imports.circles(made[:2] + made[3:4]) == []


def test_no_import_circle_beyond_the_known_ones(arrows):
    for component in imports.circles(arrows):
        inside = [a for a in arrows if a.source in component and a.target in component]
        assert any(set(component) <= allowed for allowed in ALLOWED_CIRCLES), (
            f"an import circle among {', '.join(component)}:\n{shown(inside)}")


def test_scenefmt_imports_nothing_of_renderer_or_rt_and_renderer_nothing_of_rt(arrows):
    back = [a for a in arrows if (a.source.startswith("scenefmt") and not a.target.startswith("scenefmt"))
            or (a.source.startswith("renderer") and a.target.startswith("rt"))]
    assert not back, f"imports that run back up the pipeline:\n{shown(back)}"


def test_columns_imports_no_category(arrows):
    """The table vocabulary stands below the categories that declare tables with it."""
    up = [a for a in arrows if a.source == "renderer.columns" and a.target.startswith("renderer")]
    assert not up, shown(up)


def test_numba_stays_out_of_the_scene_format_and_the_tables(outside):
    in_scenefmt = [o for o in outside if o[0].startswith("scenefmt") and o[1] in COMPILERS]
    assert not in_scenefmt, f"scenefmt (models, graph) never compiles anything: {in_scenefmt}"
    in_tables = [o for o in outside if o[0] in NUMBA_FREE_RENDERER and o[1] in COMPILERS]
    assert not in_tables, in_tables
    pydantic = [o for o in outside if o[0].startswith("renderer") and o[1] == "pydantic"]
    assert not pydantic, f"the renderer reads the graph, never the models' machinery: {pydantic}"


def test_every_allowed_circle_still_exists(arrows):
    """An entry of ALLOWED_CIRCLES whose circle is gone must go too, so the list only shrinks."""
    found = [set(c) for c in imports.circles(arrows)]
    stale = [sorted(allowed) for allowed in ALLOWED_CIRCLES if not any(c <= allowed for c in found)]
    assert not stale, f"these circles are gone: delete them from ALLOWED_CIRCLES in tests/test_imports.py: {stale}"


def test_no_arrow_runs_up_the_renderers_layers(arrows):
    """The floor (numerics, tables, target) imports nothing above it, the categories nothing of the
    tracing layer, and neither anything of the session or flattening (benchmarks/imports.py
    defines the layers)."""
    up = [a for a in arrows if imports.is_upward(a)]
    assert not up, f"imports that run up the renderer's layers:\n{shown(up)}"


def test_the_layer_rule_sees_an_upward_arrow():
    """A category importing the tracing layer, or the floor importing a category, counts as upward."""
    assert imports.is_upward(imports.Arrow("renderer.lights", "renderer.tracing.traverse", 1, False))
    assert imports.is_upward(imports.Arrow("renderer.numerics.vec", "renderer.materials", 1, False))
    assert not imports.is_upward(imports.Arrow("renderer.tracing.integrator", "renderer.materials", 1, False))
