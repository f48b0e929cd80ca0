"""Energy conservation (furnace tests): inside a uniform white world nothing may appear.

Derivation. With a background of radiance 1 in every direction and no emitters, a path's
sample is the product of the attenuations along it if it escapes, and 0 if it is cut at the
maximum depth. Every material here has attenuation 1 (lambertian and metal of albedo 1,
dielectric, isotropic medium of albedo 1), so every escaping path carries exactly 1.0 (a
product of 1.0s is 1.0 in floating point): the image is 1 in every pixel with no Monte Carlo
noise at all, and any lost energy (an absorbed ray, a NaN, a wrong Fresnel weight) makes a
sample 0. The tests therefore ask for every pixel to equal 1 to rounding (1e-12), with a max
depth of 1000: the paths in these open scenes escape with a probability of order one at every
bounce (the measured mean path length, asserted below 10, shows it), so a path is cut with a
probability far below 1e-12 and a cut does not happen in practice.

With albedo a < 1 on a single convex object the answer is a, derived as follows: a lambertian
direction n + r (r uniform on the sphere) and a metal direction (kept above the surface) leave
into the outer half-space of the tangent plane, and a ray leaving a convex surface outwards
never meets it again. So a path that hits the object scatters exactly once and escapes: its
sample is a, whatever the fuzz. A pixel whose footprint sees the object over a fraction f of
its area has the mean 1 - (1 - a) f; f is computed by quadrature over the footprint, and the
number of samples that hit (decoded exactly from the pixel sum, since samples are a or 1) is
checked against Binomial(n, f). For a medium with albedo 0 the answer is the Beer-Lambert
transmittance (tests/renderer/test_materials_robust.py); for 0 < a < 1 in a bounded medium there
is no closed form, and a = 0 and a = 1 bracket it.
"""

import numpy as np
import pytest

from renderer.variants import GENERAL
from renderer.render import render
from scenefmt import models as m
from scenefmt.graph import build_graph
from tests.renderer.scenes import WHITE, cluster, pixel_rays, render_scene, scene
from tests.renderer.stats import ALPHA, binomial_p_value

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

MAX_MEAN_PATH = 10.0


def assert_white(result, mean_path=MAX_MEAN_PATH):
    film, stats = result.film, result.stats
    assert stats.bad_samples == 0
    image = film.mean()
    assert np.all(np.abs(image - 1.0) <= 1e-12), f"{np.sum(np.abs(image - 1.0) > 1e-12)} pixel channels differ from 1, min {image.min()}"
    paths = film.width * film.height * film.samples
    assert stats.rays / paths < mean_path, f"mean path length {stats.rays / paths:.1f}: the depth cut could matter"


def test_lambertian_of_albedo_one_vanishes():
    assert_white(render_scene(cluster(m.Lambertian(albedo=WHITE))))


@pytest.mark.parametrize("fuzz", [0.0, 0.05, 0.3, 0.7, 1.0])
def test_metal_of_albedo_one_vanishes_at_any_fuzz(fuzz):
    # The books absorb fuzzed rays below the surface: that code failed here from fuzz 0.05 on, and at
    # fuzz 1 left 162 of the 256 pixels darker than 1, the darkest at 0.375.
    assert_white(render_scene(cluster(m.Metal(albedo=WHITE, fuzz=fuzz))))


@pytest.mark.parametrize("ior", [1.0, 1 / 1.5, 1.0001, 1.33, 1.5, 2.4, 10.0])
def test_dielectric_vanishes_at_any_ior(ior):
    # Glass traps light by total internal reflection, so paths are longer than for surfaces.
    assert_white(render_scene(cluster(m.Dielectric(ior=ior))), mean_path=25.0)


def test_hollow_glass_and_glass_filled_with_fog_vanish():
    shapes = [
        m.Sphere(center=(0, 0.6, 0), radius=0.6, material=m.Dielectric(ior=1.5)),
        m.Sphere(center=(0, 0.6, 0), radius=0.5, material=m.Dielectric(ior=1 / 1.5)),  # the bubble
        m.Sphere(center=(1.2, 0.5, 0), radius=0.5, material=m.Dielectric(ior=1.5),
                 interior=m.ConstantMedium(density=3.0, albedo=WHITE)),  # the final scene's subsurface sphere
    ]
    assert_white(render_scene(shapes), mean_path=25.0)


@pytest.mark.parametrize("density", [0.3, 3.0, 1e3])
def test_isotropic_medium_of_albedo_one_vanishes(density):
    # Optical sizes (density times size) kept at most 5 and 8, so a random walk ends in tens of scatterings.
    r, side = min(0.6, 5.0 / density), min(0.9, 8.0 / density)
    fog = m.ConstantMedium(density=density, albedo=WHITE)
    shapes = [m.Sphere(center=(0, 0.6, 0), radius=r, interior=fog),
              m.Box(min=(-1.7, 0, -0.6), max=(-1.7 + side, side, -0.6 + side), interior=fog)]
    assert_white(render_scene(shapes), mean_path=40.0)


def test_everything_together_vanishes():
    """Every material in one scene, surfaces inside media and media inside glass."""
    fog = m.ConstantMedium(density=1.5, albedo=WHITE)
    shapes = cluster(m.Metal(albedo=WHITE, fuzz=0.5))[:1] + [
        m.Sphere(center=(0, 0.6, 0), radius=0.6, material=m.Lambertian(albedo=WHITE)),
        m.Sphere(center=(1.05, 0.4, 0.35), radius=0.4, material=m.Dielectric(ior=1.5), interior=fog),
        m.Box(min=(-1.7, 0, -0.6), max=(-0.75, 0.9, 0.3), material=m.Metal(albedo=WHITE, fuzz=1.0)),
        m.Sphere(center=(0, 0.5, 0), radius=2.0, interior=m.ConstantMedium(density=0.2, albedo=WHITE)),
        m.MovingSphere(center0=(-0.5, 1.6, 0.5), center1=(0.5, 1.7, 0.5), radius=0.3, material=m.Dielectric(ior=2.0)),
        m.Instance(group=m.Group(shapes=[m.Sphere(center=(0, 0, 0), radius=0.3, material=m.Metal(albedo=WHITE, fuzz=0.8))]),
                   transform=[m.ScaleStep(scale=(2.0, 0.5, 1.0)), m.TranslateStep(translate=(1.5, 1.4, -0.5))]),
    ]
    assert_white(render_scene(shapes, samples=32), mean_path=25.0)


@pytest.mark.parametrize("material", [m.Lambertian(albedo=(0.6, 0.6, 0.6)), m.Metal(albedo=(0.6, 0.6, 0.6), fuzz=0.0),
                                      m.Metal(albedo=(0.6, 0.6, 0.6), fuzz=1.0)], ids=["lambertian", "mirror", "metal_fuzz_1"])
def test_convex_object_of_albedo_a_has_radiance_a(material):
    a = 0.6
    center, radius = np.array([0.2, 0.5, -0.1]), 0.9
    sc = scene([m.Sphere(center=tuple(center), radius=radius, material=material)], samples=64, width=12, height=12)
    result = render(build_graph(sc), features=GENERAL)
    film = result.film
    assert result.stats.bad_samples == 0
    n = film.samples
    # Samples are exactly a (hit the sphere) or 1 (missed it): the sum decodes to a whole number of hits.
    hits = np.rint((n - film.total[..., 0]) / (1.0 - a)).astype(int)
    assert np.allclose(film.total[..., 0], hits * a + (n - hits), rtol=0, atol=1e-9)
    # The fraction of each pixel's footprint inside the sphere's silhouette, by quadrature on a
    # grid that includes the pixel's corners. The silhouette is convex, so a pixel whose four
    # corners are inside is covered entirely: there every sample must be exactly a.
    origin, d = pixel_rays(sc, sub=33, corners=True)
    oc = origin - center
    b = d @ oc
    inside = (b * b - (oc @ oc - radius * radius) >= 0) & (b < 0)
    coverage = inside.mean(axis=-1)
    full = inside[..., [0, 32, -33, -1]].all(axis=-1)
    assert full.any() and (coverage == 0).any()
    assert (hits[full] == n).all()
    pixels = coverage.size
    for (y, x), f in np.ndenumerate(coverage):
        p = 1.0 if full[y, x] else min(max(f, 1e-4), 1 - 1e-4)
        # The quadrature error of f (about 1/33 of the pixel's edge) is below the binomial noise of 64 samples.
        assert binomial_p_value(int(hits[y, x]), n, p) > ALPHA / pixels, (y, x, f, hits[y, x])
