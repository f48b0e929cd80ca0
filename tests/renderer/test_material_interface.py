"""The material interface (renderer/materials.py) and the integrator that only asks it.

Every material answers `sample_bsdf` (direction, weight, pdf, delta), `eval_bsdf` (f . cos as
tint x value) and `pdf_bsdf`, and `emits` / `emitted`; `tracing/integrator.trace` calls these
and the shapes' `world_interaction`, and names no kind of either. These tests hold each material to
that contract on many random inputs (fixed seeds): a sampler's pdf is its own `pdf_bsdf`, its
weight is eval / pdf, its directions follow its pdf (chi-square, tests/renderer/stats.py), and
eval is non-negative and reciprocal. Which materials have a density is pinned too: only they
are light-sampled, so changing the set would change images.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from renderer import materials
from renderer import shapes
from renderer.materials import CODES, MAT_KIND, MATERIAL_I, phase_function
from renderer.shapes import PRIMITIVE_I
from tests.renderer.stats import ALPHA, chi2_test
from tests.renderer.test_sampling import frame, grid_counts

ROOT = Path(__file__).resolve().parents[2]
INTEGRATOR = ROOT / "renderer" / "tracing" / "integrator.py"

N = 200_000
SEED = 20251125
COLOR = np.array([0.7, 0.4, 0.2])
# The books' parameters where a kind reads them: a fuzzed metal, a glass.
FUZZ, IOR = 0.3, 1.5
# The materials with a density (light sampling and MIS serve them); the others are deltas or absorb.
WITH_DENSITY = {"lambertian", "isotropic"}
# A medium's material (a phase function): its value carries no cosine.
PHASE_FUNCTION = phase_function(0)[0][MAT_KIND]


# --- the integrator names no kind -------------------------------------------------------------


def kind_names(layout, column: str = "kind") -> set[str]:
    """The type-code constants a table's kind column lists ("type code: A, B or C")."""
    meaning = next(c.meaning for c in layout.columns if c.name == column)
    return set(re.findall(r"\b[A-Z][A-Z_]+\b", meaning.split(":", 1)[1].split("(")[0]))


def forbidden_names() -> set[str]:
    """Names whose use would mean the integrator tells materials or shapes apart by kind."""
    material_codes = kind_names(MATERIAL_I)
    shape_codes = kind_names(PRIMITIVE_I)
    # The declared lists are the modules' constants, value for value.
    assert {name: getattr(materials, name) for name in material_codes} == {k.upper(): v for k, v in CODES.items()}
    assert all(isinstance(getattr(shapes, name), int) for name in shape_codes)
    assert {"SPHERE", "MEDIUM", "MESH_TRIANGLE"} <= shape_codes and {"LAMBERTIAN", "DIFFUSE_LIGHT"} <= material_codes
    return material_codes | shape_codes | {"CODES", "MAT_KIND", "PRIM_KIND"}


def names_in(source: str) -> set[str]:
    """Every name a module's source uses: bare names, attributes and imported names."""
    out = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Name):
            out.add(node.id)
        elif isinstance(node, ast.Attribute):
            out.add(node.attr)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            out.update(alias.asname or alias.name.rsplit(".", 1)[-1] for alias in node.names)
    return out


def test_the_integrator_names_no_material_kind_and_no_shape_kind():
    used = names_in(INTEGRATOR.read_text())
    assert "trace" in used and "sample_bsdf" in used and "world_interaction" in used
    assert used & forbidden_names() == set()


def test_the_kind_check_finds_the_old_integrator_lines():
    """Control: the lines the integrator had before the interface are caught."""
    old = ("from ..materials import DIFFUSE_LIGHT, LAMBERTIAN\n"
           "if kind == LAMBERTIAN or kind == materials.ISOTROPIC:\n    pass\n"
           "prim_kind = S.prims_i[prim, PRIM_KIND]\n")
    assert names_in(old) & forbidden_names() == {"DIFFUSE_LIGHT", "LAMBERTIAN", "ISOTROPIC", "PRIM_KIND"}


# --- each material against its own contract ---------------------------------------------------


# The kinds whose lobes dispatch.py calls (the microfacet families join as they are wired in).
WIRED = {"lambertian", "metal", "dielectric", "diffuse_light", "isotropic"}


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def random_setups(n, seed, grazing=False):
    """n incoming directions d and normals on the ray's side (n_front . d < 0), in random frames;
    with `grazing`, within a few degrees of the surface."""
    rng = np.random.default_rng(seed)
    n_front = unit_rows(rng.normal(size=(n, 3)))
    d = unit_rows(rng.normal(size=(n, 3)))
    if grazing:
        # Mostly along the tangent plane, a little into the surface.
        d = unit_rows(d - (d * n_front).sum(axis=1)[:, None] * n_front - 0.05 * rng.random((n, 1)) * n_front)
    d = np.where(((d * n_front).sum(axis=1) > 0)[:, None], -d, d)
    return d, n_front


def rows_of(name):
    from tests.renderer.kernel_calls import material_rows

    return material_rows(CODES[name], FUZZ, IOR)


def samples_of(name, n=N, seed=SEED, grazing=False, front=True, bounce=1):
    from tests.renderer.kernel_calls import bsdf_samples

    d, n_front = random_setups(n, seed, grazing)
    return d, n_front, bsdf_samples(*rows_of(name), COLOR, d, n_front, front, seed, bounce)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(WIRED))
def test_sample_agrees_with_pdf_and_eval(name):
    """On random inputs: a sampler's pdf is `pdf_bsdf` of its direction and its weight is eval / pdf,
    colour included; a delta lobe has pdf 0 and no value for any given pair of directions."""
    for grazing in (False, True):
        d, n_front, s = samples_of(name, n=20_000, seed=SEED + 1 + grazing, grazing=grazing)
        wi, weight, pdf, delta = s[:, 0:3], s[:, 3:6], s[:, 6], s[:, 7]
        absorbed = ~np.any(wi != 0.0, axis=1)
        if name == "diffuse_light":
            assert absorbed.all() and (weight == 0.0).all()  # a light only emits
            continue
        assert not absorbed.any()
        assert set(delta) == {0.0 if name in WITH_DENSITY else 1.0}
        if name not in WITH_DENSITY:
            assert (pdf == 0.0).all() and (s[:, 8] == 0.0).all() and (s[:, 12] == 0.0).all()
            assert (weight == COLOR).all()  # the chosen lobe carries the colour, exactly
            continue
        assert np.isfinite(s).all() and (pdf > 0.0).all()
        np.testing.assert_allclose(s[:, 8], pdf, rtol=1e-12, atol=0.0)
        tint, value = s[:, 9:12], s[:, 12]
        np.testing.assert_allclose(weight, tint * (value / pdf)[:, None], rtol=1e-12, atol=0.0)
        assert (weight == COLOR).all()  # f . cos / pdf cancels analytically and is returned undivided


@pytest.mark.slow
def test_emission_goes_through_the_interface():
    from tests.renderer.kernel_calls import emission_of

    for name in CODES:
        for front in (True, False):
            emits, e = emission_of(*rows_of(name), COLOR, front)
            assert emits == (name == "diffuse_light")
            if emits:
                assert (e == COLOR).all()  # the books' light: its colour, from both sides


def direction_p_value(wi, n_front_row, pdf_on_grid):
    """Chi-square p-value of directions wi (about one normal) against the density `pdf_on_grid`
    integrates to over each cell of a (cos theta, azimuth) grid of the whole sphere."""
    t, b, n = frame(n_front_row)
    u = unit_rows(wi)
    z = u @ n
    phi = np.arctan2(u @ b, u @ t)
    nz, nphi = 20, 20
    counts = grid_counts((z + 1) / 2, (phi + np.pi) / (2 * np.pi), nz, nphi)
    return chi2_test(counts, pdf_on_grid(nz, nphi, t, b, n))[0]


def cell_probabilities(name, d_row, sub=4):
    """For each cell of the (cos theta, azimuth) grid, the integral of `pdf_bsdf` over it (solid
    angle is dz dphi: midpoints of sub x sub sub-cells); checked to integrate to 1 over the sphere."""
    from tests.renderer.kernel_calls import bsdf_values

    def on_grid(nz, nphi, t, b, n):
        kz, kphi = nz * sub, nphi * sub
        z = -1 + (np.arange(kz) + 0.5) * 2 / kz
        phi = -np.pi + (np.arange(kphi) + 0.5) * 2 * np.pi / kphi
        zz, pp = np.meshgrid(z, phi, indexing="ij")
        r = np.sqrt(1 - zz * zz)
        dirs = (r * np.cos(pp))[..., None] * t + (r * np.sin(pp))[..., None] * b + zz[..., None] * n
        dirs = dirs.reshape(-1, 3)
        m = len(dirs)
        values = bsdf_values(*rows_of(name), COLOR, np.tile(d_row, (m, 1)), np.tile(n, (m, 1)), dirs)
        assert (values[:, 3] >= 0).all() and (values[:, 4] >= 0).all()
        mass = values[:, 4].reshape(kz, kphi) * (2 / kz) * (2 * np.pi / kphi)
        cells = mass.reshape(nz, sub, nphi, sub).sum(axis=(1, 3))
        assert cells.sum() == pytest.approx(1.0, abs=1e-3), "the density does not integrate to 1"
        return cells / cells.sum()

    return on_grid


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(WITH_DENSITY))
@pytest.mark.parametrize("incoming", [(0.0, 0.0, -1.0), (0.8, 0.0, -0.6), (0.999, 0.0, -0.0447)])
def test_sampler_follows_its_own_pdf(name, incoming):
    from tests.renderer.kernel_calls import bsdf_samples

    n_front = np.array([0.0, 0.0, 1.0])
    d_row = np.array(incoming) / np.linalg.norm(incoming)
    d, nf = np.tile(d_row, (N, 1)), np.tile(n_front, (N, 1))
    s = bsdf_samples(*rows_of(name), COLOR, d, nf, True, SEED + 3, 2)
    assert direction_p_value(s[:, 0:3], n_front, cell_probabilities(name, d_row)) > ALPHA


@pytest.mark.slow
def test_the_chi_square_check_rejects_another_pdf():
    """Control: cosine-weighted directions are not the isotropic phase function's, and the reverse."""
    from tests.renderer.kernel_calls import bsdf_samples

    n_front = np.array([0.0, 0.0, 1.0])
    d_row = np.array([0.0, 0.0, -1.0])
    d, nf = np.tile(d_row, (N, 1)), np.tile(n_front, (N, 1))
    lambertian = bsdf_samples(*rows_of("lambertian"), COLOR, d, nf, True, SEED + 4, 2)
    isotropic = bsdf_samples(*rows_of("isotropic"), COLOR, d, nf, True, SEED + 5, 2)
    assert direction_p_value(lambertian[:, 0:3], n_front, cell_probabilities("isotropic", d_row)) < 1e-12
    assert direction_p_value(isotropic[:, 0:3], n_front, cell_probabilities("lambertian", d_row)) < 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(WIRED))
def test_eval_is_non_negative_and_reciprocal(name):
    """f(wo, wi) = f(wi, wo) for the light's way reversed: a ray along -wi meeting the surface
    and leaving toward -d. eval gives f . cos(wi) on a surface and the bare phase function in
    a medium; n_front is the normal on the side of the incoming ray, as the integrator sets it."""
    from tests.renderer.kernel_calls import bsdf_values

    rng = np.random.default_rng(SEED + 6)
    n = 50_000
    normal = unit_rows(rng.normal(size=(n, 3)))
    d = unit_rows(rng.normal(size=(n, 3)))
    wi = unit_rows(rng.normal(size=(n, 3)))

    def side(ray):
        return np.where(((ray * normal).sum(axis=1) < 0)[:, None], normal, -normal)

    forward = bsdf_values(*rows_of(name), COLOR, d, side(d), wi)
    backward = bsdf_values(*rows_of(name), COLOR, -wi, side(-wi), -d)
    for values in (forward, backward):
        assert np.isfinite(values).all() and (values[:, 3] >= 0).all() and (values[:, 4] >= 0).all()
    f_forward, f_backward = forward[:, 3], backward[:, 3]
    if CODES[name] != PHASE_FUNCTION:
        # Divide out the cosine at the direction light arrives from.
        cos_wi, cos_wo = np.abs((wi * normal).sum(axis=1)), np.abs((d * normal).sum(axis=1))
        keep = (cos_wi > 1e-6) & (cos_wo > 1e-6)
        f_forward, f_backward = f_forward[keep] / cos_wi[keep], f_backward[keep] / cos_wo[keep]
    np.testing.assert_allclose(f_forward, f_backward, rtol=1e-12, atol=1e-300)
    np.testing.assert_array_equal(forward[:, 0:3], backward[:, 0:3])  # the tint does not depend on the way
    if name in WITH_DENSITY:
        assert (forward[:, 3] > 0).any()  # not trivially zero
