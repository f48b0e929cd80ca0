"""A bounded run of the fuzzer (tests/fuzz.py): mutated book scenes, corrupted saved states and
hostile paths end in a refusal with a position or an accepted scene, never in a traceback, a
hang, a raw control character or, when rendered, a non-finite pixel."""

from __future__ import annotations

import pytest

from tests import fuzz


def assert_clean(counts: fuzz.Counts) -> None:
    assert counts.bad == 0, counts.report()
    assert counts.rejected_without_position == 0, counts.report()
    assert counts.cases == counts.accepted + counts.rejected_with_position + counts.rejected_without_position


def test_a_bounded_run_of_validation_cases_is_clean():
    counts = fuzz.run(cases=300, seed=18, render_share=0.0, measure_memory=False)
    assert_clean(counts)
    # The mutations reach every stage: some scenes survive, saved states and hostile paths are tried.
    assert counts.accepted > 10 and counts.states > 5 and counts.paths > 0


@pytest.mark.slow
def test_a_bounded_run_with_tiny_renders_is_clean():
    counts = fuzz.run(cases=150, seed=19, render_share=1.0, measure_memory=False)
    assert_clean(counts)
    assert counts.rendered > 10
