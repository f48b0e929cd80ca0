"""Hard cases of materials, media and textures, each against an analytic answer.

Dielectrics: total internal reflection, ior 1 (the sphere vanishes), a hollow (bubble) sphere,
the camera inside a glass sphere, a medium inside glass. Media: the camera inside a medium,
densities 1e-6 and 1e3, rays tangent to a boundary. Surfaces: a lambertian direction that
cancels the normal, metal fuzz below the surface, sphere (u, v) at the poles and the seam.
Textures: an image at u = 1 and v = 1, a checker across negative coordinates, Perlin noise
across lattice cells. docs/robustness.md states each convention these tests pin down.

Renders whose samples are 0 or 1 (an emitter or background of radiance 1, nothing else) are
judged by an exact binomial test; others by z-scores against the per-pixel standard error,
Bonferroni-corrected over the pixels; all at family-wise significance `ALPHA` = 1e-3.
"""

import math

import numpy as np
import pytest

from renderer.variants import GENERAL
from renderer.compile import compile_scene
from renderer.shapes.spheres import sphere_uv
from renderer.materials import DIELECTRIC, LAMBERTIAN, fresnel_dielectric, lambertian_direction, metal_direction, reflect
from renderer.tracing.probe import probe_rays
from renderer.textures import TEX_SOLID, perlin
from renderer.render import render
from renderer.textures import perlin_tables
from scenefmt import models as m
from scenefmt.graph import build_graph
from tests import naive
from tests.renderer.kernel_calls import scatter_many, texture_at, unit_vectors
from tests.renderer.scenes import WHITE, pixel_rays, render_scene, scene
from tests.renderer.stats import ALPHA, binomial_p_value, block_z, pixel_mean_and_se, z_limit

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

BLACK = (0.0, 0.0, 0.0)


def assert_binomial(film, p, alpha=ALPHA):
    """Samples are 0 or 1 with probability p of 1 in every pixel: the pooled count and each pixel's."""
    n = film.samples
    ones = np.rint(film.total[..., 0]).astype(int)
    assert np.allclose(film.total[..., 0], ones, atol=1e-9) and np.allclose(film.total_sq[..., 0], ones, atol=1e-9), \
        "samples other than 0 and 1"
    pixels = ones.size
    total_p = binomial_p_value(int(ones.sum()), n * pixels, p)
    assert total_p > alpha / 2, f"pooled: {ones.sum() / (n * pixels):.6f} against {p:.6f} (p-value {total_p:.2g})"
    worst = min(binomial_p_value(int(k), n, p) for k in ones.ravel())
    assert worst > alpha / 2 / pixels, f"a pixel's count is off (p-value {worst:.2g})"


# --- dielectrics ------------------------------------------------------------------------------


def test_every_material_has_a_texture_row():
    """The bug the dielectric furnace test found: a dielectric's material row pointed at texture
    -1, so the kernels read the last texture row (the glass of every book scene was tinted by the
    last colour defined, gold in weekend_glass) or stray memory. Colourless materials now use a
    white texture, and the compiler refuses a row out of range."""
    from scenefmt.validation import load
    from tests.renderer.references import scene_files

    for path in scene_files():
        flat = compile_scene(load(path).graph)
        assert ((flat.mat_i[:, 1] >= 0) & (flat.mat_i[:, 1] < len(flat.tex_i))).all(), path.stem
    flat = compile_scene(build_graph(m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=1, material=m.Dielectric())])))
    tex = flat.mat_i[0, 1]
    assert flat.tex_i[tex, 0] == TEX_SOLID and tuple(flat.tex_f[tex, :3]) == (1.0, 1.0, 1.0)


def fresnel_reference(cos_i, eta):
    """Unpolarised Fresnel reflectance from the angle form (Born and Wolf), with Snell's law by asin."""
    theta_i = math.acos(cos_i)
    s = eta * math.sin(theta_i)
    if s >= 1.0:
        return 1.0
    theta_t = math.asin(s)
    if theta_i == 0.0:
        return ((eta - 1) / (eta + 1)) ** 2
    rs = -math.sin(theta_i - theta_t) / math.sin(theta_i + theta_t)
    rp = math.tan(theta_i - theta_t) / math.tan(theta_i + theta_t)
    return 0.5 * (rs * rs + rp * rp)


@pytest.mark.parametrize("eta", [1 / 1.5, 1.5, 1 / 2.4, 2.4, 1.0001, 0.3])
def test_fresnel_reflectance_matches_the_angle_form(eta):
    for cos_i in np.linspace(0.0005, 1.0, 400):
        r, cos_t = fresnel_dielectric(cos_i, eta)
        assert 0.0 <= r <= 1.0
        assert r == pytest.approx(fresnel_reference(cos_i, eta), abs=1e-12)
        if r < 1.0:
            # Snell: the sines are in the ratio eta.
            assert math.sqrt(1 - cos_t * cos_t) == pytest.approx(eta * math.sqrt(1 - cos_i * cos_i), abs=1e-12)


def test_fresnel_at_the_edges():
    assert fresnel_dielectric(0.7, 1.0)[0] < 1e-30  # no interface (0 up to the rounding of cos_t)
    assert fresnel_dielectric(0.0, 1.0) == (1.0, 0.0)  # grazing at ior 1: the ray goes on unchanged either way
    assert fresnel_dielectric(0.0, 0.5)[0] == 1.0  # grazing: everything reflects
    assert fresnel_dielectric(1.0, 1.5)[0] == pytest.approx(0.04, abs=1e-15)
    assert fresnel_dielectric(math.cos(math.asin(1 / 1.5)) - 1e-12, 1.5) == (1.0, 0.0)  # past the critical angle


@pytest.mark.parametrize("degrees", [41.9, 60.0, 89.99])
def test_total_internal_reflection_reflects_every_ray(degrees):
    """Inside glass of ior 1.5 beyond the critical angle (41.81 degrees) nothing refracts."""
    theta = math.radians(degrees)
    d = np.array([math.sin(theta), 0.0, -math.cos(theta)])
    n = np.array([0.0, 0.0, 1.0])  # the normal on the side the ray comes from (inside)
    out = scatter_many(DIELECTRIC, 0.0, 1.5, d, n, False, 11, 20_000, 0)
    mirror = np.array(reflect(tuple(d), tuple(n)))
    assert np.abs(out - mirror).max() <= 1e-15  # (the kernel normalises d first: an ulp of difference)


def test_refraction_just_below_the_critical_angle_obeys_snell():
    theta = math.radians(41.5)
    d = np.array([math.sin(theta), 0.0, -math.cos(theta)])
    out = scatter_many(DIELECTRIC, 0.0, 1.5, d, np.array([0.0, 0.0, 1.0]), False, 12, 20_000, 0)
    refracted = out[out[:, 2] < 0]
    assert len(refracted) > 0 and len(refracted) < len(out)  # both happen near the critical angle
    assert np.allclose(np.linalg.norm(refracted, axis=1), 1.0, atol=1e-12)
    assert np.allclose(refracted[:, 0], 1.5 * math.sin(theta), atol=1e-12)  # tangential part scaled by eta
    assert np.all(refracted[:, 1] == 0.0)


def behind_scene(extra, seed, samples):
    """A sky and a checkered wall behind the origin, seen from +z; `extra` shapes in front of it."""
    wall = m.Quad(q=(-4, -3, -2), u=(8, 0, 0), v=(0, 6, 0),
                  material=m.Lambertian(albedo=m.CheckerTexture(scale=0.4, even=(0.9, 0.1, 0.1), odd=(0.1, 0.1, 0.9))))
    return render_scene([wall] + extra, look_from=(0, 0.3, 4), look_at=(0, 0, 0), vfov=35, background=m.SkyBackground(),
                        width=16, height=16, samples=samples, max_depth=50, seed=seed)


@pytest.fixture(scope="module")
def empty_wall():
    return behind_scene([], seed=1, samples=256)


@pytest.mark.parametrize("ior, vanishes", [(1.0, True), (1.3, False)])
def test_a_sphere_of_ior_one_vanishes(empty_wall, ior, vanishes):
    """ior 1: no reflection and no bending, so the image is the scene without the sphere.

    Every 4x4 block mean, per channel, within a Bonferroni z bound of the empty scene's
    (independent seeds). A weak lens (ior 1.3) must fail the same comparison, which shows the
    check can see a sphere; Schlick's approximation failed it at ior 1 with its bright rim.
    """
    with_sphere = behind_scene([m.Sphere(center=(0, 0, 0), radius=1.0, material=m.Dielectric(ior=ior))], seed=2, samples=256)
    assert with_sphere.stats.bad_samples == 0
    z = block_z(with_sphere.film, empty_wall.film)
    assert bool(np.all(np.abs(z) <= z_limit(z.size))) == vanishes, np.abs(z).max()


AXIS_CAMERA = dict(look_from=(0, 0, 10), look_at=(0, 0, 0), vfov=0.5, background=BLACK, width=4, height=4,
                   samples=4096, max_depth=100, seed=3)


def axis_light():
    """A large emitter of radiance 1 behind the origin, facing the camera on the +z axis."""
    return m.Quad(q=(-50, -50, -5), u=(100, 0, 0), v=(0, 100, 0), material=m.DiffuseLight(emit=WHITE))


@pytest.mark.parametrize("ior", [1.5, 2.4])
def test_glass_sphere_transmits_along_its_axis(ior):
    """Near the axis every interface is met at normal incidence with R = ((n-1)/(n+1))^2; light
    that reflects goes back to the black sky. Two interfaces pass (1 - R) / (1 + R) of it."""
    R = ((ior - 1) / (ior + 1)) ** 2
    result = render_scene([axis_light(), m.Sphere(center=(0, 0, 0), radius=1, material=m.Dielectric(ior=ior))], **AXIS_CAMERA)
    assert result.stats.bad_samples == 0
    assert_binomial(result.film, (1 - R) / (1 + R))


def test_hollow_bubble_sphere_transmits_along_its_axis():
    """Glass (1.5) with an air bubble (a sphere of ior 1/1.5 inside it): four interfaces with the
    same R = 0.04 pass (1 - R) / (1 + 3 R) of the light (incoherent sum of all inner reflections)."""
    R = 0.04
    shapes = [axis_light(), m.Sphere(center=(0, 0, 0), radius=1, material=m.Dielectric(ior=1.5)),
              m.Sphere(center=(0, 0, 0), radius=0.8, material=m.Dielectric(ior=1 / 1.5))]
    result = render_scene(shapes, **AXIS_CAMERA)
    assert result.stats.bad_samples == 0
    assert_binomial(result.film, (1 - R) / (1 + 3 * R))


def sky_value(d, bottom, top):
    a = 0.5 * (d[..., 1:2] + 1.0)
    return (1 - a) * np.asarray(bottom) + a * np.asarray(top)


def test_camera_inside_a_glass_sphere():
    """From the centre every ray meets the sphere at normal incidence: it leaves unbent with
    probability 1 - R, else crosses back through the centre, so L(d) = (sky(d) + R sky(-d)) / (1 + R)."""
    bottom, top = (1.0, 0.2, 0.0), (0.1, 0.3, 1.0)
    sc = scene([m.Sphere(center=(0, 0, 0), radius=1, material=m.Dielectric(ior=1.5))], look_from=(0, 0, 0),
               look_at=(0, 0.2, -1), vfov=100, background=m.SkyBackground(bottom=bottom, top=top), width=8, height=8,
               samples=1024, max_depth=100, seed=4)
    result = render(build_graph(sc), features=GENERAL)
    assert result.stats.bad_samples == 0
    R = 0.04
    _, d = pixel_rays(sc, sub=16)
    expected = ((sky_value(d, bottom, top) + R * sky_value(-d, bottom, top)) / (1 + R)).mean(axis=2)
    limit = z_limit(expected.size)
    for c in range(3):
        mean, se = pixel_mean_and_se(result.film, c)
        assert np.all(np.abs(mean - expected[..., c]) <= limit * se + 1e-12), (c, np.abs((mean - expected[..., c]) / se).max())
    # The check can fail: without the inner reflections (R = 0) the expected image is off.
    mean, se = pixel_mean_and_se(result.film, 2)
    assert not np.all(np.abs(mean - sky_value(d, bottom, top).mean(axis=2)[..., 2]) <= limit * se)


def test_medium_inside_a_dielectric_seen_from_its_centre():
    """Absorbing fog (albedo 0, density s) inside glass, camera at the centre, white sky: each
    crossing of the radius passes T = e^(-s r), each interface R, so the light reaching the camera
    is (1 - R) T / (1 - R T^2) (a geometric series of crossings back through the centre)."""
    s, r, R = 0.7, 1.0, 0.04
    T = math.exp(-s * r)
    shapes = [m.Sphere(center=(0, 0, 0), radius=r, material=m.Dielectric(ior=1.5),
                       interior=m.ConstantMedium(density=s, albedo=BLACK))]
    result = render_scene(shapes, look_from=(0, 0, 0), look_at=(0, 0, -1), vfov=90, width=8, height=8, samples=1024,
                          max_depth=100, seed=5)
    assert result.stats.bad_samples == 0
    assert_binomial(result.film, (1 - R) * T / (1 - R * T * T))


# --- media ------------------------------------------------------------------------------------


@pytest.mark.parametrize("density", [0.7, 1e-6, 1e3])
def test_camera_inside_a_medium(density):
    """From the centre of an absorbing sphere of fog every ray crosses r of it: Beer-Lambert
    transmittance e^(-density r) (0 to double precision at density 1e3, 1 - 1e-6 at 1e-6)."""
    shapes = [m.Sphere(center=(0, 0, 0), radius=1.0, interior=m.ConstantMedium(density=density, albedo=BLACK))]
    result = render_scene(shapes, look_from=(0, 0, 0), look_at=(0, 0, -1), vfov=90, width=8, height=8, samples=1024,
                          max_depth=10, seed=6)
    assert result.stats.bad_samples == 0
    assert_binomial(result.film, math.exp(-density))


@pytest.mark.parametrize("density", [1e-6, 1e3])
def test_extreme_densities_seen_from_outside(density):
    """An absorbing fog box in front of a white sky transmits e^(-density chord) along each ray:
    at 1e-6 it is invisible but for binomially rare scatterings, at 1e3 black wherever it
    covers a pixel. Chords come from the pixels' footprints by quadrature (corners included)."""
    box = m.Box(min=(-1, -1, -1), max=(1, 1, 1), interior=m.ConstantMedium(density=density, albedo=BLACK))
    sc = scene([box], look_from=(0, 0, 6), look_at=(0, 0, 0), vfov=30, width=16, height=16, samples=64, max_depth=10,
               seed=7)
    result = render(build_graph(sc), features=GENERAL)
    assert result.stats.bad_samples == 0
    origin, d = pixel_rays(sc, sub=9, corners=True)

    def chords(lo, hi):
        """Length of each grid ray inside the box [lo, hi] (slab test; the camera is outside)."""
        with np.errstate(divide="ignore"):
            t0, t1 = (lo - origin) / d, (hi - origin) / d
        return np.maximum(np.maximum(t0, t1).min(axis=-1) - np.minimum(t0, t1).max(axis=-1), 0.0)

    chord = chords(np.full(3, -1.0), np.full(3, 1.0))
    if density < 1:
        # The samples are Bernoulli with per-pixel means T; the pooled count is then at most as
        # spread as Binomial(N, mean T), so the binomial test is conservative.
        assert_binomial(result.film, float(np.exp(-density * chord).mean()))
    else:
        image = result.film.mean()[..., 0]
        # Chord length is concave over a convex body's silhouette, so corners >= 0.05 bound the
        # whole footprint: T < e^-50 there. A pixel whose grid misses a box grown by 0.05 (more
        # than the grid's spacing at the box, 0.02) misses the box.
        covered = (chord > 0.05).all(axis=-1)
        missed = (chords(np.full(3, -1.05), np.full(3, 1.05)) == 0).all(axis=-1)
        assert covered.sum() > 20 and missed.sum() > 20
        assert np.all(image[covered] == 0.0) and np.all(image[missed] == 1.0)


def medium_probe(flat, o, d):
    t, prim, *_ = probe_rays(flat, np.array([o], float), np.array([d], float), 0.0, 0.0, False)
    return t[0]


def test_rays_tangent_to_a_medium_boundary():
    """A line touching a fog sphere at one point crosses none of it; a ray lying in a face of a fog
    box is inside it (the box is closed) and scatters exactly where a ray just inside does."""
    # Densities high enough that a ray crossing a unit of fog scatters in it (but for e^-50).
    sphere = compile_scene(build_graph(m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=1.0,
                                                                   interior=m.ConstantMedium(density=50.0))])))
    assert medium_probe(sphere, (-3, 1, 0), (1, 0, 0)) == math.inf  # tangent
    assert medium_probe(sphere, (-3, 1 + 1e-12, 0), (1, 0, 0)) == math.inf  # just outside
    grazing = medium_probe(sphere, (-3, 1 - 1e-12, 0), (1, 0, 0))  # a chord of 3e-6: almost never scatters
    assert grazing == math.inf or 2.99 < grazing < 3.01
    assert 2.0 <= medium_probe(sphere, (-3, 0, 0), (1, 0, 0)) < 4.0  # through the middle: scatters inside
    box = compile_scene(build_graph(m.Scene(shapes=[m.Box(min=(0, 0, 0), max=(1, 1, 1),
                                                          interior=m.ConstantMedium(density=50.0))])))
    in_face = medium_probe(box, (-1, 1, 0.5), (1, 0, 0))
    just_inside = medium_probe(box, (-1, 1 - 1e-9, 0.5), (1, 0, 0))
    assert 1.0 <= in_face < 2.0 and in_face == pytest.approx(just_inside, abs=1e-12)
    assert medium_probe(box, (-1, 1 + 1e-9, 0.5), (1, 0, 0)) == math.inf
    along_edge = medium_probe(box, (-1, 1, 1), (1, 0, 0))
    assert along_edge == pytest.approx(in_face, abs=1e-12)  # the edge belongs to the box as well
    assert medium_probe(box, (0.5, 2, 1), (0, -1, -1)) == math.inf  # touches the edge (0.5, 1, 0) only: no length
    assert medium_probe(box, (0.5, 2, -1), (0, -1, 1)) < 2.0  # from edge to edge, through the inside


# --- surfaces ---------------------------------------------------------------------------------


def test_lambertian_direction_that_cancels_the_normal():
    for n in [(0.0, 0.0, 1.0), (0.6, 0.0, -0.8), tuple(np.array([1.0, -2.0, 3.0]) / math.sqrt(14.0))]:
        assert lambertian_direction(n, tuple(-x for x in n)) == n
        nearly = tuple(-x + 3e-9 for x in n)
        assert lambertian_direction(n, nearly) == n
    # On the renderer's own draws: never zero, never below the surface.
    n = np.array([0.0, 1.0, 0.0])
    out = scatter_many(LAMBERTIAN, 0.0, 1.0, np.array([0.3, -1.0, 0.0]), n, True, 13, 100_000, 0)
    assert (out @ n >= 0).all() and (np.abs(out).max(axis=1) > 0).all()


def test_metal_fuzz_below_the_surface_is_mirrored_above_it():
    n = (0.0, 1.0, 0.0)
    d = (1.0, -0.01, 0.0)  # grazing
    mirror = np.array(reflect(d, n)) / math.hypot(1.0, 0.01)
    out = metal_direction(d, n, 1.0, (0.0, -1.0, 0.0))  # pushed straight down, below the surface
    assert out == pytest.approx((mirror[0], 1.0 - mirror[1], 0.0), abs=1e-15)
    assert metal_direction(d, n, 0.0, (0.0, 0.0, 0.0)) == pytest.approx(tuple(mirror), abs=1e-15)
    # Exactly in the tangent plane: the unfuzzed mirror direction.
    tangent = metal_direction(d, n, 1.0, (0.0, -mirror[1], 0.0))
    assert tangent == pytest.approx(tuple(mirror), abs=1e-15)
    # Every fuzzed direction is above the surface, and is the fuzzed one or its mirror image.
    for fuzz in (0.3, 1.0):
        for r in unit_vectors(14, 20_000, 0)[::7]:
            out = np.array(metal_direction(d, n, fuzz, tuple(r)))
            raw = mirror + fuzz * r
            assert out[1] > 0
            assert np.allclose(out, raw if raw[1] > 0 else raw * (1, -1, 1), atol=1e-15)


def test_sphere_uv_at_the_poles_and_the_seam():
    """Poles: v is 0 or 1 and u is finite in [0, 1] (any u names the pole). Seam (-x): u is 0 or 1
    by the sign of zero, both in range; points either side of the seam get u near 0 and near 1."""
    for n, v in [((0.0, 1.0, 0.0), 1.0), ((0.0, -1.0, 0.0), 0.0), ((0.0, 1.0000000000000002, 0.0), 1.0),
                 ((1e-300, -1.0, -1e-300), 0.0)]:
        u, vv = sphere_uv(n)
        assert vv == v and 0.0 <= u <= 1.0
    for z in (0.0, -0.0):
        u, v = sphere_uv((-1.0, 0.0, z))
        assert u in (0.0, 1.0) and v == 0.5
    assert sphere_uv((-1.0, 0.0, 1e-9))[0] < 1e-9 and sphere_uv((-1.0, 0.0, -1e-9))[0] > 1 - 1e-9
    # Through the kernels: rays at the poles and across the seam of a rotated, moved sphere.
    steps = [m.RotateStep(rotate=m.Rotation(axis=(1, 1, 0), degrees=70)), m.TranslateStep(translate=(0.5, -0.2, 0.1))]
    flat = compile_scene(build_graph(m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=1.0, material=m.Lambertian(),
                                                              transform=steps)])))
    from scenefmt import affine
    world = affine.from_steps(steps)
    targets = [(0, 1, 0), (0, -1, 0), (-1, 0, 0), (-1, 0, 1e-12), (-1, 0, -1e-12), (-1, 1e-9, 0)]
    for p_obj, (u_ref, v_ref) in zip(targets, [(None, 1.0), (None, 0.0), (None, 0.5), (0.0, 0.5), (1.0, 0.5), (None, 0.5)]):
        p = np.array(naive.apply(world, naive.unit(p_obj)))
        normal = np.array(naive.apply_linear(world, naive.unit(p_obj)))
        o = p + 3 * normal
        t, prim, _, hit, nn, uv = probe_rays(flat, o[None], -normal[None], 0.0, 0.0, False)
        assert prim[0] >= 0 and np.isfinite(uv).all()
        assert 0.0 <= uv[0, 0] <= 1.0 and uv[0, 1] == pytest.approx(v_ref, abs=1e-7)
        if u_ref is not None:
            assert uv[0, 0] == pytest.approx(u_ref, abs=1e-6)


def image_flat(tmp_path):
    from PIL import Image

    pixels = np.array([[[10, 0, 0], [20, 0, 0], [30, 0, 0]], [[40, 0, 0], [50, 0, 0], [60, 0, 0]]], np.uint8)  # 3 x 2
    Image.fromarray(pixels, "RGB").save(tmp_path / "tex.png")
    tex = m.ImageTexture(file=str(tmp_path / "tex.png"), colorspace="linear")
    return compile_scene(build_graph(m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=1, material=m.Lambertian(albedo=tex))])))


def test_image_texture_at_its_edges(tmp_path):
    """u = 1 and v = 1 fall in the last column and the top row (clamped, never one past the end);
    values outside [0, 1] clamp to the edge."""
    flat = image_flat(tmp_path)
    uv = np.array([[0, 0], [1, 1], [1, 0], [0, 1], [0.5, 0.5], [1 - 1e-16, 1 - 1e-16], [1 + 1e-9, -1e-9], [-5, 7],
                   [2 / 3, 0.5], [1 / 3 - 1e-12, 0.5]], float)
    got = np.rint(texture_at(flat, 0, uv, np.zeros((len(uv), 3)))[:, 0] * 255).astype(int).tolist()
    # Top row (v = 1): 10 20 30; bottom row (v = 0): 40 50 60.
    assert got == [40, 30, 60, 10, 50, 30, 60, 10, 60, 40]


def test_checker_across_negative_coordinates():
    """The parity of floor(x/s) + floor(y/s) + floor(z/s), with floor (not truncation) on both sides of 0."""
    chk = m.CheckerTexture(scale=0.32, even=(1.0, 1.0, 1.0), odd=(0.0, 0.0, 0.0))
    flat = compile_scene(build_graph(m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=1, material=m.Lambertian(albedo=chk))])))
    tex = int(flat.mat_i[0, 1])
    book = np.array([[0.1, 0.1, 0.1], [-0.1, 0.1, 0.1], [-0.1, -0.1, 0.1], [-0.1, -0.1, -0.1]])
    assert texture_at(flat, tex, np.zeros((4, 2)), book)[:, 0].tolist() == [1.0, 0.0, 1.0, 0.0]  # the books' facts
    rng = np.random.default_rng(15)
    p = rng.uniform(-5, 5, (5000, 3)) * rng.choice([1e-3, 1, 1e4], (5000, 1))
    cell = np.floor(p / 0.32)
    keep = (np.abs(p / 0.32 - np.rint(p / 0.32)) > 1e-9).all(axis=1)  # not on a cell boundary
    even = (cell.sum(axis=1) % 2 == 0)
    got = texture_at(flat, tex, np.zeros((len(p), 2)), p)[:, 0]
    assert np.array_equal(got[keep] == 1.0, even[keep])
    assert (p[keep] < 0).any(axis=1).sum() > 1000


def perlin_reference(perm, vec, x, y, z, floor=math.floor):
    """Perlin's gradient noise in plain Python (Hermite smoothing once, as the kernel); `floor` picks the lattice cell."""
    i, j, k = floor(x), floor(y), floor(z)
    u, v, w = x - i, y - j, z - k
    uu, vv, ww = (t * t * (3 - 2 * t) for t in (u, v, w))
    total = 0.0
    for di in (0, 1):
        for dj in (0, 1):
            for dk in (0, 1):
                g = vec[perm[0, (i + di) & 255] ^ perm[1, (j + dj) & 255] ^ perm[2, (k + dk) & 255]]
                weight = (uu if di else 1 - uu) * (vv if dj else 1 - vv) * (ww if dk else 1 - ww)
                total += weight * (g[0] * (u - di) + g[1] * (v - dj) + g[2] * (w - dk))
    return total


# Each of the 8 corner terms is s(u) s(v) s(w) (g . delta) with |s'| <= 3/2, |g| = 1 and
# |delta| <= sqrt(3), so its derivative along an axis is at most 1.5 sqrt(3) + 1 < 3.6, and the
# noise is Lipschitz with constant 8 * 3.6 < 29 along each axis.
PERLIN_LIPSCHITZ = 29.0


def test_perlin_noise_is_continuous_across_lattice_cells():
    perm, vec = perlin_tables(3)
    rng = np.random.default_rng(16)
    delta = 1e-9
    planes = np.concatenate([np.arange(-300, 301), [-256, 255, 256, 511, -257]])
    worst = 0.0
    for k in planes:
        for axis in range(3):
            base = rng.uniform(-300, 300, 3)
            lo, hi = base.copy(), base.copy()
            lo[axis], hi[axis] = k - delta, k + delta
            jump = abs(perlin(perm[None], vec[None], 0, *hi) - perlin(perm[None], vec[None], 0, *lo))
            worst = max(worst, jump)
    assert worst <= PERLIN_LIPSCHITZ * 2 * delta + 1e-15
    # The kernel equals the plain reference; the reference with truncation in place of floor
    # (a classic bug) jumps at the lattice planes left of 0, which the same check would catch.
    x, y, z = -2.0 - delta, 0.37, -5.6
    assert perlin(perm[None], vec[None], 0, x, y, z) == pytest.approx(perlin_reference(perm, vec, x, y, z), abs=1e-14)
    broken = abs(perlin_reference(perm, vec, -2.0 + delta, 0.37, 0.8, floor=int)
                 - perlin_reference(perm, vec, -2.0 - delta, 0.37, 0.8, floor=int))
    assert broken > PERLIN_LIPSCHITZ * 2 * delta


@pytest.mark.parametrize("form", ["plain", "turbulence", "marble"])
def test_noise_textures_are_continuous_and_in_range(form):
    tex = m.NoiseTexture(scale=4.0, form=form, color=WHITE)
    flat = compile_scene(build_graph(m.Scene(shapes=[m.Sphere(center=(0, 0, 0), radius=1, material=m.Lambertian(albedo=tex))])))
    t = int(flat.mat_i[0, 1])
    rng = np.random.default_rng(17)
    # Points on lattice planes of the scaled coordinates, in all octaves (2^k s p integral), and either side.
    p = rng.uniform(-70, 70, (3000, 3))
    p[:, 0] = np.round(p[:, 0] * 4) / 4
    delta = 1e-10
    lo, hi = p.copy(), p.copy()
    lo[:, 0] -= delta
    hi[:, 0] += delta
    a = texture_at(flat, t, np.zeros((len(p), 2)), lo)[:, 0]
    b = texture_at(flat, t, np.zeros((len(p), 2)), hi)[:, 0]
    assert np.isfinite(a).all() and (a >= 0).all()
    if form != "turbulence":
        assert (a <= 1).all()
    # Lipschitz bounds from PERLIN_LIPSCHITZ = L: plain 0.5 s L; turbulence sums 7 octaves of weight
    # 2^-k at frequency 2^k s, so 7 s L; marble is sin(s z + 10 turb(p)) with turbulence at scale 1.
    scale = 4.0
    bound = {"plain": 0.5 * scale, "turbulence": 7 * scale, "marble": scale / PERLIN_LIPSCHITZ + 10 * 7}[form] * PERLIN_LIPSCHITZ
    assert np.abs(a - b).max() <= bound * 2 * delta + 1e-13
