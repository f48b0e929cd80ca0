"""The thin dielectric (renderer/materials/thin_dielectric.py): a sheet of glass that reflects
R' = R + T^2 R / (1 - R^2) with every internal bounce summed and lets the rest straight through.

Checked against a textbook Fresnel reflectance written here from the s- and p-polarised
amplitudes (not the kernel's arrangement of them), the series summed term by term, and the
sampler's choice at u0 on either side of R'. The kernels run un-jitted (`.py_func`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.materials.thin_dielectric import (thin_dielectric_eval, thin_dielectric_pdf, thin_dielectric_reflectance,
                                                thin_dielectric_sample)

TINT = (0.9, 0.6, 0.3)
IORS = (1.0, 1.33, 1.5, 2.4)
COSINES = (1.0, 0.8, 0.5, 0.1, 1e-3, 1e-9, 0.0)

reflectance = thin_dielectric_reflectance.py_func
sample = thin_dielectric_sample.py_func


def textbook_reflectance(ior: float, cos_i: float) -> float:
    """Unpolarised Fresnel reflectance from air (index 1) into a medium of index `ior`."""
    sin_t = math.sqrt(max(0.0, 1.0 - cos_i * cos_i)) / ior
    cos_t = math.sqrt(1.0 - sin_t * sin_t)
    r_s = (cos_i - ior * cos_t) / (cos_i + ior * cos_t)
    r_p = (ior * cos_i - cos_t) / (ior * cos_i + cos_t)
    return 0.5 * (r_s * r_s + r_p * r_p)


def summed_bounces(r: float, terms: int = 20_000) -> float:
    """R + T R T + T R^3 T + ...: the sheet's reflectance, summed bounce by bounce."""
    t = 1.0 - r
    return r + sum(t * t * r ** (2 * k + 1) for k in range(terms))


def direction(cos_theta: float, phi: float = 0.7):
    s = math.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
    return (s * math.cos(phi), s * math.sin(phi), cos_theta)


@pytest.mark.parametrize("ior", IORS)
@pytest.mark.parametrize("cos_i", COSINES[:-2])
def test_reflectance_is_the_sum_of_the_internal_bounces(ior, cos_i):
    r = textbook_reflectance(ior, cos_i)
    expected = summed_bounces(r) if r < 0.999 else 2 * r / (1 + r)
    assert reflectance(ior, cos_i) == pytest.approx(expected, rel=1e-9, abs=1e-12)
    assert reflectance(ior, cos_i) == pytest.approx(r + (1 - r) ** 2 * r / (1 - r * r), rel=1e-9, abs=1e-12)


def test_closed_form_at_normal_incidence_of_glass():
    # R = ((1.5 - 1) / (1.5 + 1))^2 = 0.04, so R' = 0.08 / 1.04.
    assert reflectance(1.5, 1.0) == pytest.approx(0.08 / 1.04, rel=1e-12)


@pytest.mark.parametrize("ior", IORS)
@pytest.mark.parametrize("cos_i", COSINES)
def test_reflected_and_transmitted_shares_sum_to_one_and_choose_the_lobe(ior, cos_i):
    """R' + T' = 1: u0 just below R' reflects (weight white), just above lets through (weight tint)."""
    wo = direction(cos_i)
    r_thin = reflectance(ior, min(cos_i, 1.0))
    assert 0.0 <= r_thin <= 1.0
    t_thin = 1.0 - r_thin
    assert r_thin + t_thin == 1.0
    if cos_i == 0.0:
        # In the tangent plane there is no sample (nor any light to carry).
        wi, weight, pdf, delta = sample(ior, TINT, wo, 0.5, 0.5, 0.5)
        assert wi == (0.0, 0.0, 0.0) and weight == (0.0, 0.0, 0.0) and pdf == 0.0 and delta
        return
    below = np.nextafter(r_thin, 0.0)
    if r_thin > 0.0:
        wi, weight, pdf, delta = sample(ior, TINT, wo, below, 0.3, 0.9)
        assert wi == pytest.approx((-wo[0], -wo[1], wo[2]), abs=0.0)
        assert weight == (1.0, 1.0, 1.0) and pdf == 0.0 and delta
    if r_thin < 1.0:
        wi, weight, pdf, delta = sample(ior, TINT, wo, r_thin, 0.3, 0.9)
        assert wi == (-wo[0], -wo[1], -wo[2])
        assert weight == TINT and pdf == 0.0 and delta


def test_the_share_reflected_by_the_sampler_is_r_prime():
    """Over a grid of u0 the reflected fraction is R' (to the grid's resolution)."""
    wo = direction(0.3)
    us = (np.arange(100_000) + 0.5) / 100_000
    reflected = sum(sample(1.5, TINT, wo, u, 0.0, 0.0)[1] == (1.0, 1.0, 1.0) for u in us)
    assert reflected / len(us) == pytest.approx(reflectance(1.5, 0.3), abs=1e-5)


def test_ior_one_is_no_sheet_at_all():
    for cos_i in COSINES[:-1]:
        wo = direction(cos_i)
        assert reflectance(1.0, cos_i) == 0.0
        wi, weight, _, _ = sample(1.0, TINT, wo, 0.0, 0.0, 0.0)
        assert wi == (-wo[0], -wo[1], -wo[2]) and weight == TINT


def test_grazing_light_is_all_reflected_and_finite():
    for ior in IORS[1:]:
        values = [reflectance(ior, c) for c in (1e-6, 1e-9, 1e-15, 0.0)]
        assert all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in values)
        assert values[-1] == 1.0 and values[0] > 0.999


def test_below_the_surface_gives_no_sample():
    for wo in ((0.0, 0.0, -1.0), direction(-0.3), (1.0, 0.0, 0.0)):
        wi, weight, pdf, _ = sample(1.5, TINT, wo, 0.01, 0.5, 0.5)
        assert wi == (0.0, 0.0, 0.0) and weight == (0.0, 0.0, 0.0) and pdf == 0.0


def test_eval_and_pdf_are_zero_everywhere():
    rng = np.random.default_rng(31)
    for _ in range(200):
        wo, wi = rng.normal(size=3), rng.normal(size=3)
        wo, wi = tuple(wo / np.linalg.norm(wo)), tuple(wi / np.linalg.norm(wi))
        assert thin_dielectric_eval.py_func(1.5, TINT, wo, wi) == (0.0, 0.0, 0.0)
        assert thin_dielectric_pdf.py_func(1.5, TINT, wo, wi) == 0.0
