"""Plastic through the material interface a render uses (`dispatch.sample_bsdf`, `eval_bsdf`,
`pdf_bsdf` by way of `families.py`): world directions in random frames with random tangents,
the row's ior, nonlinear flag and shadowing form, the widths in the parameter slots. The lobes
themselves are tested in the local frame by test_plastic.py; this holds the wiring: the sampler's
pdf is pdf_bsdf of its direction, its weight eval / pdf, deltas only from the smooth coat's
mirror, eval reciprocal and zero across the surface. Slow: it compiles the interface's kernels.
"""

from __future__ import annotations

import numpy as np
import pytest

from renderer.materials import MATERIAL_F, MATERIAL_I
from renderer.materials.table import PLASTIC

pytestmark = pytest.mark.slow

SEED = 20251128
N = 20_000
ALBEDO = np.array([0.7, 0.4, 0.2])


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def rows(ior=1.5, nonlinear=False, correlated=True):
    ints = MATERIAL_I.row(kind=PLASTIC, nonlinear=int(nonlinear), correlated=int(correlated))
    floats = MATERIAL_F.row(fuzz=0.0, ior=ior)
    return np.array([ints], np.int32), np.array([floats], np.float64)


def setups(n, seed):
    """Incoming directions d, normals on d's side, and tangents (not all perpendicular to the
    normal: the frame projects them)."""
    rng = np.random.default_rng(seed)
    n_front = unit_rows(rng.normal(size=(n, 3)))
    d = unit_rows(rng.normal(size=(n, 3)))
    d = np.where(((d * n_front).sum(axis=1) > 0)[:, None], -d, d)
    tangent = unit_rows(rng.normal(size=(n, 3)))
    return d, n_front, tangent


def params(ax, ay):
    p = np.zeros(8)
    p[0], p[1] = ax, ay
    return p


@pytest.mark.parametrize("ax,ay,nonlinear", [(0.0, 0.0, False), (0.2, 0.2, True), (0.05, 0.4, False)])
def test_samples_agree_with_eval_and_pdf_through_the_interface(ax, ay, nonlinear):
    from tests.renderer.kernel_calls import bsdf_samples

    d, n_front, tangent = setups(N, SEED)
    s = bsdf_samples(*rows(nonlinear=nonlinear), ALBEDO, d, n_front, True, SEED, 1, params(ax, ay), tangent)
    assert np.isfinite(s).all()
    wi, weight, pdf, delta = s[:, 0:3], s[:, 3:6], s[:, 6], s[:, 7] == 1.0
    absorbed = ~np.any(wi != 0.0, axis=1)
    # A failed sample (a microfacet reflection below the surface) comes back absorbed, never a delta.
    assert not (absorbed & delta).any() and (weight[absorbed] == 0.0).all()
    assert delta.any() == (ax == 0.0)
    ok = ~absorbed & ~delta
    assert ok.mean() > 0.5
    # Above the surface on the ray's side.
    assert ((unit_rows(wi[ok]) * n_front[ok]).sum(axis=1) > 0).all()
    np.testing.assert_allclose(s[ok, 8], pdf[ok], rtol=1e-9)
    tint, value = s[ok, 9:12], s[ok, 12]
    np.testing.assert_allclose(weight[ok], tint * (value / pdf[ok])[:, None], rtol=1e-9)
    # The mirror: along the reflection of d, no density, no value for a given pair.
    if delta.any():
        mirror = d[delta] - 2 * (d[delta] * n_front[delta]).sum(axis=1)[:, None] * n_front[delta]
        np.testing.assert_allclose(unit_rows(wi[delta]), mirror, atol=1e-9)
        assert (pdf[delta] == 0.0).all() and (weight[delta] > 0.0).all()


@pytest.mark.parametrize("ax,ay", [(0.0, 0.0), (0.3, 0.1)])
@pytest.mark.parametrize("correlated", [True, False])
def test_eval_is_reciprocal_and_black_across_the_surface(ax, ay, correlated):
    from tests.renderer.kernel_calls import bsdf_values

    rng = np.random.default_rng(SEED + 1)
    normal = unit_rows(rng.normal(size=(N, 3)))
    tangent = unit_rows(rng.normal(size=(N, 3)))
    d = unit_rows(rng.normal(size=(N, 3)))
    d = np.where(((d * normal).sum(axis=1) > 0)[:, None], -d, d)
    wi = unit_rows(rng.normal(size=(N, 3)))
    mat = rows(correlated=correlated)
    p = params(ax, ay)
    forward = bsdf_values(*mat, ALBEDO, d, normal, wi, p, tangent)
    backward = bsdf_values(*mat, ALBEDO, -wi, normal, -d, p, tangent)
    same_side = (wi * normal).sum(axis=1) > 1e-6
    cos_wi, cos_wo = (wi * normal).sum(axis=1), -(d * normal).sum(axis=1)
    keep = same_side & (cos_wo > 1e-6)
    f_forward = forward[keep, 0:3] * forward[keep, 3:4] / cos_wi[keep, None]
    f_backward = backward[keep, 0:3] * backward[keep, 3:4] / cos_wo[keep, None]
    assert (f_forward > 0).all()
    np.testing.assert_allclose(f_forward, f_backward, rtol=1e-9)
    across = (wi * normal).sum(axis=1) < 0
    assert (forward[across, 3] == 0.0).all() and (forward[across, 4] == 0.0).all()
