"""Run by hand with the bench extra: `pytest benchmarks/mitsuba_bsdf_points.py` (CI does not: Mitsuba is
no test dependency). The rough conductor against Mitsuba 3's `roughconductor` (GGX, separable Smith G, its default):
the same f . cos and the same pdf for the same local directions, to Mitsuba's single precision.
Mitsuba is a benchmark dependency (the `bench` extra), so the test is skipped without it; it is
slow because loading Mitsuba takes seconds. Mitsuba's sampler maps (u1, u2) to normals
differently, so only eval and pdf are compared point by point (the sampler is held to its own
pdf in test_conductor.py)."""

from __future__ import annotations

import numpy as np
import pytest

from renderer.materials import conductor as co
from scenefmt import metals

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def mi():
    mitsuba = pytest.importorskip("mitsuba")
    mitsuba.set_variant("scalar_rgb")
    return mitsuba


def local_interaction(mi, wo):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wo)
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    return si


@pytest.mark.parametrize("ax,ay", [(0.3, 0.3), (0.05, 0.05), (0.3, 0.1), (0.08, 0.6)])
@pytest.mark.parametrize("metal", ["Au", "Al"])
def test_eval_and_pdf_match_mitsubas_roughconductor(mi, ax, ay, metal):
    bsdf = mi.load_dict({"type": "roughconductor", "material": metal, "distribution": "ggx",
                         "alpha_u": ax, "alpha_v": ay})
    params = mi.traverse(bsdf)
    eta = tuple(float(x) for x in params["eta.value"])
    k = tuple(float(x) for x in params["k.value"])
    ctx = mi.BSDFContext()
    rng = np.random.default_rng(31)
    compared = 0
    for _ in range(300):
        wo, wi = (v / np.linalg.norm(v) for v in rng.normal(size=(2, 3)))
        wo[2], wi[2] = abs(wo[2]), abs(wi[2])
        si = local_interaction(mi, wo)
        # Mitsuba's si.wi is our wo (toward the viewer); its eval's `wo` is our wi.
        theirs = [float(x) for x in bsdf.eval(ctx, si, mi.Vector3f(*wi))] + [float(bsdf.pdf(ctx, si, mi.Vector3f(*wi)))]
        wo_t, wi_t = tuple(float(x) for x in wo), tuple(float(x) for x in wi)
        ours = list(co.conductor_eval(ax, ay, eta, k, (1.0, 1.0, 1.0), False, wo_t, wi_t))
        ours.append(co.conductor_pdf(ax, ay, eta, k, (1.0, 1.0, 1.0), False, wo_t, wi_t))
        for a, b in zip(ours, theirs):
            assert abs(a - b) <= 1e-5 * abs(b) + 1e-6, (wo, wi, ours, theirs)
        compared += theirs[-1] > 1e-3
    assert compared > 50


def test_smooth_conductor_matches_mitsubas_conductor(mi):
    bsdf = mi.load_dict({"type": "conductor", "material": "Cu"})
    params = mi.traverse(bsdf)
    eta = tuple(float(x) for x in params["eta.value"])
    k = tuple(float(x) for x in params["k.value"])
    ctx = mi.BSDFContext()
    for cos in (1.0, 0.7, 0.3, 0.05):
        wo = (float(np.sqrt(1 - cos * cos)), 0.0, cos)
        bs, weight = bsdf.sample(ctx, local_interaction(mi, wo), 0.5, mi.Point2f(0.5, 0.5))
        wi, ours, pdf, delta = co.conductor_sample(0.0, 0.0, eta, k, (1.0, 1.0, 1.0), False, wo, 0.5, 0.5, 0.5)
        assert delta and pdf == 0.0
        assert np.allclose(wi, [float(x) for x in bs.wo], atol=1e-6)
        assert np.allclose(ours, [float(x) for x in weight], rtol=1e-5)


@pytest.mark.slow
def test_named_metals_are_mitsubas(mi):
    presets = {s: s for s in metals.METALS} | {"Ni": "Ni_palik"}
    for symbol, m in metals.METALS.items():
        if "Johnson" in m.source:
            continue
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": presets[symbol]}))
        got = [float(x) for x in params["eta.value"]] + [float(x) for x in params["k.value"]]
        assert max(abs(a - b) for a, b in zip(got, m.eta + m.k)) < 1e-5, symbol
