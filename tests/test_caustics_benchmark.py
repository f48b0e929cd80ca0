"""The caustics benchmark's arithmetic (benchmarks/caustics.py, issue 34): the time-to-error
extrapolation, the pixels it measures (the same for every integrator), the true error against the
converged reference with the pixels masked, and the ratio its table prints. No timing is asserted:
the renders are a fraction of a second on a 48-pixel image and the machine may be busy."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import caustics  # noqa: E402
from tests.renderer.converged import Reference, load_reference, true_error  # noqa: E402

INTEGRATORS = ("mis", "guided")


def test_time_to_error_is_the_time_scaled_by_the_squared_error_ratio():
    # An unbiased estimator at 4% after 10 s reaches 2% after 4 times the samples: 40 s.
    assert caustics.time_to_error(10.0, 0.04, 0.02) == pytest.approx(40.0, rel=1e-12)
    assert caustics.time_to_error(3.0, 0.01, 0.02) == pytest.approx(0.75, rel=1e-12)
    assert caustics.time_to_error(3.0, 0.0, 0.02) == 0.0
    assert caustics.time_to_error(3.0, math.nan, 0.02) == math.inf
    assert caustics.time_to_error(math.inf, 0.1, 0.02) == math.inf


def test_the_masked_true_error_sees_an_error_of_the_kept_pixels_only():
    reference = load_reference("cornell_box")
    keep = np.ones(reference.mean.shape[:2], bool)
    keep[:4] = False  # the top rows, where the lamp is
    truth = caustics.masked(reference, keep)
    assert truth.mean.shape == (int(keep.sum()), 3)
    # The reference itself is the truth up to its own noise: no error beyond it.
    assert true_error(reference.mean[keep], truth) == 0.0
    # 10% too bright on the kept pixels is a 10% error there, less the reference's own part.
    expected = math.sqrt(0.01 - float(np.sum(truth.var)) / float(np.sum(truth.mean**2)))
    assert true_error(1.1 * reference.mean[keep], truth) == pytest.approx(expected, rel=1e-9)
    # Whatever the masked pixels hold does not count.
    wrong = reference.mean.copy()
    wrong[~keep] *= 100.0
    assert true_error(wrong[keep], truth) == 0.0


def test_the_table_prints_each_renderers_time_over_guideds():
    keep = np.ones((2, 2), bool)
    truth = Reference(np.ones((4, 3)), np.zeros((4, 3)), np.zeros((4, 3)), 1)
    rows = [caustics.Measurement("s", "mis", 1.0, 2.0, 3.5, 0.0, 10, 0.2, keep),
            caustics.Measurement("s", "guided", 1.0, 2.0, 3.5, 0.5, 10, 0.05, keep)]
    text = caustics.table([(rows, truth)], 0.02)
    mis_row = next(line for line in text.splitlines() if "| mis |" in line)
    assert mis_row.split("|")[-4].strip() == "200"  # 2 s x (0.2 / 0.02)^2
    assert mis_row.split("|")[-3].strip() == "350"  # the same of 3.5 CPU seconds
    assert mis_row.split("|")[-2].strip() == "16.00"  # (0.2 / 0.05)^2


@pytest.mark.slow
def test_the_benchmark_measures_every_integrator_on_the_same_pixels():
    measurements, truth = caustics.measure_scene("cornell_box", INTEGRATORS, seconds=1.0, factors=(1, 2))
    assert [m.renderer for m in measurements] == list(INTEGRATORS) * 2
    assert [m.budget for m in measurements] == [1.0, 1.0, 2.0, 2.0]
    keep = measurements[0].kept
    # The lamp's pixels are left out, the walls kept, and the mask is the same for every render.
    assert 0 < np.sum(~keep) < 0.05 * keep.size
    assert truth.mean.shape == (int(keep.sum()), 3)
    for m in measurements:
        assert np.array_equal(m.kept, keep)
        assert m.wall > 0.0 and m.cpu >= 0.0
        if m.renderer == "guided":
            assert 0.0 < m.training <= m.wall  # the training is part of the render's time
        else:
            assert m.training == 0.0 and m.spp > 0
        if m.spp == 0:
            # A machine so busy that the training took the whole budget: no image, no figure.
            assert m.error == math.inf and m.time_to(0.02) == math.inf
            continue
        assert math.isfinite(m.error) and 0.0 < m.error < 10.0
        assert m.time_to(0.02) == pytest.approx(m.wall * (m.error / 0.02) ** 2, rel=1e-12)
