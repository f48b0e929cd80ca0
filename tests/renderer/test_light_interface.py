"""The shape sampling interface and the light category's: areas, surface samplers, sample_li
against pdf_li for every kind of light, and the one selection step.

- Each shape family's area (measured in numpy when flattening) agrees with a Monte Carlo
  estimate that uses only the intersection code: by Cauchy-Crofton, lines meeting a ball of
  radius R uniformly cross a surface of area A on average A / (2 pi R^2) times, so
  A = 2 pi R^2 E[crossings].
- Each family's surface sampler gives the density 1 / area, and its points are uniform by area
  (chi-square in coordinates where area is uniform); the sphere's cone sampler and the
  rectangle's solid angle are checked against their own densities too.
- `pdf_li` gives, for a point (or a direction at infinity) that `sample_li` drew, the density
  `sample_li` reported, for the map and every shape of area light, and `radiance_escaped` the
  map's alike.
- The selection's probabilities (the map's share, the rest by power) sum to 1, and
  `select_light` follows them.
"""

import ast
import math
import zlib
from pathlib import Path

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.lights import (AREA_LIGHT, ENVIRONMENT_LIGHT, LIGHT_AREA, LIGHT_CORNER, LIGHT_EDGE_U, LIGHT_EDGE_V, LIGHT_KIND,
                             LIGHT_PMF, LIGHT_PRIMITIVE)
from renderer.shapes import BOX, DISK, MESH_TRIANGLE, MOVING_SPHERE, PRIM_KIND, QUAD, SPHERE, TRIANGLE
from renderer.shapes.boxes import BOX_HI, BOX_LO
from renderer.shapes.planar import PLANAR_ALPHA, PLANAR_BETA, PLANAR_CORNER
from renderer.shapes.spheres import SPHERE_CENTER, SPHERE_RADIUS
from scenefmt.validation import loads
from tests.renderer.stats import ALPHA, chi2_test, z_limit

ROOT = Path(__file__).resolve().parents[2]
SKY = ROOT / "scenes" / "sky.pfm"
INTEGRATOR = ROOT / "renderer" / "tracing" / "integrator.py"

LAMP = "materials: {lamp: {type: diffuse_light, emit: [4, 3, 2]}, white: {type: lambertian, albedo: [0.8, 0.8, 0.8]}}\n"
CAMERA = "camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\nimage: {width: 8, aspect_ratio: 1}\n"

# One emitting shape of each family, as the file states it: (name, shapes YAML, expected area or None).
FAMILIES = [
    ("sphere", "{type: sphere, center: [0.2, 0.3, -0.1], radius: 0.7, material: lamp}", 4 * math.pi * 0.49),
    ("moving sphere", "{type: moving_sphere, center0: [0, 0, 0], center1: [0.5, 0, 0], radius: 0.6, material: lamp}",
     4 * math.pi * 0.36),
    ("quad", "{type: quad, q: [-0.5, -0.4, 0.1], u: [1.2, 0.1, 0], v: [0.3, 0.9, 0.4], material: lamp}", None),
    ("triangle", "{type: triangle, vertices: [[-0.6, -0.5, 0], [0.7, -0.2, 0.3], [0.1, 0.8, -0.4]], material: lamp}", None),
    ("disk", "{type: disk, center: [0.1, 0, 0.2], normal: [0.3, 1, -0.2], radius: 0.8, material: lamp}", math.pi * 0.64),
    ("box", "{type: box, min: [-0.5, -0.3, -0.4], max: [0.6, 0.5, 0.3], material: lamp}", 2 * (1.1 * 0.8 + 0.8 * 0.7 + 0.7 * 1.1)),
    ("mesh", "{type: mesh, vertices: [[-1, -0.5, -0.6], [0.9, -0.4, -0.5], [0, 0.9, -0.3], [0.1, -0.1, 0.8]],"
             " faces: [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]], material: lamp}", None),
]


def flat_of(shapes: str, background: str = ""):
    return compile_scene(loads(LAMP + CAMERA + background + f"shapes: [{shapes}]\n", allow_paths=[SKY.parent]).graph)


def area_rows(flat) -> np.ndarray:
    return np.flatnonzero(flat.light_i[:, LIGHT_KIND] == AREA_LIGHT)


def test_the_integrator_names_no_kind_of_light_and_no_map():
    """The integrator asks the light category; it does not know a map from a shape."""
    names = {n.id for n in ast.walk(ast.parse(INTEGRATOR.read_text())) if isinstance(n, ast.Name)}
    names |= {a.name for n in ast.walk(ast.parse(INTEGRATOR.read_text())) if isinstance(n, ast.ImportFrom) for a in n.names}
    kinds = {"ENVIRONMENT_LIGHT", "AREA_LIGHT", "POINT_LIGHT", "SPOT_LIGHT", "DIRECTIONAL_LIGHT", "SUN_LIGHT", "PUNCTUAL",
             "LIGHT_TREE", "choose", "env_nee", "env_map",
             "ENVIRONMENT", "LIGHTS"}
    environment = {"environment_radiance", "sample_environment", "ENV_CHOOSE", "BACKGROUND_IMAGE", "background", "sample_light",
                   "light_pdf"}
    assert not names & (kinds | environment), sorted(names & (kinds | environment))


def test_every_kind_of_light_has_its_own_code_and_name():
    import renderer.lights as lights

    codes = [lights.ENVIRONMENT_LIGHT, lights.AREA_LIGHT, lights.POINT_LIGHT, lights.SPOT_LIGHT, lights.DIRECTIONAL_LIGHT,
             lights.SUN_LIGHT]
    assert len(set(codes)) == len(codes) and set(lights.KINDS) == set(codes)


# --- shapes: areas and surface samplers -------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name, shape, exact", FAMILIES, ids=[f[0] for f in FAMILIES])
def test_each_family_measures_its_area_as_its_intersections_do(name, shape, exact):
    from tests.renderer.kernel_calls import line_crossings

    flat = flat_of(shape)
    rows = area_rows(flat)
    assert len(rows) >= 1 and (flat.inst_i[:, 1] == 1).all(), "baked into the world: tree space is world space"
    area = float(flat.light_f[rows, LIGHT_AREA].sum())
    if exact is not None:
        assert area == pytest.approx(exact, rel=1e-12)
    centre = np.zeros(3)
    radius = 2.0
    rng = np.random.default_rng(zlib.crc32(name.encode()))  # a fixed seed per case
    n = 400_000
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    # A point uniform in the disk of `radius` perpendicular to each direction.
    helper = np.where(np.abs(dirs[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(helper, dirs)
    t /= np.linalg.norm(t, axis=1)[:, None]
    b = np.cross(dirs, t)
    rr, phi = radius * np.sqrt(rng.random(n)), 2 * np.pi * rng.random(n)
    offsets = (rr * np.cos(phi))[:, None] * t + (rr * np.sin(phi))[:, None] * b
    crossings = line_crossings(flat, centre, radius, dirs, offsets).astype(float)
    estimate = 2 * np.pi * radius ** 2 * crossings.mean()
    se = 2 * np.pi * radius ** 2 * crossings.std() / math.sqrt(n)
    assert abs(estimate - area) <= z_limit(len(FAMILIES)) * se, f"area {area}, Monte Carlo {estimate} +- {se}"


def cells_of(flat, light, points, normals):
    """Each point's cell, and the cells' probabilities, for points uniform by area on area light
    `light`'s surface: coordinates in which area is uniform, on a grid."""
    prim = flat.light_i[light, LIGHT_PRIMITIVE]
    kind = flat.prims_i[prim, PRIM_KIND]
    k = 16
    if kind in (SPHERE, MOVING_SPHERE):
        c = flat.prims_f[prim, SPHERE_CENTER:SPHERE_CENTER + 3]
        rel = (points - c) / flat.prims_f[prim, SPHERE_RADIUS]
        a, b = (rel[:, 2] + 1) / 2, (np.arctan2(rel[:, 1], rel[:, 0]) + np.pi) / (2 * np.pi)
    elif kind == BOX:
        lo, hi = flat.prims_f[prim, BOX_LO:BOX_LO + 3], flat.prims_f[prim, BOX_HI:BOX_HI + 3]
        size = hi - lo
        axis = np.argmax(np.abs(normals), axis=1)
        side = (normals[np.arange(len(axis)), axis] > 0).astype(int)
        rel = (points - lo) / size
        a, b = rel[np.arange(len(axis)), (axis + 1) % 3], rel[np.arange(len(axis)), (axis + 2) % 3]
        face = axis * 2 + side
        cell = face * k * k + np.clip((a * k).astype(int), 0, k - 1) * k + np.clip((b * k).astype(int), 0, k - 1)
        faces = np.array([size[1] * size[2], size[2] * size[0], size[0] * size[1]])
        probs = np.repeat(np.repeat(faces, 2) / (2 * faces.sum()), k * k) / (k * k)
        return cell, probs
    else:
        if kind == MESH_TRIANGLE:
            q = flat.light_f[light, LIGHT_CORNER:LIGHT_CORNER + 3]
            eu, ev = flat.light_f[light, LIGHT_EDGE_U:LIGHT_EDGE_U + 3], flat.light_f[light, LIGHT_EDGE_V:LIGHT_EDGE_V + 3]
            coords = np.linalg.lstsq(np.stack([eu, ev], axis=1), (points - q).T, rcond=None)[0].T
            alpha, beta = coords[:, 0], coords[:, 1]
        else:
            rel = points - flat.prims_f[prim, PLANAR_CORNER:PLANAR_CORNER + 3]
            alpha, beta = rel @ flat.prims_f[prim, PLANAR_ALPHA:PLANAR_ALPHA + 3], rel @ flat.prims_f[prim, PLANAR_BETA:PLANAR_BETA + 3]
        if kind == QUAD:
            a, b = alpha, beta
        elif kind == DISK:
            a, b = alpha ** 2 + beta ** 2, (np.arctan2(beta, alpha) + np.pi) / (2 * np.pi)
        else:  # a triangle: (alpha + beta)^2 and beta / (alpha + beta) are uniform
            s = alpha + beta
            a, b = s * s, beta / np.where(s > 0, s, 1.0)
    assert a.min() >= -1e-9 and a.max() <= 1 + 1e-9 and b.min() >= -1e-9 and b.max() <= 1 + 1e-9
    cell = np.clip((a * k).astype(int), 0, k - 1) * k + np.clip((b * k).astype(int), 0, k - 1)
    return cell, np.full(k * k, 1.0 / (k * k))


@pytest.mark.slow
@pytest.mark.parametrize("name, shape, exact", FAMILIES, ids=[f[0] for f in FAMILIES])
def test_each_family_samples_its_surface_uniformly_with_density_one_over_its_area(name, shape, exact):
    from tests.renderer.kernel_calls import surface_samples

    flat = flat_of(shape)
    rng = np.random.default_rng(20240607)
    for light in area_rows(flat):
        draws = surface_samples(flat, light, rng.random((60_000, 2)), 0.0)
        assert np.all(draws[:, 6] == 1.0 / flat.light_f[light, LIGHT_AREA]), "the density is not 1 / area"
        assert np.allclose(np.linalg.norm(draws[:, 3:6], axis=1), 1.0)
        cell, probs = cells_of(flat, light, draws[:, :3], draws[:, 3:6])
        p_value, dof = chi2_test(np.bincount(cell, minlength=len(probs)), probs)
        assert dof > 100 and p_value > ALPHA / len(area_rows(flat)), f"chi-square p = {p_value:.2e}"


@pytest.mark.slow
def test_a_wrong_surface_density_is_caught():
    """Control: points crowded toward one corner of a quad fail the same check."""
    flat = flat_of(FAMILIES[2][1])
    from tests.renderer.kernel_calls import surface_samples

    us = np.random.default_rng(3).random((60_000, 2)) ** 1.1
    draws = surface_samples(flat, area_rows(flat)[0], us, 0.0)
    cell, probs = cells_of(flat, area_rows(flat)[0], draws[:, :3], draws[:, 3:6])
    assert chi2_test(np.bincount(cell, minlength=len(probs)), probs)[0] < ALPHA


@pytest.mark.slow
def test_the_cone_sampler_is_uniform_in_the_cone_with_its_density():
    """From outside a sphere: cos(theta) about the axis uniform in [cos theta_max, 1], the azimuth
    uniform, the density 1 / the cone's solid angle, and every point on the near side."""
    from tests.renderer.kernel_calls import cone_samples

    p, c, r = np.array([0.3, -0.2, 0.1]), np.array([1.0, 2.0, -0.5]), 0.8
    draws = cone_samples(p, c, r, np.random.default_rng(5).random((100_000, 2)))
    axis = (c - p) / np.linalg.norm(c - p)
    wi = draws[:, :3] - p
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    cos_max = math.sqrt(1 - r * r / np.sum((c - p) ** 2))
    assert np.allclose(draws[:, 6], 1 / (2 * math.pi * (1 - cos_max)), rtol=1e-9)
    assert np.allclose(np.linalg.norm(draws[:, :3] - c, axis=1), r)
    assert np.all(np.einsum("ij,ij->i", draws[:, 3:6], wi) <= 1e-9), "a point on the far side"
    t = np.cross([1.0, 0.0, 0.0], axis)
    t /= np.linalg.norm(t)
    b = np.cross(axis, t)
    a = (1 - wi @ axis) / (1 - cos_max)
    phi = (np.arctan2(wi @ b, wi @ t) + np.pi) / (2 * np.pi)
    cell = np.clip((a * 20).astype(int), 0, 19) * 20 + np.clip((phi * 20).astype(int), 0, 19)
    assert chi2_test(np.bincount(cell, minlength=400), np.full(400, 1 / 400))[0] > ALPHA


@pytest.mark.slow
def test_the_rectangle_solid_angle_agrees_with_an_integral_over_its_area():
    """The spherical rectangle's density is 1 / the solid angle it finds: that angle against
    A x mean(|cos| / d^2) over points uniform on the rectangle."""
    from tests.renderer.kernel_calls import rectangle_solid_angle

    q, eu, ev = np.array([-1.0, 0.5, -0.8]), np.array([2.0, 0.0, 0.0]), np.array([0.0, 0.6, 1.2])
    n = np.cross(eu, ev)
    area = np.linalg.norm(n)
    n /= area
    rng = np.random.default_rng(9)
    for p in (np.array([0.2, -0.3, 0.1]), np.array([0.0, 2.0, -1.0]), np.array([3.0, 0.1, 0.4])):
        uv = rng.random((400_000, 2))
        x = q + uv[:, :1] * eu + uv[:, 1:] * ev
        rel = x - p
        d2 = np.sum(rel * rel, axis=1)
        g = area * np.abs(rel @ n) / d2 ** 1.5
        solid = rectangle_solid_angle(q, eu, ev, p)
        assert abs(g.mean() - solid) <= z_limit(3) * g.std() / math.sqrt(len(g)), (solid, g.mean())


# --- the light category: sample_li against pdf_li, and the selection -------------------------

ALL_KINDS = (
    "{type: quad, q: [-0.5, 2.5, -0.5], u: [1, 0, 0], v: [0, 0, 1], material: lamp},"
    " {type: quad, q: [-3, 0.2, -2], u: [0.5, 0, 0], v: [0, 0.4, 0.3], material: lamp},"
    " {type: sphere, center: [1.5, 0.3, 0], radius: 0.3, material: lamp},"
    " {type: sphere, center: [0, 0, 0], radius: 0.25, material: lamp, transform: [{scale: [1, 2, 1]}, {translate: [0.8, 0.5, 1.2]}]},"
    " {type: disk, center: [-1.5, 1.5, 0], normal: [1, -1, 0], radius: 0.3, material: lamp},"
    " {type: triangle, vertices: [[0, 1.2, -1.5], [0.5, 1.2, -1.5], [0, 1.7, -1.5]], material: lamp},"
    " {type: box, min: [-1.2, 0.1, 0.6], max: [-0.8, 0.5, 1.0], material: lamp},"
    " {type: mesh, vertices: [[-1, 0.2, -1], [-0.6, 0.2, -1], [-0.8, 0.7, -1.2], [-0.8, 0.3, -0.6]],"
    " faces: [[0, 1, 2], [0, 3, 1], [1, 3, 2]], smooth: true, material: lamp}"
)
MAP = f"background: {{type: image, file: '{SKY}', strength: 0.5, rotate: 30}}\n"


@pytest.mark.slow
@pytest.mark.parametrize("with_map", [True, False], ids=["map and lamps", "lamps"])
def test_pdf_li_gives_what_sample_li_drew_for_every_kind(with_map):
    from tests.renderer.kernel_calls import li_and_pdf_li

    flat = flat_of(ALL_KINDS, MAP if with_map else "")
    kinds = flat.light_i[:, LIGHT_KIND]
    assert (kinds[0] == ENVIRONMENT_LIGHT) == with_map and (kinds[1:] == AREA_LIGHT).all()
    shapes = set(flat.prims_i[flat.light_i[area_rows(flat), LIGHT_PRIMITIVE], PRIM_KIND])
    assert {QUAD, SPHERE, DISK, TRIANGLE, BOX, MESH_TRIANGLE} <= shapes
    draws = li_and_pdf_li(flat, np.array([0.1, 0.0, 0.2]), 0.0, 11, 100_000, 0)
    ok = draws[:, 0] == 1.0
    assert ok.mean() > 0.99
    at_infinity = ok & np.isinf(draws[:, 1])
    assert at_infinity.any() == with_map
    pdf, again = draws[:, 2], draws[:, 3]
    if with_map:
        share = flat.light_f[0, LIGHT_PMF]
        assert at_infinity.mean() == pytest.approx(share, abs=0.01)
        # The map: the lookup finds the sampled texel, but for draws on a texel's edge.
        agree = np.abs(again[at_infinity] - pdf[at_infinity]) <= 1e-9 * pdf[at_infinity]
        assert agree.mean() > 0.999, f"{(~agree).sum()} of {agree.size} map densities differ"
        assert np.allclose(draws[at_infinity, 5], again[at_infinity], rtol=1e-9, atol=0.0), "radiance_escaped and pdf_li disagree on the map"
    # A point on a lamp: pdf_li of the surface the ray meets there, where that is the drawn point.
    finite = ok & ~np.isinf(draws[:, 1])
    distance = np.where(finite, draws[:, 1], 1.0)
    visible = finite & (np.abs(draws[:, 4] - distance) <= 1e-6 * distance)
    assert visible.sum() > 0.5 * finite.sum()
    agree = np.abs(again[visible] - pdf[visible]) <= 1e-6 * pdf[visible]
    assert agree.mean() > 0.9999, f"{(~agree).sum()} of {agree.size} lamp densities differ"


@pytest.mark.slow
@pytest.mark.parametrize("with_map", [True, False], ids=["map and lamps", "lamps"])
def test_one_selection_step_follows_probabilities_that_sum_to_one(with_map):
    from tests.renderer.kernel_calls import selections

    flat = flat_of(ALL_KINDS, MAP if with_map else "")
    # The choice by power (its cdf), which a kernel without a light tree makes: the tree's own
    # choice is tested in test_light_tree.py.
    flat = flat._replace(ltree_f=flat.ltree_f[:0], ltree_i=flat.ltree_i[:0])
    choose = flat.light_f[0, LIGHT_PMF] if with_map else 0.0
    first = 1 if with_map else 0
    probs = np.concatenate([[choose] if with_map else [], (1.0 - choose) * flat.light_f[first:, LIGHT_PMF]])
    assert probs.sum() == pytest.approx(1.0, abs=1e-12) and np.all(probs > 0)
    if with_map:
        assert 0.1 <= choose <= 0.9
    got = selections(flat, np.random.default_rng(17).random(200_000))
    rows = got[:, 0].astype(int)
    assert rows.min() >= 0
    assert np.all(got[:, 1] == got[:, 2]), "share_of disagrees with select_light"
    assert np.all(got[:, 1] == np.where(rows == 0, choose, 1.0 - choose) if with_map else got[:, 1] == 1.0)
    assert chi2_test(np.bincount(rows, minlength=len(probs)), probs)[0] > ALPHA


@pytest.mark.slow
def test_a_map_alone_takes_every_sample_and_a_black_one_none(tmp_path):
    from renderer.film import write_pfm

    write_pfm(tmp_path / "black.pfm", np.zeros((4, 8, 3)))
    alone = compile_scene(loads(CAMERA + MAP + "shapes: []\n", allow_paths=[SKY.parent]).graph)
    assert alone.light_i[:, LIGHT_KIND].tolist() == [ENVIRONMENT_LIGHT] and alone.light_f[0, LIGHT_PMF] == 1.0
    black = compile_scene(loads(LAMP + CAMERA + f"background: {{type: image, file: '{tmp_path / 'black.pfm'}'}}\n"
                                "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: lamp}]\n",
                                allow_paths=[tmp_path]).graph)
    assert black.light_i[:, LIGHT_KIND].tolist() == [AREA_LIGHT] and black.light_f[0, LIGHT_PMF] == 1.0
    assert black.inst_light.tolist() == [0]
