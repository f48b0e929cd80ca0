"""The microfacet core (renderer/materials/microfacet.py) and the Fresnel terms of fresnel.py.

The kernels are checked against the textbook forms of tests/naive.py on random inputs, the
distribution against its own normalisation (the projected area of the microfacets is the
macrosurface's: the integral of D(m) m.z over the hemisphere is 1), the visible-normal sampler
by chi-square against `visible_normal_pdf`, and every function for finite values at the edges:
grazing directions, alpha at MIN_ALPHA and 1, normals in the tangent plane.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from renderer.materials import fresnel as fr
from renderer.materials import microfacet as mf
from tests import naive
from tests.renderer.stats import ALPHA, chi2_test

SEED = 20251126
# (ax, ay): isotropic rough and glossy, anisotropic both ways.
ALPHAS = [(0.5, 0.5), (0.1, 0.1), (0.3, 0.08), (0.05, 0.6), (1.0, 1.0)]


def random_unit(rng, upper=False):
    v = rng.normal(size=3)
    v /= np.linalg.norm(v)
    if upper:
        v[2] = abs(v[2])
    return tuple(float(x) for x in v)


def close(a, b, rel=1e-9, abs_=1e-12):
    return abs(a - b) <= abs_ + rel * max(abs(a), abs(b))


# --- kernels against the textbook forms -------------------------------------------------------


def test_d_lambda_g1_g_match_textbook_forms():
    rng = np.random.default_rng(SEED)
    for _ in range(300):
        ax, ay = (float(a) for a in rng.uniform(0.02, 1.0, 2))
        wo, wi, m = random_unit(rng), random_unit(rng), random_unit(rng)
        if min(abs(wo[2]), abs(wi[2]), abs(m[2])) < 1e-6:
            continue
        assert close(mf.ggx_d(ax, ay, m), naive.ggx_d(ax, ay, m))
        assert close(mf.ggx_lambda(ax, ay, wo), naive.ggx_lambda(ax, ay, wo))
        assert close(mf.smith_g1(ax, ay, wo, m), naive.smith_g1(ax, ay, wo, m))
        for correlated in (True, False):
            assert close(mf.smith_g(ax, ay, wo, wi, m, correlated), naive.smith_g(ax, ay, wo, wi, m, correlated))
        assert close(mf.visible_normal_pdf(ax, ay, wo, m),
                     naive.visible_normal_pdf(ax, ay, wo, m) if wo[2] > 0 else 0.0)


def test_correlated_g_lies_between_separable_and_min_g1():
    rng = np.random.default_rng(SEED + 1)
    for _ in range(200):
        ax, ay = (float(a) for a in rng.uniform(0.02, 1.0, 2))
        wo, wi, m = random_unit(rng, True), random_unit(rng, True), random_unit(rng, True)
        g1o, g1i = mf.smith_g1(ax, ay, wo, m), mf.smith_g1(ax, ay, wi, m)
        g = mf.smith_g(ax, ay, wo, wi, m, True)
        assert g1o * g1i - 1e-12 <= g <= min(g1o, g1i) + 1e-12


def test_fresnel_matches_complex_arithmetic():
    rng = np.random.default_rng(SEED + 2)
    for _ in range(300):
        cos_i = float(rng.uniform(0.0, 1.0))
        eta = tuple(float(x) for x in rng.uniform(0.05, 3.0, 3))
        k = tuple(float(x) for x in rng.uniform(0.0, 6.0, 3))
        got = fr.fresnel_conductor(cos_i, eta, k)
        for c in range(3):
            assert close(got[c], naive.fresnel_conductor(cos_i, eta[c], k[c]), rel=1e-9, abs_=1e-12)
        # With k = 0 a conductor is a dielectric seen from outside (eta = far side over near side).
        e = float(rng.uniform(1.01, 3.0))
        assert close(fr.fresnel_conductor(cos_i, (e, e, e), (0.0, 0.0, 0.0))[0],
                     naive.fresnel_dielectric(cos_i, 1.0 / e), rel=1e-9)
        # The existing dielectric Fresnel (its eta incident over far side), both ways.
        for eta_d in (e, 1.0 / e):
            assert close(fr.fresnel_dielectric(cos_i, eta_d)[0], naive.fresnel_dielectric(cos_i, eta_d), rel=1e-9)
        f0 = tuple(float(x) for x in rng.uniform(0, 1, 3))
        s = fr.schlick(f0, cos_i)
        assert all(close(s[c], naive.schlick(f0[c], cos_i)) for c in range(3))


def test_fresnel_conductor_limits():
    gold_like = ((0.18, 0.42, 1.37), (3.4, 2.35, 1.77))
    assert fr.fresnel_conductor(0.0, *gold_like) == (1.0, 1.0, 1.0)
    # Normal incidence: ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2).
    r = fr.fresnel_conductor(1.0, *gold_like)
    for c in range(3):
        e, k = gold_like[0][c], gold_like[1][c]
        assert close(r[c], ((e - 1) ** 2 + k * k) / ((e + 1) ** 2 + k * k))
    # A huge extinction reflects (almost) everything; eta 1, k 0 is no interface.
    assert min(fr.fresnel_conductor(0.5, (1.0, 1.0, 1.0), (1e4, 1e4, 1e4))) > 0.9999
    # (Exactly at grazing incidence every index reflects 1, this one included.)
    for cos_i in (1e-4, 0.5, 1.0 - 1e-9, 1.0):
        assert all(0.0 <= x < 1e-15 for x in fr.fresnel_conductor(cos_i, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)))
    # Out-of-range cosines are clamped, degenerate indices stay finite.
    for cos_i in (-0.5, 0.0, 1.0, 1.5):
        for idx in (((0.0,) * 3, (0.0,) * 3), gold_like):
            assert all(math.isfinite(x) and 0.0 <= x <= 1.0 for x in fr.fresnel_conductor(cos_i, *idx))
    assert fr.schlick((0.04, 0.5, 1.0), 0.0) == (1.0, 1.0, 1.0)
    assert fr.schlick((0.04, 0.5, 1.0), 1.0) == (0.04, 0.5, 1.0)


# --- integrals over the hemisphere --------------------------------------------------------------

# Bins in (t, phi) with t = sqrt(theta / (pi / 2)), finer toward the pole where GGX peaks.
NT, NP, SUB = 40, 40, 6


@numba.njit(cache=False)
def _bin_integrals(ax, ay, w, which):
    """The integral over each (t, phi) bin of the upper hemisphere of: which 0, D(m) m.z;
    which 1, visible_normal_pdf(w, m); by a SUB x SUB midpoint rule in (t, phi)."""
    out = np.zeros((NT, NP))
    dt = 1.0 / (NT * SUB)
    dp = 2.0 * math.pi / (NP * SUB)
    for i in range(NT * SUB):
        t = (i + 0.5) * dt
        theta = 0.5 * math.pi * t * t
        # d(theta) = pi t dt; solid angle sin(theta) d(theta) d(phi).
        jac = math.sin(theta) * math.pi * t * dt * dp
        for j in range(NP * SUB):
            phi = (j + 0.5) * dp
            m = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
            if which == 0:
                v = mf.ggx_d(ax, ay, m) * m[2]
            else:
                v = mf.visible_normal_pdf(ax, ay, w, m)
            out[i // SUB, j // SUB] += v * jac
    return out


@numba.njit(cache=False)
def _draw(ax, ay, w, n, seed):
    np.random.seed(seed)
    out = np.empty((n, 3))
    for i in range(n):
        m = mf.sample_visible_normal(ax, ay, w, np.random.random(), np.random.random())
        out[i, 0], out[i, 1], out[i, 2] = m
    return out


def _bin_of(m):
    theta = np.arccos(np.clip(m[:, 2], -1, 1))
    t = np.sqrt(theta / (0.5 * np.pi))
    phi = np.mod(np.arctan2(m[:, 1], m[:, 0]), 2 * np.pi)
    it = np.clip((t * NT).astype(int), 0, NT - 1)
    ip = np.clip((phi / (2 * np.pi) * NP).astype(int), 0, NP - 1)
    return np.bincount(it * NP + ip, minlength=NT * NP)


@pytest.mark.parametrize("ax,ay", ALPHAS)
def test_d_is_normalised(ax, ay):
    total = _bin_integrals(ax, ay, (0.0, 0.0, 1.0), 0).sum()
    assert abs(total - 1.0) < 1e-4, total


def _direction(theta, phi):
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))


# View directions: normal, oblique, grazing (85 degrees).
VIEWS = [_direction(0.0, 0.0), _direction(1.0, 0.7), _direction(math.radians(85.0), 2.2)]


@pytest.mark.parametrize("ax,ay", [(0.5, 0.5), (0.1, 0.1), (0.3, 0.08)])
@pytest.mark.parametrize("w", VIEWS)
def test_visible_normal_sampler_follows_its_pdf(ax, ay, w):
    probs = _bin_integrals(ax, ay, w, 1).ravel()
    # The visible-normal density is itself normalised (its projected areas sum to the view's).
    assert abs(probs.sum() - 1.0) < 1e-4, probs.sum()
    m = _draw(ax, ay, w, 200_000, SEED)
    assert np.isfinite(m).all()
    assert (m[:, 2] >= 0).all() and (m @ np.array(w) >= -1e-12).all(), "a normal facing away from the view"
    p, dof = chi2_test(_bin_of(m), probs / probs.sum())
    assert dof > 50
    assert p > ALPHA, (p, dof)


# --- no NaN or Inf ------------------------------------------------------------------------------


def test_finite_at_the_edges():
    edge_alphas = [mf.MIN_ALPHA, 1.0]
    dirs = [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, -1.0), _direction(math.pi / 2 - 1e-9, 0.3),
            _direction(1e-9, 1.0), (math.sqrt(0.5), 0.0, -math.sqrt(0.5)), (1.0, 0.0, 5e-324), (0.0, 1.0, -1e-310)]
    for ax in edge_alphas:
        for ay in edge_alphas:
            for w in dirs:
                assert math.isfinite(mf.ggx_lambda(ax, ay, w))
                for m in dirs:
                    values = [mf.ggx_d(ax, ay, m), mf.smith_g1(ax, ay, w, m), mf.visible_normal_pdf(ax, ay, w, m)]
                    for wi in dirs:
                        values += [mf.smith_g(ax, ay, w, wi, m, True), mf.smith_g(ax, ay, w, wi, m, False)]
                    assert all(math.isfinite(v) and v >= 0.0 for v in values), (ax, ay, w, m, values)
                if w[2] > 0:
                    for u1 in (0.0, 0.5, 1.0 - 2 ** -53):
                        for u2 in (0.0, 0.25, 0.5, 1.0 - 2 ** -53):
                            m = mf.sample_visible_normal(ax, ay, w, u1, u2)
                            assert all(math.isfinite(x) for x in m) and abs(math.hypot(*m) - 1.0) < 1e-9
                            assert m[2] >= 0.0
    # Grazing views: masking is total, nothing is infinite.
    assert mf.smith_g1(0.5, 0.5, (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)) == 0.0
    assert mf.ggx_lambda(0.5, 0.5, (1.0, 0.0, 0.0)) == mf.LAMBDA_AT_GRAZING
    # D's peak at MIN_ALPHA is large but finite: 1 / (pi alpha^2).
    assert close(mf.ggx_d(mf.MIN_ALPHA, mf.MIN_ALPHA, (0.0, 0.0, 1.0)), 1.0 / (math.pi * mf.MIN_ALPHA ** 2))
