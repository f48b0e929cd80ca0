"""Bounded runs of the fuzzer (tests/fuzz.py): mutated book scenes, corrupted saved states, hostile
paths, and the surfaces beyond the scene text (includes, `--set`, standard input, mesh files,
image files, `rt render`'s outputs) end in a refusal with a position or an accepted scene, never
in a traceback, a hang, a raw control character, an echoed file, an overwritten input or, when
rendered, a non-finite pixel."""

from __future__ import annotations

import pytest

from tests import fuzz


def assert_clean(counts: fuzz.Counts) -> None:
    assert counts.bad == 0, counts.report()
    assert counts.rejected_without_position == 0, counts.report()
    assert counts.cases == counts.accepted + counts.rejected_with_position + counts.rejected_without_position + counts.tracebacks + counts.hangs


def test_a_bounded_run_of_validation_cases_is_clean():
    counts = fuzz.run(cases=300, seed=18, render_share=0.0, measure_memory=False, surfaces=fuzz.OLD_SURFACES)
    assert_clean(counts)
    # The mutations reach every stage: some scenes survive, saved states and hostile paths are tried.
    assert counts.accepted > 10 and counts.states > 5 and counts.paths > 0


@pytest.mark.slow
def test_a_bounded_run_with_tiny_renders_is_clean():
    counts = fuzz.run(cases=150, seed=19, render_share=1.0, measure_memory=False, surfaces=fuzz.OLD_SURFACES)
    assert_clean(counts)
    assert counts.rendered > 10


# The surfaces issue 29 added to the fuzzer; on the code before its fixes, each of these runs met
# at least one failure (docs/robustness.md lists them).
NEW_SURFACES = ["includes", "set", "stdin", "meshes", "images", "outputs"]


@pytest.mark.parametrize("surface", NEW_SURFACES)
def test_a_bounded_run_of_a_new_surface_is_clean(surface):
    # Seeds whose 40 cases meet at least one of the failures above on the code before the fixes.
    seed = 30 if surface == "images" else 29
    counts = fuzz.run(cases=40, seed=seed, render_share=0.0, measure_memory=False, surfaces=[surface])
    assert_clean(counts)
    assert counts.cases == 40 and counts.accepted + counts.rejected_with_position > 20
