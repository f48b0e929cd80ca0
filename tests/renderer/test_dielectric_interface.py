"""The rough and thin dielectrics through the material interface (dispatch.py -> families.py):
world directions, the shading frame, and eta chosen by the side that was hit.

- A rough glass row answers `sample_bsdf`, `pdf_bsdf` and `eval_bsdf` consistently (pdf of the
  sample, weight = eval / pdf) on both faces, and equals the local-frame lobe with eta = ior on
  the outward face and 1 / ior on the inward one.
- A thin sheet reflects white or passes straight on, tinted, from either face: a delta.
- `has_density`: a rough glass has one (light sampling serves it), a smooth one and a sheet not.
Compiles the interface's test loops: slow.
"""

from __future__ import annotations

import numpy as np
import pytest

from renderer.materials import CODES, has_density
from renderer.materials.table import MAT_CORRELATED
from renderer.materials.rough_dielectric import rough_dielectric_eval, rough_dielectric_pdf
from renderer.numerics.frame import frame_of, to_local

pytestmark = pytest.mark.slow

SEED = 20251132
IOR = 1.5
COLOR = np.array([0.9, 0.6, 0.3])
N = 20_000


def rows(kind, correlated=1):
    from tests.renderer.kernel_calls import material_rows

    mat_i, mat_f = material_rows(CODES[kind], 0.0, IOR)
    mat_i[0, MAT_CORRELATED] = correlated
    return mat_i, mat_f


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def setups(n, seed):
    """Incoming directions d and unit normals on the ray's side (d . n < 0), in random frames."""
    rng = np.random.default_rng(seed)
    n_front = unit_rows(rng.normal(size=(n, 3)))
    d = unit_rows(rng.normal(size=(n, 3)))
    d = np.where(((d * n_front).sum(axis=1) > 0)[:, None], -d, d)
    return d, n_front


@pytest.mark.parametrize("front", [True, False])
@pytest.mark.parametrize("alpha", [0.05, 0.4])
def test_rough_glass_through_the_interface(front, alpha):
    from tests.renderer.kernel_calls import bsdf_samples

    params = [alpha, alpha, 0, 0, 0, 0, 0, 0]
    d, n_front = setups(N, SEED + int(front))
    s = bsdf_samples(*rows("rough_dielectric"), COLOR, d, n_front, front, SEED, 1, params)
    wi, weight, pdf, delta = s[:, 0:3], s[:, 3:6], s[:, 6], s[:, 7]
    assert np.isfinite(s).all() and not delta.any()
    used = np.any(wi != 0.0, axis=1)
    assert used.mean() > 0.8 and (pdf[used] > 0).all() and (weight[~used] == 0).all()
    np.testing.assert_allclose(s[used, 8], pdf[used], rtol=1e-9)
    tint, value = s[used, 9:12], s[used, 12]
    np.testing.assert_allclose(weight[used], tint * (value / pdf[used])[:, None], rtol=1e-9)
    assert (weight[used] <= COLOR * (1 + 1e-12)).all()
    through = (wi[used] * n_front[used]).sum(axis=1) < 0
    assert 0.2 < through.mean() < 0.99  # both lobes are taken

    # The world answers are the local lobe's with eta = ior outside, 1 / ior inside.
    eta = IOR if front else 1 / IOR
    for k in np.flatnonzero(used)[:200]:
        n = tuple(n_front[k])
        sv, tv = frame_of.py_func(n, (0.0, 0.0, 0.0))
        wo = to_local.py_func(sv, tv, n, tuple(-d[k]))
        w = to_local.py_func(sv, tv, n, tuple(wi[k] / np.linalg.norm(wi[k])))
        local = rough_dielectric_eval.py_func(alpha, alpha, eta, tuple(COLOR), True, wo, w)
        assert s[k, 9:12] * s[k, 12] == pytest.approx(local, rel=1e-9)
        assert s[k, 8] == pytest.approx(rough_dielectric_pdf.py_func(alpha, alpha, eta, tuple(COLOR), True, wo, w),
                                        rel=1e-9)


@pytest.mark.parametrize("front", [True, False])
def test_thin_sheet_through_the_interface(front):
    from tests.renderer.kernel_calls import bsdf_samples

    d, n_front = setups(N, SEED + 2 + int(front))
    s = bsdf_samples(*rows("thin_dielectric"), COLOR, d, n_front, front, SEED, 1)
    wi, weight, pdf, delta = s[:, 0:3], s[:, 3:6], s[:, 6], s[:, 7]
    assert np.isfinite(s).all() and delta.all() and (pdf == 0).all()
    assert (s[:, 8] == 0).all() and (s[:, 12] == 0).all()  # no density, no value off the deltas
    through = (wi * n_front).sum(axis=1) < 0
    np.testing.assert_allclose(wi[through], d[through], atol=1e-12)  # straight on
    assert (weight[through] == COLOR).all() and (weight[~through] == 1.0).all()
    mirror = d - 2 * (d * n_front).sum(axis=1)[:, None] * n_front
    np.testing.assert_allclose(wi[~through], mirror[~through], atol=1e-12)
    assert 0.03 < (~through).mean() < 0.3  # about R' averaged over the directions drawn


def test_has_density_for_rough_glass_only():
    def density(kind, alpha):
        mat_i, _ = rows(kind)
        return has_density(mat_i, 0, (alpha, alpha, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))

    assert density("rough_dielectric", 0.3) and density("rough_dielectric", 1e-3)
    assert not density("rough_dielectric", 0.0) and not density("rough_dielectric", 0.5e-4)
    assert not density("thin_dielectric", 0.3)
