"""Light sampling: each emitter's sampler against its density, and the integrator that uses them.

For every kind of emitter the format can express (quad, triangle, disk, box, a sphere seen from
outside and from inside, an ellipsoid, a smooth mesh, an emitter inside a rotated and scaled instance, a moving
sphere at a chosen time, a textured emitter), directions drawn by `lights.sample_li` from a
fixed point are binned on a grid of (1 - cos theta, phi) about the axis to the light, and the
counts are tested (chi-square, as tests/renderer/test_sampling.py does for BSDFs) against the
probabilities found by integrating `lights.pdf_li` over each cell: 32 x 32 directions a
cell, each traced to the light. The integral over all cells must be 1: the density is a density.
"""

import math

import numpy as np
import pytest

from renderer.compile import compile_scene, with_integrator
from renderer.trees import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED
from renderer.numerics.vec import xform_point
from renderer.lights import BY_RECTANGLE, LIGHT_EDGE_U, LIGHT_EDGE_V, LIGHT_INSTANCE, LIGHT_PRIMITIVE, LIGHT_STRATEGY
from renderer.shapes.planar import PLANAR_CORNER, SMALL_RECTANGLE, rectangle_frame, rectangle_is_near
from renderer.render import render
from scenefmt.validation import loads
from tests.renderer.kernel_calls import light_pdf_along, light_samples, segment_transmittance
from tests.renderer.stats import ALPHA, chi2_test, film_mean_and_se, z_limit

# Runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

N = 100_000
CELLS = 20
SUB = 32

LIGHT = "materials: {lamp: {type: diffuse_light, emit: [4, 3, 2]}, white: {type: lambertian, albedo: [0.8, 0.8, 0.8]}}\n"

# (name, shapes and groups YAML, shading point, time)
CASES = [
    ("quad", "shapes: [{type: quad, q: [-1, 2, -0.5], u: [2, 0, 0], v: [0, 0.5, 1], material: lamp}]", (0.2, 0.0, 0.1), 0.0),
    ("parallelogram", "shapes: [{type: quad, q: [-1, 2, -0.5], u: [2, 0, 0], v: [0.6, 0.4, 1], material: lamp}]", (0.2, 0.0, 0.1), 0.0),
    ("close rectangle", "shapes: [{type: quad, q: [-3, 0.05, -2], u: [6, 0, 0], v: [0, 0, 4], material: lamp}]", (0.3, 0.0, 0.2), 0.0),
    # Beyond planar.FAR_RECTANGLE times its edges from its centre: sampled by area.
    ("far rectangle", "shapes: [{type: quad, q: [-0.5, 6, -0.4], u: [1, 0, 0], v: [0, 0.3, 0.8], material: lamp}]", (0.2, 0.0, 0.1), 0.0),
    # Within planar.FAR_RECTANGLE times its edges (1.6 from its centre, in the group's frame, against
    # 1.75): the spherical rectangle, through an instance's similarity.
    ("rotated rectangle", "groups: {panel: {shapes: [{type: quad, q: [-1, 0, -1], u: [2, 0, 0], v: [0, 0, 1.5], material: lamp}]}}\n"
     "shapes: [{type: instance, group: panel, transform: [{scale: 0.8}, {rotate: {axis: [1, 0, 1], degrees: 150}}, {translate: [0.3, 1.2, 0]}]}]",
     (0.0, 0.0, 0.0), 0.0),
    ("triangle", "shapes: [{type: triangle, vertices: [[-1, 2, 0], [1.5, 2.5, 0.3], [0, 1.8, 1.2]], material: lamp}]", (0.0, 0.0, 0.0), 0.0),
    ("disk", "shapes: [{type: disk, center: [0.3, 2, 0], normal: [0.2, -1, 0.3], radius: 0.8, material: lamp}]", (0.0, 0.0, 0.0), 0.0),
    ("box", "shapes: [{type: box, min: [-0.5, 1.5, -0.4], max: [0.7, 2.2, 0.6], material: lamp}]", (0.1, 0.0, 0.2), 0.0),
    ("sphere outside", "shapes: [{type: sphere, center: [0.2, 3, 0.1], radius: 0.9, material: lamp}]", (0.0, 0.0, 0.0), 0.0),
    ("small far sphere", "shapes: [{type: sphere, center: [0.0, 300, 40], radius: 0.5, material: lamp}]", (0.0, 0.0, 0.0), 0.0),
    ("sphere inside", "shapes: [{type: sphere, center: [0.2, 0.3, 0.1], radius: 2.0, material: lamp}]", (0.0, 0.0, 0.0), 0.0),
    ("ellipsoid", "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: lamp, transform: [{scale: [1.5, 0.5, 0.8]}, {rotate: {axis: [1, 1, 0], degrees: 30}}, {translate: [0, 2.5, 0]}]}]", (0.0, 0.0, 0.0), 0.0),
    ("instanced quad", "groups: {panel: {shapes: [{type: quad, q: [-1, 0, -1], u: [2, 0, 0], v: [0, 0, 2], material: lamp}]}}\n"
     "shapes: [{type: instance, group: panel, transform: [{scale: [0.7, 1, 1.3]}, {rotate: {axis: [0, 0, 1], degrees: 160}}, {translate: [0.3, 2, 0]}]}]",
     (0.0, 0.0, 0.0), 0.0),
    ("mesh", "shapes: [{type: mesh, smooth: true, vertices: [[-1, 2, -1], [1, 2.4, -1], [1, 2, 1], [-1, 2.6, 1], [0, 3, 0]],"
     " faces: [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], material: lamp, transform: [{rotate: {axis: [1, 0, 0], degrees: 180}}, {translate: [0, 5, 0]}]}]",
     (0.1, 0.0, 0.2), 0.0),
    ("moving sphere", "shutter: {open: 0, close: 1}\nshapes: [{type: moving_sphere, center0: [0, 2, 0], center1: [1, 2.5, 0], radius: 0.6, material: lamp}]",
     (0.0, 0.0, 0.0), 0.7),
]


# Which of sample_li's ways each rectangle is drawn from its shading point: True, near enough
# (planar.rectangle_is_near) to be drawn uniform in the solid angle it subtends; False, by area.
RECTANGLE_NEAR = {"quad": False, "close rectangle": True, "far rectangle": False, "rotated rectangle": True}


def flat_of(text: str, width: int = 8):
    graph = loads(LIGHT + "camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\nimage: {width: %d, aspect_ratio: 1}\n" % width + text).graph
    return compile_scene(graph)


@pytest.mark.parametrize("name, near", RECTANGLE_NEAR.items(), ids=list(RECTANGLE_NEAR))
def test_each_rectangle_is_sampled_the_way_its_case_is_meant_to_test(name, near):
    """The rectangle cases reach the sampler they are there for: the spherical rectangle for the
    near ones, the rotated one through its instance's transform, and sampling by area for the far ones."""
    _, shapes, point, _ = next(c for c in CASES if c[0] == name)
    flat = flat_of(shapes)
    assert len(flat.light_i) == 1 and flat.light_i[0, LIGHT_STRATEGY] == BY_RECTANGLE
    inst, prim = flat.light_i[0, LIGHT_INSTANCE], flat.light_i[0, LIGHT_PRIMITIVE]
    moved = flat.inst_i[inst, INST_UNTRANSFORMED] != 1
    assert moved == (name == "rotated rectangle")
    p = tuple(float(x) for x in point)
    p_tree = xform_point(flat.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
    q = tuple(float(x) for x in flat.prims_f[prim, PLANAR_CORNER:PLANAR_CORNER + 3])
    eu = tuple(float(x) for x in flat.light_f[0, LIGHT_EDGE_U:LIGHT_EDGE_U + 3])
    ev = tuple(float(x) for x in flat.light_f[0, LIGHT_EDGE_V:LIGHT_EDGE_V + 3])
    assert rectangle_is_near(q, eu, ev, p_tree) == near
    if near:
        assert rectangle_frame(q, eu, ev, p_tree)[8] > SMALL_RECTANGLE  # not too small a solid angle to use


def direction_grid(axis, cos_bound):
    """The cell of each of CELLS x CELLS x SUB x SUB directions about `axis` out to angle acos(cos_bound),
    and each direction's solid angle."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(helper, axis)
    t /= np.linalg.norm(t)
    b = np.cross(axis, t)
    k = CELLS * SUB
    s = (np.arange(k) + 0.5) / k
    one_minus = s * (1.0 - cos_bound)
    phi = s * 2.0 * np.pi - np.pi
    om, ph = np.meshgrid(one_minus, phi, indexing="ij")
    z = 1.0 - om
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    dirs = (r * np.cos(ph))[..., None] * t + (r * np.sin(ph))[..., None] * b + z[..., None] * axis
    cell = (np.arange(k)[:, None] // SUB) * CELLS + (np.arange(k)[None, :] // SUB)
    d_omega = (1.0 - cos_bound) / k * 2.0 * np.pi / k
    return dirs.reshape(-1, 3), cell.ravel(), d_omega, (t, b, axis)


def cell_of(wi, frame, cos_bound):
    t, b, axis = frame
    z = wi @ axis
    phi = np.arctan2(wi @ b, wi @ t)
    i = np.clip(((1.0 - z) / (1.0 - cos_bound) * CELLS).astype(int), 0, CELLS)
    j = np.clip(((phi + np.pi) / (2.0 * np.pi) * CELLS).astype(int), 0, CELLS - 1)
    return np.where(i < CELLS, i * CELLS + j, -1)


@pytest.mark.parametrize("name, shapes, point, time", CASES, ids=[c[0] for c in CASES])
def test_sampled_directions_follow_the_light_pdf(name, shapes, point, time):
    flat = flat_of(shapes)
    p = np.array(point, float)
    draws = light_samples(flat, p, time, 7, N)
    ok = draws[:, 0] == 1.0
    assert ok.mean() > 0.999, f"{(~ok).sum()} draws refused"
    wi, pdf = draws[ok, 1:4], draws[ok, 5]
    assert np.all(np.isfinite(pdf)) and np.all(pdf > 0)
    # A point on the far side of a closed light (a box, an ellipsoid) is hidden by its near side:
    # its shadow ray is blocked and it adds nothing. For every visible point, the density the
    # draw reports is the one pdf_li gives the surface it points at: the sampler and the MIS
    # weight of a path that reaches the same point agree.
    visible = np.abs(draws[ok, 10] - draws[ok, 4]) <= 1e-6 * draws[ok, 4]
    if name not in ("box", "ellipsoid"):
        assert visible.all(), f"{(~visible).sum()} sampled points are hidden behind the light itself"
    # (To 1e-6, but for the odd point on the silhouette, where the traced hit's normal differs.)
    agree = np.abs(draws[ok, 9][visible] - pdf[visible]) <= 1e-6 * pdf[visible]
    assert agree.mean() > 0.9999, f"{(~agree).sum()} of {agree.size} densities differ"
    if name == "sphere inside":
        axis, cos_bound = (0.0, 1.0, 0.0), -1.0  # the whole sphere of directions
    else:
        axis = wi.mean(axis=0)
        lowest = float((wi @ (axis / np.linalg.norm(axis))).min())
        cos_bound = max(-1.0, lowest - 0.1 * (1.0 - lowest))
    dirs, cell, d_omega, frame = direction_grid(axis, cos_bound)
    density = light_pdf_along(flat, p, dirs, time)
    probs = np.bincount(cell, weights=density * d_omega, minlength=CELLS * CELLS)
    seen = probs.sum()
    if name in ("box", "ellipsoid"):
        assert 0.1 < seen < 0.9, f"{seen:.3f} of the draws should be visible"
    else:
        assert seen == pytest.approx(1.0, abs=0.01), "the density does not integrate to 1 over the light"
    p_value, dof = cell_test(wi[visible], cell, density, d_omega, frame, cos_bound)
    assert dof > 20 and p_value > ALPHA, f"chi-square p = {p_value:.2e} with {dof} degrees of freedom"


def cell_test(wi, cell, density, d_omega, frame, cos_bound):
    """Chi-square of the draws `wi` over the cells that lie wholly on the light and where its
    density is smooth (within a factor 1.5), where 32 x 32 points integrate it well; every
    other draw (edge cells, hidden points) goes to one pooled bin."""
    cells = CELLS * CELLS
    probs = np.bincount(cell, weights=density * d_omega, minlength=cells)
    hits = np.bincount(cell, weights=(density > 0).astype(float), minlength=cells)
    high, low = np.zeros(cells), np.full(cells, np.inf)
    np.maximum.at(high, cell, density)
    np.minimum.at(low, cell, density)
    inner = (hits == SUB * SUB) & (high <= 1.5 * low)
    counts = np.bincount(cell_of(wi, frame, cos_bound) % cells, minlength=cells)
    total = N  # every draw; those not in an inner cell are pooled
    observed = np.append(counts[inner], total - counts[inner].sum())
    expected = np.append(probs[inner], max(0.0, 1.0 - probs[inner].sum()))
    return chi2_test(observed, expected / expected.sum())


def test_a_wrong_density_is_caught():
    """Control: the same check rejects a sampler whose density is off by a smooth factor."""
    flat = flat_of(CASES[0][1])
    p = np.array(CASES[0][2], float)
    draws = light_samples(flat, p, 0.0, 7, N)
    wi = draws[:, 1:4]
    axis = wi.mean(axis=0)
    lowest = float((wi @ (axis / np.linalg.norm(axis))).min())
    cos_bound = lowest - 0.1 * (1.0 - lowest)
    dirs, cell, d_omega, frame = direction_grid(axis, cos_bound)
    # Up to 50% too dense at the rim of the cone the light fills.
    off_axis = (1.0 - dirs @ (axis / np.linalg.norm(axis))) / (1.0 - cos_bound)
    density = light_pdf_along(flat, p, dirs, 0.0) * (1.0 + 0.5 * off_axis)
    density /= np.sum(density) * d_omega
    assert cell_test(wi, cell, density, d_omega, frame, cos_bound)[0] < ALPHA


def test_lights_are_chosen_in_proportion_to_power():
    """Three lamps of powers 1 : 4 : 16 (area times emission): the choice follows the powers."""
    flat = flat_of(
        "shapes: [{type: quad, q: [-3, 2, 0], u: [1, 0, 0], v: [0, 0, 1], material: {type: diffuse_light, emit: [1, 1, 1]}},"
        " {type: quad, q: [0, 2, 0], u: [1, 0, 0], v: [0, 0, 1], material: {type: diffuse_light, emit: [4, 4, 4]}},"
        " {type: quad, q: [3, 2, 0], u: [2, 0, 0], v: [0, 0, 2], material: {type: diffuse_light, emit: [4, 4, 4]}}]"
    )
    np.testing.assert_allclose(sorted(flat.light_f[:, 1]), np.array([1, 4, 16]) / 21, rtol=1e-9)
    draws = light_samples(flat, np.zeros(3), 0.0, 3, 42_000)
    x = draws[:, 1] * draws[:, 4]  # the sampled point's x
    counts = np.array([(x < -1).sum(), ((x > -1) & (x < 2)).sum(), (x > 2).sum()])
    assert chi2_test(counts, np.array([1, 4, 16]) / 21)[0] > ALPHA


def test_shadow_rays_are_blocked_by_surfaces_and_attenuated_by_media():
    """exp(-density x length) through a medium, nested media add, and a surface blocks."""
    text = (
        "media: {fog: {type: constant, density: 0.5, albedo: [1, 1, 1]}, thick: {type: constant, density: 2.0, albedo: [1, 1, 1]}}\n"
        "shapes: [{type: sphere, center: [0, 0, 0], radius: 10, interior: fog},"
        " {type: box, min: [2, -1, -1], max: [3, 1, 1], interior: thick},"
        " {type: quad, q: [0, -1, 4], u: [1, 0, 0], v: [0, 2, 0], material: white},"
        " {type: quad, q: [0, 5, 0], u: [1, 0, 0], v: [0, 0, 1], material: lamp}]"
    )
    flat = flat_of(text)
    # Inside the fog (a camera inside a medium), 1.5 through it: exp(-0.75).
    assert segment_transmittance(flat, np.array([-2.0, 0, 0]), np.array([-0.5, 0, 0]), 0.0) == pytest.approx(math.exp(-0.75), rel=1e-9)
    # Through the box as well: 4 in fog (the box is inside it too) and 1 in the box.
    assert segment_transmittance(flat, np.array([0.0, 0, 0]), np.array([4.0, 0, 0]), 0.0) == pytest.approx(math.exp(-0.5 * 4 - 2.0), rel=1e-9)
    # Out of the fog: only the part inside counts.
    assert segment_transmittance(flat, np.array([5.0, 5, 0]), np.array([30.0, 5, 0]), 0.0) == pytest.approx(
        math.exp(-0.5 * (math.sqrt(75.0) - 5.0)), rel=1e-9)
    # A surface in the way.
    assert segment_transmittance(flat, np.array([0.5, 0, 3]), np.array([0.5, 0, 5]), 0.0) == 0.0
    # Grazing the fog's boundary: a tangent segment, finite and in [0, 1].
    t = segment_transmittance(flat, np.array([-5.0, 10, 0]), np.array([5.0, 10, 0]), 0.0)
    assert 0.0 <= t <= 1.0


def test_a_white_sphere_inside_a_lamp_of_radiance_one_is_one():
    """The furnace with light sampling on: a diffuse sphere of albedo 1 inside an emitting sphere of
    radiance 1 (sampled as a light, from inside) returns 1 within noise; the books' estimator
    returns exactly 1."""
    text = (
        "camera: {look_from: [0, 0, 3], look_at: [0, 0, 0], vfov: 50}\n"
        "image: {width: 16, aspect_ratio: 1, samples_per_pixel: 64, max_depth: 50}\n"
        "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: {type: lambertian, albedo: [1, 1, 1]}},"
        " {type: sphere, center: [0, 0, 0], radius: 20, material: {type: diffuse_light, emit: [1, 1, 1]}}]"
    )
    graph = loads(text).graph
    exact = render(with_integrator(graph, "path")).film.mean()
    assert np.all(np.abs(exact - 1.0) <= 1e-12)
    film = render(graph).film
    mean, se = film_mean_and_se(film, pooled=True)
    assert abs(mean - 1.0) <= z_limit(1) * se + 1e-12, f"mean {mean} differs from 1 by {abs(mean - 1) / se:.1f} standard errors"
    assert np.all(np.isfinite(film.mean()))


EDGE_CASES = """
camera: {look_from: [0, 1, 6], look_at: [0, 1, 0], vfov: 60}
image: {width: 24, aspect_ratio: 1, samples_per_pixel: 16, max_depth: 8}
media: {fog: {type: constant, density: 0.3, albedo: [0.9, 0.9, 0.9]}}
shapes:
  - {type: quad, q: [-3, 0, -3], u: [6, 0, 0], v: [0, 0, 6], material: white}
  # a lamp in the floor's plane, seen edge-on by every point of the floor
  - {type: quad, q: [-1, 0, -1], u: [1, 0, 0], v: [0, 0, 1], material: lamp}
  # a lamp touching a wall: shading points on the wall reach the lamp at its edge
  - {type: quad, q: [-3, 0, -3], u: [0, 3, 0], v: [0, 0, 6], material: white}
  - {type: quad, q: [-3, 2, -1], u: [0, 1, 0], v: [0, 0, 1], material: lamp}
  - {type: sphere, center: [1, 1, 0], radius: 0.5, material: lamp}
  # a medium whose boundary the shadow rays graze
  - {type: sphere, center: [1, 2, 0], radius: 0.5, interior: fog}
  - {type: disk, center: [0, 3, 0], normal: [0, -1, 0], radius: 0.5, material: lamp}
"""


def test_hard_light_configurations_give_finite_pixels():
    """Lights seen edge-on, shading points at a light's edge, shadow rays grazing a medium: no NaN or Inf."""
    result = render(loads(LIGHT + EDGE_CASES).graph)
    assert result.stats.bad_samples == 0
    assert np.all(np.isfinite(result.film.total)) and np.all(np.isfinite(result.film.total_sq))
