"""The principled material's lobes (renderer/materials/principled.py), in the local frame.

Its sampler is held to its own density by chi-square (dielectric, metallic, transmissive and
clearcoated variants, two roughnesses, normal and grazing views), its sampled weight to
eval / pdf, its reflection to reciprocity, and its energy to at most 1 in a white furnace (one
case to its exact closed form). Its limits are checked against simpler materials: metallic 1 is
a GGX conductor with Schlick's F0 = base colour (tests/naive.py's formula), and with metallic,
transmission, clearcoat and specular all 0 it is lambertian. No input at the edges (grazing
directions, roughness 0 and 1, ior 1, a view below the surface) gives NaN or Inf.

Small compiled loops (declared through renderer/target.py, so their code is cached with the
renderer's) drive the device functions over arrays with random numbers from numpy's seeded
generator, so every outcome is deterministic.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from renderer import target

from renderer.materials import principled as pr
from renderer.materials.microfacet import MIN_ALPHA
from tests import naive
from tests.renderer.stats import ALPHA, chi2_test

SEED = 20251126
BASE = (0.8, 0.5, 0.3)
WHITE = (1.0, 1.0, 1.0)
IOR = 1.5


def params(alpha=0.3, metallic=0.0, transmission=0.0, clearcoat=0.0, cc_alpha=0.1, specular=1.0, specular_color=WHITE,
           eta=IOR, thin_walled=True, base=BASE, correlated=True, ay=None):
    """The argument list of the principled functions before wo (ax, ay, metallic, transmission,
    clearcoat, cc_alpha, specular, specular_color, eta, thin_walled, base, correlated)."""
    return (float(alpha), float(alpha if ay is None else ay), float(metallic), float(transmission), float(clearcoat),
            float(cc_alpha), float(specular), tuple(float(c) for c in specular_color), float(eta), bool(thin_walled),
            tuple(float(c) for c in base), bool(correlated))


def direction(theta, phi=0.0):
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))


NORMAL = direction(0.0)
OBLIQUE = direction(0.9, 0.4)
GRAZING = direction(math.radians(84.0), 2.0)


# --- drivers ------------------------------------------------------------------------------------


@target.kernel
def _samples(p, wo, us):
    """Rows (wi, weight, pdf, delta, eval at wi, pdf at wi) of principled_sample for each row of us."""
    ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr = p
    out = np.zeros((us.shape[0], 12))
    for k in range(us.shape[0]):
        wi, w, pdf, delta = pr.principled_sample(ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr, wo, us[k, 0],
                                                 us[k, 1], us[k, 2])
        out[k, 0], out[k, 1], out[k, 2] = wi
        out[k, 3], out[k, 4], out[k, 5] = w
        out[k, 6] = pdf
        out[k, 7] = 1.0 if delta else 0.0
        if wi[0] != 0.0 or wi[1] != 0.0 or wi[2] != 0.0:
            f = pr.principled_eval(ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr, wo, wi)
            out[k, 8], out[k, 9], out[k, 10] = f
            out[k, 11] = pr.principled_pdf(ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr, wo, wi)
    return out


@target.kernel
def _values(p, wo, wis):
    """Rows (eval r, g, b, pdf) for each direction of wis."""
    ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr = p
    out = np.zeros((wis.shape[0], 4))
    for k in range(wis.shape[0]):
        wi = (wis[k, 0], wis[k, 1], wis[k, 2])
        f = pr.principled_eval(ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr, wo, wi)
        out[k, 0], out[k, 1], out[k, 2] = f
        out[k, 3] = pr.principled_pdf(ax, ay, m, t, c, cca, s, sc, eta, thin, base, corr, wo, wi)
    return out


def draw(p, wo, n, seed):
    us = np.random.default_rng(seed).random((n, 3))
    return _samples(p, wo, us)


# --- the sampler follows its own density ----------------------------------------------------------

# Bins per hemisphere in (t, phi), t = sqrt(theta / (pi / 2)): finer toward the poles, where
# the specular and transmission lobes peak at a normal view. Each bin's integral is a midpoint
# rule of SUB x SUB points, and of HORIZON_SUB points in t in the bins next to the horizon, where
# a lobe seen at grazing incidence changes fast (a refraction's density, for one).
NT, NP, SUB, HORIZON_SUB = 24, 24, 16, 96


def _bin_directions():
    """Unit directions of the upper hemisphere's integration points, their solid angles and bins."""
    ts, dts, rows = [], [], []
    for i in range(NT):
        n = HORIZON_SUB if i >= NT - 2 else SUB
        ts.append((i + (np.arange(n) + 0.5) / n) / NT)
        dts.append(np.full(n, 1.0 / (NT * n)))
        rows.append(np.full(n, i))
    t, dt, row = np.concatenate(ts), np.concatenate(dts), np.concatenate(rows)
    dp = 2.0 * math.pi / (NP * SUB)
    phi = (np.arange(NP * SUB) + 0.5) * dp
    tt, pp = np.meshgrid(t, phi, indexing="ij")
    theta = 0.5 * np.pi * tt * tt
    jac = np.sin(theta) * np.pi * tt * dt[:, None] * dp  # solid angle of each point's cell
    dirs = np.stack([np.sin(theta) * np.cos(pp), np.sin(theta) * np.sin(pp), np.cos(theta)], axis=-1).reshape(-1, 3)
    cell = (row[:, None] * NP + np.arange(NP * SUB)[None, :] // SUB).reshape(-1)
    return dirs, jac.reshape(-1), cell


def cell_probabilities(p, wo):
    """The integral of principled_pdf over each bin of the upper, then the lower hemisphere."""
    dirs, jac, cell = _bin_directions()
    cells = []
    for sign in (1.0, -1.0):
        d = dirs * np.array([1.0, 1.0, sign])
        mass = _values(p, wo, d)[:, 3] * jac
        cells.append(np.bincount(cell, weights=mass, minlength=NT * NP))
    return np.concatenate(cells)


def cell_counts(wi):
    theta = np.arccos(np.clip(np.abs(wi[:, 2]), 0, 1))
    t = np.sqrt(theta / (0.5 * np.pi))
    phi = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), 2 * np.pi)
    it = np.clip((t * NT).astype(int), 0, NT - 1)
    ip = np.clip((phi / (2 * np.pi) * NP).astype(int), 0, NP - 1)
    cell = it * NP + ip + np.where(wi[:, 2] < 0, NT * NP, 0)
    return np.bincount(cell, minlength=2 * NT * NP)


def sampler_p_value(p, wo, n=200_000, seed=SEED):
    """Chi-square p-value of the sampled directions against principled_pdf's bin integrals, with
    one more bin for failed samples (probability 1 - the pdf's integral)."""
    s = draw(p, wo, n, seed)
    assert not s[:, 7].any(), "a rough material gave a delta sample"
    ok = np.any(s[:, 0:3] != 0.0, axis=1)
    probs = cell_probabilities(p, wo)
    total = probs.sum()
    assert 0.5 < total <= 1.0 + 2e-3, total
    counts = np.append(cell_counts(s[ok, 0:3]), (~ok).sum())
    probs = np.append(probs, max(0.0, 1.0 - total))
    return chi2_test(counts, probs / probs.sum())[0]


VARIANTS = {
    "dielectric": {},
    "metallic": {"metallic": 1.0},
    "transmissive": {"transmission": 0.8},
    "clearcoated": {"clearcoat": 1.0, "cc_alpha": 0.15},
    "everything": {"metallic": 0.3, "transmission": 0.5, "clearcoat": 0.6, "cc_alpha": 0.25, "specular": 0.7,
                   "specular_color": (1.0, 0.4, 2.0)},
    # Volumetric transmission through the rough dielectric, entering and leaving.
    "glass": {"transmission": 1.0, "thin_walled": False},
    "glass_from_inside": {"transmission": 1.0, "thin_walled": False, "eta": 1 / IOR},
    "frosted_coated": {"transmission": 0.6, "thin_walled": False, "clearcoat": 0.4, "cc_alpha": 0.2, "metallic": 0.2},
}


@pytest.mark.slow
@pytest.mark.parametrize("variant", sorted(VARIANTS))
@pytest.mark.parametrize("alpha", [0.15, 0.6])
@pytest.mark.parametrize("wo", [NORMAL, GRAZING], ids=["normal", "grazing"])
def test_sampler_follows_its_pdf(variant, alpha, wo):
    p = params(alpha=alpha, **VARIANTS[variant])
    assert sampler_p_value(p, wo) > ALPHA


@pytest.mark.slow
def test_sampler_follows_its_pdf_anisotropic():
    p = params(alpha=0.1, ay=0.5, transmission=0.5, clearcoat=0.5)
    assert sampler_p_value(p, OBLIQUE) > ALPHA


@pytest.mark.slow
def test_the_chi_square_check_rejects_a_wrong_pdf():
    """Control: samples of one roughness against the density of another are rejected."""
    wo = OBLIQUE
    s = draw(params(alpha=0.3, metallic=1.0), wo, 200_000, SEED)
    ok = np.any(s[:, 0:3] != 0.0, axis=1)
    probs = cell_probabilities(params(alpha=0.35, metallic=1.0), wo)
    counts = np.append(cell_counts(s[ok, 0:3]), (~ok).sum())
    probs = np.append(probs, max(0.0, 1.0 - probs.sum()))
    assert chi2_test(counts, probs / probs.sum())[0] < 1e-6


# --- weight, reciprocity, energy ------------------------------------------------------------------


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_sampled_weight_is_eval_over_pdf(variant):
    for alpha in (0.0, 0.2, 1.0):
        for wo in (NORMAL, OBLIQUE, GRAZING):
            p = params(alpha=alpha, **VARIANTS[variant])
            s = draw(p, wo, 4000, SEED + 1)
            assert np.isfinite(s).all()
            ok = np.any(s[:, 0:3] != 0.0, axis=1)
            smooth = s[:, 7] == 1.0
            rough = ok & ~smooth
            np.testing.assert_allclose(np.linalg.norm(s[ok, 0:3], axis=1), 1.0, atol=1e-12)
            # The density sampled is the density asked, and the weight is eval / pdf.
            np.testing.assert_allclose(s[rough, 6], s[rough, 11], rtol=1e-12)
            assert (s[rough, 6] > 0).all()
            np.testing.assert_allclose(s[rough, 3:6], s[rough, 8:11] / s[rough, 6][:, None], rtol=1e-12)
            # A delta sample: no density; the mirror, straight through or Snell's refraction.
            assert (s[smooth, 6] == 0.0).all()
            if alpha > 0.0:
                assert variant != "dielectric" or not smooth.any()
            flat = s[smooth]
            eta = p[8]
            sin2_t = (1 - wo[2] ** 2) / eta ** 2
            refracted = np.array([-wo[0] / eta, -wo[1] / eta, -math.sqrt(max(0.0, 1 - sin2_t))])
            allowed = [np.array([-wo[0], -wo[1], wo[2]]), -np.array(wo), refracted]
            assert np.any([np.all(np.abs(flat[:, 0:3] - a) < 1e-12, axis=1) for a in allowed], axis=0).all()
            # A failed sample is black.
            assert (s[~ok, 3:6] == 0.0).all()


def random_upper(rng, n):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    v[:, 2] = np.abs(v[:, 2])
    return v


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_reflection_is_reciprocal(variant):
    """f(wo, wi) = f(wi, wo) for both directions above the surface: eval / cos theta_i."""
    rng = np.random.default_rng(SEED + 2)
    for alpha in (0.05, 0.4, 1.0):
        for correlated in (True, False):
            p = params(alpha=alpha, correlated=correlated, **VARIANTS[variant])
            a, b = random_upper(rng, 300), random_upper(rng, 300)
            for wo, wi in zip(a, b):
                if min(wo[2], wi[2]) < 1e-4:
                    continue
                f = pr.principled_eval(*p, tuple(wo), tuple(wi))
                g = pr.principled_eval(*p, tuple(wi), tuple(wo))
                for c in range(3):
                    assert f[c] >= 0.0
                    assert math.isclose(f[c] / wi[2], g[c] / wo[2], rel_tol=1e-10, abs_tol=1e-300)


def furnace(p, wo, n=200_000, seed=SEED + 3):
    """Mean and standard error of the sampled weight per channel: the directional albedo."""
    s = draw(p, wo, n, seed)
    w = s[:, 3:6]
    return w.mean(axis=0), w.std(axis=0) / math.sqrt(n)


@pytest.mark.slow
@pytest.mark.parametrize("variant", sorted(VARIANTS))
@pytest.mark.parametrize("alpha", [0.0, 0.1, 0.5, 1.0])
def test_white_furnace_energy_at_most_one(variant, alpha):
    kw = dict(VARIANTS[variant])
    for eta in [kw.pop("eta")] if "eta" in kw else (1.0, 1.5, 3.0):
        for wo in (NORMAL, OBLIQUE, GRAZING, direction(math.radians(89.5))):
            mean, se = furnace(params(alpha=alpha, base=WHITE, eta=eta, **kw), wo, n=40_000)
            assert np.isfinite(mean).all()
            assert (mean <= 1.0 + 5.0 * se + 1e-12).all(), (eta, wo, mean, se)


def test_white_furnace_smooth_dielectric_closed_form():
    """Smooth coat over a white diffuse base, at normal incidence: the mirror takes F0 and the
    base (1 - F0) times the diffuse albedo of (1 - F(cos_i)), 1 - F0 - (1 - F0) / 21."""
    f0 = 0.04
    expected = f0 + (1 - f0) * (1 - f0 - (1 - f0) / 21)
    mean, se = furnace(params(alpha=0.0, base=WHITE), NORMAL, n=200_000)
    assert (np.abs(mean - expected) < 5 * se).all(), (mean, se, expected)
    assert (se < 2e-3).all()  # the check above is sharp enough to tell 1 from 0.918


def test_white_furnace_smooth_metal_is_one():
    for wo in (NORMAL, OBLIQUE, GRAZING):
        s = draw(params(alpha=0.0, metallic=1.0, base=WHITE), wo, 1000, SEED + 4)
        assert (s[:, 7] == 1.0).all() and (s[:, 3:6] == 1.0).all()


# --- limits ---------------------------------------------------------------------------------------


def test_metallic_is_a_schlick_conductor():
    """metallic 1, roughness alpha: D G / (4 cos_o cos_i) Schlick(base, wo . h) cos_i, with the
    textbook D and G of tests/naive.py; nothing below the surface."""
    rng = np.random.default_rng(SEED + 5)
    for ax, ay in ((0.3, 0.3), (0.05, 0.4), (1.0, 1.0)):
        for correlated in (True, False):
            p = params(alpha=ax, ay=ay, metallic=1.0, transmission=0.7, clearcoat=0.0, correlated=correlated)
            for wo, wi in zip(random_upper(rng, 100), random_upper(rng, 100)):
                wo, wi = tuple(wo), tuple(wi)
                got = pr.principled_eval(*p, wo, wi)
                want = naive.principled_metal(ax, ay, BASE, wo, wi, correlated)
                for c in range(3):
                    assert math.isclose(got[c], want[c], rel_tol=1e-9, abs_tol=1e-300)
                below = (wi[0], wi[1], -wi[2])
                assert pr.principled_eval(*p, wo, below) == (0.0, 0.0, 0.0)


def test_plain_base_is_lambertian():
    """metallic, transmission, clearcoat and specular 0: base / pi cos theta_i, cosine sampled,
    weight the base colour; at any roughness."""
    rng = np.random.default_rng(SEED + 6)
    for alpha in (0.0, 0.3, 1.0):
        p = params(alpha=alpha, specular=0.0)
        for wo, wi in zip(random_upper(rng, 100), random_upper(rng, 100)):
            wo, wi = tuple(wo), tuple(wi)
            f = pr.principled_eval(*p, wo, wi)
            for c in range(3):
                assert math.isclose(f[c], BASE[c] / math.pi * wi[2], rel_tol=1e-14)
            assert math.isclose(pr.principled_pdf(*p, wo, wi), wi[2] / math.pi, rel_tol=1e-14)
            assert pr.principled_eval(*p, wo, (wi[0], wi[1], -wi[2])) == (0.0, 0.0, 0.0)
        s = draw(p, OBLIQUE, 2000, SEED + 7)
        assert not s[:, 7].any() and (s[:, 2] > 0).all()
        np.testing.assert_allclose(s[:, 3:6], np.tile(BASE, (len(s), 1)), rtol=1e-12)


def test_smooth_lobes_weights():
    """Roughness 0: the mirror carries the layer's and the metal's Fresnel at wo.z, the straight
    path the base-tinted (1 - F)^2; summed over the lobe choice they give the albedo."""
    wo = OBLIQUE
    cos_o = wo[2]
    f = pr.schlick1(pr.dielectric_f0(IOR), cos_o)
    p = params(alpha=0.0, transmission=1.0)
    s = draw(p, wo, 20_000, SEED + 8)
    through = s[:, 7].astype(bool) & (s[:, 2] < 0)
    mirror = s[:, 7].astype(bool) & (s[:, 2] > 0)
    assert through.any() and mirror.any() and (through | mirror).all()
    probs = pr.lobe_probabilities(0.0, 1.0, 0.0, 1.0, pr.layer_f0(IOR, WHITE), True, cos_o, False)
    np.testing.assert_allclose(s[mirror, 3:6], f / probs[1], rtol=1e-12)
    np.testing.assert_allclose(s[through, 3:6], np.tile(np.array(BASE) * (1 - f) ** 2 / probs[2], (through.sum(), 1)),
                               rtol=1e-12)
    # ior 1: no layer to reflect at normal incidence, so all of it goes straight through, tinted.
    s = draw(params(alpha=0.0, transmission=1.0, eta=1.0), NORMAL, 1000, SEED + 9)
    np.testing.assert_allclose(s[:, 0:3], np.tile((0.0, 0.0, -1.0), (len(s), 1)), atol=0)
    np.testing.assert_allclose(s[:, 3:6], np.tile(BASE, (len(s), 1)), rtol=1e-12)


def test_smooth_volumetric_glass_is_the_books_dielectric():
    """transmission 1, metallic 0, roughness 0, volumetric: the smooth dielectric, reflecting with
    the exact Fresnel probability (white) and refracting by Snell's law (tinted by the base)."""
    from renderer.materials.fresnel import fresnel_dielectric
    from tests.renderer.stats import binomial_p_value

    wo = direction(0.5, 0.4)  # inside the critical angle from within the glass too
    for eta in (IOR, 1 / IOR):
        s = draw(params(alpha=0.0, transmission=1.0, thin_walled=False, eta=eta), wo, 20_000, SEED + 10)
        assert (s[:, 7] == 1.0).all()
        up = s[:, 2] > 0
        np.testing.assert_allclose(s[up, 3:6], 1.0, rtol=1e-15)
        np.testing.assert_allclose(s[~up, 3:6], np.tile(BASE, ((~up).sum(), 1)), rtol=1e-15)
        reflectance = fresnel_dielectric(wo[2], 1 / eta)[0]
        assert binomial_p_value(int(up.sum()), len(s), reflectance) > ALPHA
        # Control: the same count is far from a reflectance 30% off.
        assert binomial_p_value(int(up.sum()), len(s), reflectance * 1.3) < ALPHA


# --- no NaN or Inf --------------------------------------------------------------------------------

EDGE_DIRECTIONS = [NORMAL, GRAZING, direction(math.pi / 2 - 1e-9, 0.3), direction(math.pi / 2, 1.0),
                   direction(math.pi / 2 + 1e-9, 2.0), direction(math.pi), direction(2.5, 0.1), direction(1e-12, 0.5)]


@pytest.mark.parametrize("alpha", [0.0, MIN_ALPHA * 0.5, MIN_ALPHA, 1.0])
@pytest.mark.parametrize("eta", [1.0, IOR, 1 / IOR])
def test_finite_at_the_edges(alpha, eta):
    """Grazing and tangent directions, views below the surface (a normal map can cause them),
    roughness 0 and 1, ior 1: finite and non-negative, black and 0 where wo is not above."""
    us = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5], [1 - 2 ** -53] * 3, [0.999, 1e-12, 0.999], [0.3, 1 - 2 ** -53, 0.0],
                   [0.6, 0.25, 1 - 2 ** -53], [0.9, 0.0, 0.75]])
    cases = [params(alpha=alpha, **{"cc_alpha": alpha, **kw, "eta": eta}) for kw in VARIANTS.values()]
    # Anisotropic with one width below MIN_ALPHA (raised to it, as the conductor does).
    cases += [params(alpha=0.3, ay=alpha, eta=eta, transmission=0.5, clearcoat=0.5, cc_alpha=alpha)]
    for p in cases:
        for wo in EDGE_DIRECTIONS:
            s = _samples(p, wo, us)
            v = _values(p, wo, np.array(EDGE_DIRECTIONS))
            assert np.isfinite(s).all() and np.isfinite(v).all(), (p, wo)
            assert (s[:, 3:7] >= 0).all() and (v >= 0).all()
            if not wo[2] > 0:
                assert (s == 0).all() and (v == 0).all()
