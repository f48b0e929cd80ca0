"""The microfacet families through the material interface the integrator calls (world space).

Each family's lobe is tested in its own local frame by its own test file; here the same lobes are
reached the way a render reaches them: a material row flattened from a model, its parameter
slots, a shading frame about a random normal with a random tangent, `sample_bsdf`, `eval_bsdf`,
`pdf_bsdf` and `has_density` of `renderer/materials/dispatch.py`. What must hold there:

- a sampled non-delta direction's weight is eval / pdf, and its pdf is `pdf_bsdf` of it;
- `has_density` is True exactly when the material can give a non-delta direction;
- the directions follow `pdf_bsdf` in world space (chi-square, about a tilted normal), so the
  frame's round trip is right;
- a render that samples lights through these lobes (mis) converges to the books' estimator
  (path), block by block.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import TypeAdapter

from renderer.compile import with_integrator
from renderer.materials.table import MAT_PARAM, PARAMETER_SLOTS, material_rows
from renderer.render import render
from scenefmt.materials import Material
from scenefmt.validation import loads
from tests.renderer.sphere_chi2 import cell_probabilities, sphere_p_value
from tests.renderer.stats import ALPHA, block_z, z_limit
from tests.renderer.test_sampling import frame

pytestmark = pytest.mark.slow

SEED = 20261126
COLOR = np.array([0.9, 0.6, 0.3])

# name -> (material, whether it has a non-delta part)
CASES = {
    "rough conductor": ({"type": "conductor", "metal": "gold", "roughness": 0.5}, True),
    "anisotropic conductor": ({"type": "conductor", "metal": "copper", "alpha": 0.05, "alpha_v": 0.4}, True),
    "smooth conductor": ({"type": "conductor", "metal": "silver"}, False),
    "rough dielectric": ({"type": "rough_dielectric", "ior": 1.5, "roughness": 0.5}, True),
    "smooth rough_dielectric": ({"type": "rough_dielectric", "ior": 1.33, "alpha": 0.0}, False),
    "thin dielectric": ({"type": "thin_dielectric", "ior": 1.5}, False),
    "smooth plastic": ({"type": "plastic", "albedo": [0.2, 0.5, 0.8], "ior": 1.5}, True),
    "rough plastic": ({"type": "plastic", "albedo": [0.8, 0.5, 0.2], "ior": 1.6, "roughness": 0.4, "nonlinear": True}, True),
    "principled paint": ({"type": "principled", "base_color": [0.8, 0.2, 0.2], "roughness": 0.4, "clearcoat": 1,
                          "clearcoat_roughness": 0.2}, True),
    "principled metal": ({"type": "principled", "base_color": [0.9, 0.6, 0.3], "metallic": 1, "roughness": 0.3}, True),
    "principled glass": ({"type": "principled", "transmission": 1, "roughness": 0.3}, True),
}
MODEL = TypeAdapter(Material)


def setup_of(name):
    """(mat_i, mat_f, params) of one material row flattened from the case's model (textures: row 0)."""
    model = MODEL.validate_python(CASES[name][0])
    ints, floats = material_rows(model, 0, {})
    mat_i, mat_f = np.array([ints], np.int32), np.array([floats], np.float64)
    return mat_i, mat_f, mat_f[0, MAT_PARAM:MAT_PARAM + PARAMETER_SLOTS].copy()


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def random_setups(n, seed):
    """Incoming directions d, normals on the ray's side and tangents, in random frames."""
    rng = np.random.default_rng(seed)
    n_front = unit_rows(rng.normal(size=(n, 3)))
    d = unit_rows(rng.normal(size=(n, 3)))
    d = np.where(((d * n_front).sum(axis=1) > 0)[:, None], -d, d)
    tangent = unit_rows(np.cross(n_front, rng.normal(size=(n, 3))))
    return d, n_front, tangent


@pytest.mark.parametrize("front", [True, False])
@pytest.mark.parametrize("name", sorted(CASES))
def test_weight_is_eval_over_pdf_and_has_density_says_which(name, front):
    from tests.renderer.kernel_calls import bsdf_samples, has_density_of

    mat_i, mat_f, params = setup_of(name)
    d, n_front, tangent = random_setups(20_000, SEED)
    s = bsdf_samples(mat_i, mat_f, COLOR, d, n_front, front, SEED, 1, params, tangent)
    assert np.isfinite(s).all()
    wi, weight, pdf, delta = s[:, 0:3], s[:, 3:6], s[:, 6], s[:, 7]
    alive = np.any(wi != 0.0, axis=1)
    assert alive.mean() > 0.5  # most samples give a direction (single-scattering GGX loses a few)
    assert (weight >= 0).all() and (pdf >= 0).all()
    smooth = (delta == 1.0) & alive
    rough = (delta == 0.0) & alive
    has = has_density_of(mat_i, params)
    assert has == CASES[name][1]
    if not has:
        assert not rough.any() and (s[:, 8] == 0.0).all() and (s[:, 12] == 0.0).all()
        return
    assert rough.any()
    assert (pdf[rough] > 0).all()
    np.testing.assert_allclose(s[rough, 8], pdf[rough], rtol=1e-9)
    tint, value = s[rough, 9:12], s[rough, 12]
    np.testing.assert_allclose(weight[rough], tint * (value / pdf[rough])[:, None], rtol=1e-9, atol=1e-12)
    assert not smooth.any() or (pdf[smooth] == 0).all()


@pytest.mark.parametrize("name", [name for name, (_, has) in sorted(CASES.items()) if has])
def test_world_directions_follow_pdf_bsdf(name):
    assert world_p_value(name) > ALPHA


def test_the_world_check_catches_a_frame_turned_about_the_normal():
    """Control: the anisotropic lobe's density read in a frame turned by 90 degrees is not its
    samples' density."""
    assert world_p_value("anisotropic conductor", turn_density=True) < 1e-9


def world_p_value(name, turn_density=False):
    """About a tilted normal with a tangent that is not the frame's default: the sampled world
    directions (non-delta ones) against the integral of pdf_bsdf over each cell of the whole
    sphere (refined until stable: tests/renderer/sphere_chi2.py); lost and delta samples form one
    more cell with the rest of the probability."""
    from tests.renderer.kernel_calls import bsdf_samples, bsdf_values

    mat_i, mat_f, params = setup_of(name)
    normal = np.array([0.3, -0.5, 0.81])
    normal /= np.linalg.norm(normal)
    tangent = np.cross(normal, [0.2, 0.9, 0.1])
    tangent /= np.linalg.norm(tangent)
    d_row = -(0.6 * normal + 0.8 * tangent)
    d_row /= np.linalg.norm(d_row)
    t, b, n = frame(normal)
    basis = np.stack([t, b, n])  # rows: local axes in world coordinates

    read_tangent = np.cross(normal, tangent) if turn_density else tangent

    def density(local):
        world = local @ basis
        m = len(world)
        return bsdf_values(mat_i, mat_f, COLOR, np.tile(d_row, (m, 1)), np.tile(normal, (m, 1)), world, params,
                           np.tile(read_tangent, (m, 1)), True)[:, 4]

    count = 200_000
    s = bsdf_samples(mat_i, mat_f, COLOR, np.tile(d_row, (count, 1)), np.tile(normal, (count, 1)), True, SEED + 7, 2,
                     params, np.tile(tangent, (count, 1)))
    rough = (s[:, 7] == 0.0) & np.any(s[:, 0:3] != 0.0, axis=1)
    local = unit_rows(s[rough, 0:3]) @ basis.T
    p, _, _ = sphere_p_value(local, count - rough.sum(), cell_probabilities(density))
    return p


SCENE = """
camera: {look_from: [0, 1.2, 4.5], look_at: [0, 0.45, 0], vfov: 36}
image: {width: 24, aspect_ratio: 1.5, samples_per_pixel: 384, max_depth: 8}
background: [0.05, 0.06, 0.08]
materials:
  floor: {type: lambertian, albedo: [0.6, 0.6, 0.6]}
  lamp: {type: diffuse_light, emit: [12, 11, 10]}
shapes:
  - {type: quad, q: [-4, 0, -4], u: [8, 0, 0], v: [0, 0, 8], material: floor}
  - {type: quad, q: [-0.6, 2.4, -0.2], u: [1.2, 0, 0], v: [0, 0, 0.8], material: lamp}
"""


def test_light_sampling_through_the_families_converges_to_the_books_estimator():
    """One sphere per non-delta case and a pane of thin glass before them, under a small lamp: mis
    (light sampling on every lobe with a density, MIS against the bounce) and path (the books'
    estimator, lights found by chance) agree block by block."""
    rough = [name for name, (_, has) in sorted(CASES.items()) if has]
    spheres = "".join(
        f"  - {{type: sphere, center: [{-1.2 + 2.4 * k / max(1, len(rough) - 1):.3f}, 0.4, 0], radius: 0.38,"
        f" material: {CASES[name][0]}}}\n".replace("'", "")
        for k, name in enumerate(rough))
    pane = "  - {type: quad, q: [-1.6, 0, 1.0], u: [3.2, 0, 0], v: [0, 0.35, 0], material: {type: thin_dielectric, ior: 1.5}}\n"
    graph = loads(SCENE + spheres + pane).graph
    mis = render(graph, seed=1).film
    path = render(with_integrator(graph, "path"), seed=2).film
    assert np.isfinite(mis.total).all() and np.isfinite(path.total).all()
    z = block_z(mis, path, 4)
    assert np.abs(z).max() <= z_limit(z.size), f"largest |z| {np.abs(z).max():.2f}"
