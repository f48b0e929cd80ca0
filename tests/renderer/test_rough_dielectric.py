"""The rough dielectric (renderer/materials/rough_dielectric.py, Walter et al. 2007 with GGX).

Local frame of the material interface: wo.z > 0, eta = far index / near index (1.5 entering
glass, 1 / 1.5 leaving it), a transmitted wi has wi.z < 0.

- The sampler against its own pdf: chi-square over the whole sphere of directions (both sides
  of the surface, a last bin for the samples the single-scattering model loses), on both sides
  of the interface, at alpha 0.1, 0.5 and 1, anisotropic, near-normal and grazing wo.
- weight = eval / pdf, and pdf = `_pdf` of the sampled direction.
- eval against Walter's formulas written out here with the textbook D, G and Fresnel of
  tests/naive.py.
- Reciprocity in the convention implemented (radiance not scaled by 1 / eta^2, as the books'
  smooth dielectric): reflection f(wo, wi) = f(wi, wo); refraction f(wo, wi) / n_i^2 =
  f(wi, wo) / n_o^2 with n_o the index on wo's side and n_i on wi's, i.e. f(wo, wi) = eta^2
  f(wi, wo) where the reversed pair sees the interface from the other side (eta -> 1 / eta).
- White furnace (tint 1): the directional albedo is at most 1, close to 1 at low alpha, and the
  loss of single-scattering GGX at alpha 1 measured (by the sampler and, independently, by
  quadrature of eval) and held in a stated band.
- The smooth limit (alpha below MIN_ALPHA) is `books.dielectric_direction`'s choice exactly;
  eta = 1 passes straight through; grazing wo, alpha MIN_ALPHA and 1 give finite values.

The fast tests call the device functions un-jitted (`.py_func`); those over many samples run a
compiled loop (tests/renderer/dielectric_calls.py) and are marked slow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.materials.books import dielectric_direction
from renderer.materials.microfacet import MIN_ALPHA
from renderer.materials.rough_dielectric import (rough_dielectric_eval, rough_dielectric_pdf, rough_dielectric_sample)
from tests import naive
from tests.renderer.stats import ALPHA, chi2_test

SEED = 20251131
TINT = (0.9, 0.6, 0.3)
WHITE = (1.0, 1.0, 1.0)
GLASS = 1.5

sample = rough_dielectric_sample.py_func
evaluate = rough_dielectric_eval.py_func
density = rough_dielectric_pdf.py_func


def direction(theta_deg: float, phi: float = 0.3):
    t = math.radians(theta_deg)
    return (math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t))


def random_unit(rng):
    v = rng.normal(size=3)
    v /= np.linalg.norm(v)
    return tuple(float(x) for x in v)


def finite(*values):
    return all(math.isfinite(x) for v in values for x in (v if isinstance(v, tuple) else (v,)))


# --- Walter's BSDF from the textbook pieces ---------------------------------------------------


def walter_f(ax, ay, eta, wo, wi, correlated=True):
    """f(wo, wi) (no cosine) from Walter et al.'s equations (20) and (21), radiance unscaled:
    the half vector by its definition, D, G and F from tests/naive.py."""
    if wi[2] > 0:
        h = naive.unit(naive.add(wo, wi))
    else:
        h = naive.unit(naive.add(wo, naive.mul(wi, eta)))
    if h[2] < 0:
        h = naive.mul(h, -1.0)
    o_h, i_h = naive.dot(wo, h), naive.dot(wi, h)
    if o_h <= 0 or i_h * wi[2] <= 0:
        return 0.0
    d = naive.ggx_d(ax, ay, h)
    g = naive.smith_g(ax, ay, wo, wi, h, correlated)
    f = naive.fresnel_dielectric(o_h, 1.0 / eta)
    if wi[2] > 0:
        return f * d * g / (4 * abs(wo[2]) * abs(wi[2]))
    return (abs(o_h) * abs(i_h) / (abs(wo[2]) * abs(wi[2]))
            * (1 - f) * d * g / (i_h + o_h / eta) ** 2)


def test_eval_matches_walters_formulas():
    rng = np.random.default_rng(SEED)
    checked = {True: 0, False: 0}
    for _ in range(800):
        ax, ay = (float(a) for a in rng.uniform(0.05, 1.0, 2))
        eta = float(rng.choice([GLASS, 1 / GLASS, 1.33, 2.4]))
        wo, wi = random_unit(rng), random_unit(rng)
        wo = (wo[0], wo[1], abs(wo[2]))
        if min(abs(wo[2]), abs(wi[2])) < 1e-3:
            continue
        correlated = bool(rng.integers(2))
        want = walter_f(ax, ay, eta, wo, wi, correlated) * abs(wi[2])
        got = evaluate(ax, ay, eta, WHITE, correlated, wo, wi)
        assert got[0] == got[1] == got[2]
        assert got[0] == pytest.approx(want, rel=1e-9, abs=1e-300)
        checked[wi[2] > 0] += want > 0
    assert min(checked.values()) > 50  # both lobes were met with a value


# --- sample, eval and pdf agree ---------------------------------------------------------------


CASES = [  # (ax, ay, eta, theta of wo in degrees)
    (0.1, 0.1, GLASS, 10), (0.1, 0.1, 1 / GLASS, 10), (0.5, 0.5, GLASS, 10), (0.5, 0.5, 1 / GLASS, 10),
    (0.1, 0.1, GLASS, 80), (0.1, 0.1, 1 / GLASS, 80), (0.5, 0.5, GLASS, 80), (0.5, 0.5, 1 / GLASS, 80),
    (1.0, 1.0, GLASS, 45), (1.0, 1.0, 1 / GLASS, 45), (0.08, 0.4, GLASS, 50), (0.4, 0.08, 1 / GLASS, 30),
]


@pytest.mark.parametrize("correlated", [True, False])
def test_weight_is_eval_over_pdf_and_pdf_is_the_pdf_of_the_sample(correlated):
    rng = np.random.default_rng(SEED + 1)
    lobes = {True: 0, False: 0}
    for ax, ay, eta, theta in CASES:
        wo = direction(theta)
        for u in rng.random((25, 3)):
            wi, weight, pdf, delta = sample(ax, ay, eta, TINT, correlated, wo, *map(float, u))
            assert not delta and finite(wi, weight, pdf)
            if pdf == 0.0:  # lost by single scattering: no direction, no weight
                assert wi == (0.0, 0.0, 0.0) and weight == (0.0, 0.0, 0.0)
                continue
            assert math.sqrt(sum(x * x for x in wi)) == pytest.approx(1.0, abs=1e-12)
            f = evaluate(ax, ay, eta, TINT, correlated, wo, wi)
            assert density(ax, ay, eta, TINT, correlated, wo, wi) == pytest.approx(pdf, rel=1e-9)
            for c in range(3):
                assert weight[c] == pytest.approx(f[c] / pdf, rel=1e-9)
                assert 0.0 <= weight[c] <= TINT[c] * (1 + 1e-12)  # G / G1 <= 1
            lobes[wi[2] > 0] += 1
    assert min(lobes.values()) > 20


# --- reciprocity ------------------------------------------------------------------------------


def test_reflection_is_reciprocal_and_refraction_scales_by_eta_squared():
    """f(wo, wi) = f(wi, wo) for a reflection; f(wo, wi) / n_i^2 = f(wi, wo) / n_o^2 for a refraction
    (n_o = 1 on wo's side, n_i = eta on wi's). The reversed refraction is seen from the other side:
    both directions negated (the frame turned over, which leaves D and G as they are), 1 / eta."""
    rng = np.random.default_rng(SEED + 2)
    met = {True: 0, False: 0}
    for _ in range(1500):
        ax, ay = (float(a) for a in rng.uniform(0.05, 1.0, 2))
        eta = float(rng.choice([GLASS, 1 / GLASS, 2.4]))
        correlated = bool(rng.integers(2))
        wo, wi = random_unit(rng), random_unit(rng)
        wo = (wo[0], wo[1], abs(wo[2]))
        if min(abs(wo[2]), abs(wi[2])) < 1e-3:
            continue
        f = evaluate(ax, ay, eta, WHITE, correlated, wo, wi)[0] / abs(wi[2])
        if wi[2] > 0:
            back = evaluate(ax, ay, eta, WHITE, correlated, wi, wo)[0] / abs(wo[2])
            assert f == pytest.approx(back, rel=1e-9, abs=1e-300)
        else:
            back = evaluate(ax, ay, 1 / eta, WHITE, correlated, naive.mul(wi, -1.0), naive.mul(wo, -1.0))[0] / abs(wo[2])
            assert f / eta ** 2 == pytest.approx(back / 1.0 ** 2, rel=1e-9, abs=1e-300)
        met[wi[2] > 0] += f > 0
    assert min(met.values()) > 50


# --- the smooth limit and eta = 1 -------------------------------------------------------------


@pytest.mark.parametrize("alphas", [(0.0, 0.0), (0.5 * MIN_ALPHA, 0.9 * MIN_ALPHA)])
def test_below_min_alpha_it_is_the_books_dielectric(alphas):
    """The same choice (reflect or refract) and direction as books.dielectric_direction for the same
    u, on both sides of the interface; a delta of weight tint; eval and pdf 0."""
    rng = np.random.default_rng(SEED + 3)
    books = dielectric_direction.py_func
    for _ in range(300):
        wo = random_unit(rng)
        wo = (wo[0], wo[1], abs(wo[2]))
        front = bool(rng.integers(2))
        u = float(rng.random())
        wi, weight, pdf, delta = sample(*alphas, GLASS if front else 1 / GLASS, TINT, True, wo, u, 0.5, 0.5)
        assert delta and pdf == 0.0 and weight == TINT
        want = books((-wo[0], -wo[1], -wo[2]), (0.0, 0.0, 1.0), front, GLASS, u)
        assert wi == pytest.approx(want, abs=1e-14)
        assert evaluate(*alphas, GLASS, TINT, True, wo, wi) == (0.0, 0.0, 0.0)
        assert density(*alphas, GLASS, TINT, True, wo, wi) == 0.0


@pytest.mark.parametrize("alpha", [0.0, 0.3, 1.0])
def test_ior_one_passes_straight_through(alpha):
    """eta = 1 is no interface: nothing reflects and nothing bends, rough or not (a rough lobe would
    send all its light one way, a density with no bound), and nothing is NaN or Inf."""
    rng = np.random.default_rng(SEED + 4)
    for _ in range(100):
        wo = random_unit(rng)
        wo = (wo[0], wo[1], abs(wo[2]) + 1e-3)
        wo = tuple(x / math.sqrt(sum(y * y for y in wo)) for x in wo)
        wi, weight, pdf, delta = sample(alpha, alpha, 1.0, TINT, True, wo, *map(float, rng.random(3)))
        # -wo up to the rounding of Snell's cosine sqrt(1 - sin^2).
        assert delta and weight == TINT and wi == pytest.approx((-wo[0], -wo[1], -wo[2]), abs=1e-12)
        other = random_unit(rng)
        assert evaluate(alpha, alpha, 1.0, TINT, True, wo, other) == (0.0, 0.0, 0.0)
        assert density(alpha, alpha, 1.0, TINT, True, wo, other) == 0.0


# --- no NaN or Inf at the edges ---------------------------------------------------------------


EDGE_WO = {
    "normal": (0.0, 0.0, 1.0),
    "grazing 89.9 degrees": direction(89.9),
    "grazing 1e-12": (math.sqrt(1 - 1e-24), 0.0, 1e-12),
    "in the tangent plane": (1.0, 0.0, 0.0),
    "below the surface (a normal map)": direction(120.0),
}
EDGE_WI = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), direction(89.99, 3.4),
           direction(90.01, 3.4), direction(30, 3.4), direction(150, 3.4), direction(179.9, 0.3)]


@pytest.mark.parametrize("name", list(EDGE_WO))
@pytest.mark.parametrize("alpha", [MIN_ALPHA, 1e-3, 1.0])
@pytest.mark.parametrize("eta", [GLASS, 1 / GLASS, 1.0 + 1e-9])
def test_edges_are_finite(name, alpha, eta):
    wo = EDGE_WO[name]
    us = [(0.0, 0.0, 0.0), (0.999999, 0.999999, 0.999999), (0.5, 0.25, 0.75), (0.01, 1 - 1e-16, 0.5)]
    for u in us:
        wi, weight, pdf, delta = sample(alpha, alpha, eta, TINT, True, wo, *u)
        assert finite(wi, weight, pdf) and pdf >= 0.0 and all(0.0 <= w <= 1.0 for w in weight)
        if wo[2] <= 0.0:
            assert weight == (0.0, 0.0, 0.0) and wi == (0.0, 0.0, 0.0)
    for wi in EDGE_WI:
        f = evaluate(alpha, alpha, eta, TINT, False, wo, wi)
        p = density(alpha, alpha, eta, TINT, True, wo, wi)
        assert finite(f, p) and min(f) >= 0.0 and p >= 0.0
        if wo[2] <= 0.0 or wi[2] == 0.0:
            assert f == (0.0, 0.0, 0.0) and p == 0.0


# --- many samples: chi-square and the white furnace (compiled loops, slow) ---------------------


N = 1_000_000
# Both sides of the interface, glossy and rough, near-normal and grazing wo, alpha 1, anisotropic.
CHI2_CASES = CASES + [(0.3, 0.3, GLASS, 89), (0.3, 0.3, 1 / GLASS, 89)]


def local_wo(theta_deg):
    return np.array(direction(theta_deg))


def many_samples(ax, ay, eta, wo, seed, correlated=True, n=N):
    from tests.renderer.dielectric_calls import rough_samples

    us = np.random.default_rng(seed).random((n, 3))
    return rough_samples(ax, ay, eta, np.ones(3), correlated, wo, us)


def pdf_on(ax, ay, eta, wo):
    from tests.renderer.dielectric_calls import rough_values

    return lambda dirs: rough_values(ax, ay, eta, np.ones(3), True, wo, dirs)[:, 3]


def eval_on(ax, ay, eta, wo, correlated=True):
    from tests.renderer.dielectric_calls import rough_values

    return lambda dirs: rough_values(ax, ay, eta, np.ones(3), correlated, wo, dirs)[:, 0]


@pytest.mark.slow
@pytest.mark.parametrize("ax, ay, eta, theta", CHI2_CASES)
def test_sampler_follows_its_pdf_over_the_whole_sphere(ax, ay, eta, theta):
    from tests.renderer.sphere_chi2 import cell_probabilities, sphere_p_value

    wo = local_wo(theta)
    s = many_samples(ax, ay, eta, wo, SEED + 10 + theta)
    assert np.isfinite(s).all() and not s[:, 7].any()
    used = s[:, 6] > 0.0
    # A lost sample has no direction and no weight; every other has both.
    assert (s[~used, :6] == 0.0).all() and (s[used, 3] > 0.0).all()
    p, dof, integral = sphere_p_value(s[used, :3], (~used).sum(), cell_probabilities(pdf_on(ax, ay, eta, wo)))
    assert p > ALPHA, (p, dof, integral, used.mean())


@pytest.mark.slow
@pytest.mark.parametrize("wrong", ["alpha 10% wider", "eta 1.6 for 1.5"])
def test_the_sphere_check_rejects_a_wrong_density(wrong):
    """Control: the same samples against a slightly different lobe's density fail."""
    from tests.renderer.sphere_chi2 import cell_probabilities, sphere_p_value

    wo = local_wo(30)
    s = many_samples(0.3, 0.3, GLASS, wo, SEED + 5)
    used = s[:, 6] > 0.0
    other = pdf_on(0.33, 0.33, GLASS, wo) if wrong.startswith("alpha") else pdf_on(0.3, 0.3, 1.6, wo)
    assert sphere_p_value(s[used, :3], (~used).sum(), cell_probabilities(other))[0] < 1e-12


def albedo(ax, ay, eta, theta, correlated=True, n=N):
    """(mean weight, its standard error) over n samples, tint white: the directional albedo."""
    w = many_samples(ax, ay, eta, local_wo(theta), SEED + 20, correlated, n)[:, 3]
    return w.mean(), w.std() / math.sqrt(len(w))


@pytest.mark.slow
@pytest.mark.parametrize("eta", [GLASS, 1 / GLASS])
@pytest.mark.parametrize("correlated", [True, False])
def test_white_furnace_loses_nothing_at_low_alpha_and_never_gains(eta, correlated):
    """A white, non-absorbing rough dielectric reflects and transmits at most what arrives, and
    all of it (to 0.1%) at alpha 0.01 away from grazing: single scattering loses only the light
    the microfacets send to the wrong side of the surface, which a narrow lobe hardly does."""
    for alpha in (0.01, 0.05, 0.2, 0.5, 1.0):
        for theta in (0, 30, 60, 80, 89):
            mean, se = albedo(alpha, alpha, eta, theta, correlated, n=200_000)
            assert mean <= 1.0 + 4 * se
            if alpha == 0.01 and theta <= 60:
                assert mean >= 0.999


# Measured single-scattering albedo at alpha 1, normal incidence (1e6 samples, standard error
# 3e-4 and 5e-4): 0.8937 entering glass (eta 1.5) and 0.4174 leaving it (eta 1 / 1.5): losses of
# 10.6% and 58.3%. Leaving the denser side, most microfacets are steep enough to reflect totally
# and send the light down through the macro surface, which single scattering drops.
ALPHA1_BANDS = {GLASS: (0.885, 0.900), 1 / GLASS: (0.410, 0.425)}


@pytest.mark.slow
@pytest.mark.parametrize("eta", [GLASS, 1 / GLASS])
def test_single_scattering_loss_at_alpha_one(eta):
    """The albedo at alpha 1 (normal incidence) lies in its stated band, by the sampler's mean
    weight and, independently of the sampler, by quadrature of eval over the sphere."""
    from tests.renderer.sphere_chi2 import cell_probabilities

    mean, se = albedo(1.0, 1.0, eta, 0)
    lo, hi = ALPHA1_BANDS[eta]
    assert lo <= mean <= hi
    quadrature = cell_probabilities(eval_on(1.0, 1.0, eta, local_wo(0))).sum()
    assert abs(quadrature - mean) < 4 * se + 1e-4, (quadrature, mean, se)
