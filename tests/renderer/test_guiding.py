"""The guide's data structure: its kernels (renderer/guiding.py) and its build (guide_build.py).

- Sampling against the density: `sample_guide`'s directions follow `pdf_guide` (chi-square on
  cells of the square of directions that hold whole quadtree cells, so each bin's probability is
  exact) for a peaked lobe, a broad one and a uniform one; the density a sample returns is
  `pdf_guide` of its direction; the density integrates to 1 over the sphere (an exact sum on the
  square, and a midpoint rule in theta and phi that does not share the guide's map).
- What is learned: records of light from a small cone toward a point give a guide whose samples
  go there; two regions with opposite lobes get leaves that keep them apart.
- Bounded and robust: the same records give the same bits; records that are not finite or of
  negative weight change nothing; no records, no energy, every record at one point, tiny caps and
  extreme settings all give finite tables within their caps, and a guide that says nothing (-1)
  where it learned nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from renderer.guide_build import build_guide, guide_summary
from renderer.guiding import (G_CHILD, G_QUAD, G_SHARE, GUIDE_F_HEAD, GUIDE_F_NODE, GUIDE_F_QUAD, GUIDE_I_HEAD, GUIDE_I_NODE,
                              GUIDE_I_QUAD, empty_guide)
from tests.renderer import guiding_calls as calls
from tests.renderer.stats import ALPHA, chi2_test

LO, HI = np.zeros(3), np.ones(3)


def unit_sphere(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


def cone_weights(d, axis, cos_max, inside=1.0, outside=0.0):
    """Weights of records of uniform directions d: radiance `inside` a cone about `axis`, `outside` elsewhere,
    over the uniform density 1 / 4 pi."""
    return np.where(d @ np.asarray(axis, float) >= cos_max, inside, outside) * 4.0 * math.pi


def lobe_guide(kind, seed=5, n=40_000, quad_depth=7):
    """A guide of one leaf (records spread over the unit box) with a lobe of `kind`."""
    rng = np.random.default_rng(seed)
    p = rng.random((n, 3))
    d = unit_sphere(rng, n)
    if kind == "peaked":
        w = cone_weights(d, (0.3, -0.4, 0.866), math.cos(math.radians(8)), 1.0, 0.002)
    elif kind == "broad":
        w = np.maximum(d[:, 0], 0.0) + 0.1 * rng.random(n)
    else:
        w = np.ones(n)
    return build_guide(p, d, w, LO, HI, max_records=n, quad_depth=quad_depth)


def the_leaf(g):
    leaves = calls.leaves(g["guide_f"], g["guide_i"], np.array([[0.5, 0.5, 0.5]]))
    assert leaves[0] >= 0
    return int(leaves[0])


def square_of(d):
    """(x, y) of unit directions on the square of the equal-area map."""
    y = np.arctan2(d[:, 1], d[:, 0]) / (2 * math.pi)
    return 0.5 * (d[:, 2] + 1.0), np.where(y < 0, y + 1.0, y)


def direction_of(x, y):
    z = 2 * x - 1
    r = np.sqrt(np.maximum(0.0, 1 - z * z))
    return np.stack([r * np.cos(2 * math.pi * y), r * np.sin(2 * math.pi * y), z], -1)


def square_masses(g, leaf, depth, bins):
    """Probabilities of bins x bins cells of the square: the density at the centre of every cell of
    the finest depth (where it is constant), summed: exact."""
    k = 1 << depth
    c = (np.arange(k) + 0.5) / k
    x, y = np.meshgrid(c, c, indexing="ij")
    pdf = calls.densities(g["guide_f"], g["guide_i"], leaf, direction_of(x.ravel(), y.ravel()))
    cell = pdf.reshape(k, k) * 4 * math.pi / (k * k)
    return cell.reshape(bins, k // bins, bins, k // bins).sum(axis=(1, 3))


@pytest.mark.parametrize("kind", ["peaked", "broad", "uniform"])
def test_samples_follow_the_density(kind):
    g = lobe_guide(kind)
    leaf = the_leaf(g)
    s = calls.samples(g["guide_f"], g["guide_i"], leaf, np.random.default_rng(11).random((100_000, 2)))
    d, pdf, back = s[:, :3], s[:, 3], s[:, 4]
    assert np.all(np.abs(np.linalg.norm(d, axis=1) - 1.0) < 1e-12)
    assert np.all(pdf > 0.0)
    # The density returned is the density of the direction returned (a direction on a cell's edge
    # may map back into its neighbour: none among these).
    np.testing.assert_allclose(back, pdf, rtol=1e-12)
    bins = 32
    masses = square_masses(g, leaf, 7, bins)
    assert abs(masses.sum() - 1.0) < 1e-12
    x, y = square_of(d)
    counts = np.bincount(np.minimum((x * bins).astype(int), bins - 1) * bins + np.minimum((y * bins).astype(int), bins - 1),
                         minlength=bins * bins)
    p, dof = chi2_test(counts, masses.ravel() / masses.sum())
    assert p > ALPHA, (kind, p, dof)


@pytest.mark.parametrize("kind", ["peaked", "broad", "uniform"])
def test_density_integrates_to_one_over_the_sphere(kind):
    """A midpoint rule in (theta, phi) with sin theta: independent of the guide's own map, so a
    wrong Jacobian (4 pi) or axis would show; its error is that of the guide's cell edges that
    cut the rule's cells, about 1e-4 for the broad lobes and 1.6e-3 for the peaked one."""
    g = lobe_guide(kind)
    leaf = the_leaf(g)
    nt, nphi = 500, 1000
    theta = (np.arange(nt) + 0.5) * math.pi / nt
    phi = (np.arange(nphi) + 0.5) * 2 * math.pi / nphi
    t, f = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1).reshape(-1, 3)
    pdf = calls.densities(g["guide_f"], g["guide_i"], leaf, d).reshape(nt, nphi)
    integral = (pdf * np.sin(t)).sum() * (math.pi / nt) * (2 * math.pi / nphi)
    assert abs(integral - 1.0) < 3e-3, integral


@pytest.mark.parametrize("kind", ["peaked", "broad", "uniform"])
def test_density_over_uniform_directions_averages_to_one(kind):
    """4 pi x the mean density over uniformly drawn directions estimates the integral, 1: within
    5 of its standard errors."""
    g = lobe_guide(kind)
    leaf = the_leaf(g)
    values = 4 * math.pi * calls.densities(g["guide_f"], g["guide_i"], leaf, unit_sphere(np.random.default_rng(2), 250_000))
    se = values.std(ddof=1) / math.sqrt(len(values))
    assert abs(values.mean() - 1.0) < 5 * se + 1e-12, (values.mean(), se)


def cone_directions(rng, n, axis, cos_max):
    """n unit directions uniform in the cone about unit `axis` of half-angle acos(cos_max)."""
    z = 1.0 - rng.random(n) * (1.0 - cos_max)
    phi = 2 * math.pi * rng.random(n)
    r = np.sqrt(np.maximum(0.0, 1 - z * z))
    a = np.asarray(axis, float)
    t = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    t /= np.linalg.norm(t)
    b = np.cross(a, t)
    return (r * np.cos(phi))[:, None] * t + (r * np.sin(phi))[:, None] * b + z[:, None] * a


def test_light_from_a_small_cone_is_where_the_guide_sends_its_samples():
    """Records at points of the unit box of the light of a disc at (0.5, 20, 0.5) that subtends
    about 3 degrees (radiance 1; 1e-5 elsewhere), their directions drawn half uniformly, half
    from a 10 degree cone about +y (weights over that mixture's density, as a training render
    that already guides gives them): 98.6% of the energy comes from the disc's 0.0086 sr. Each
    leaf's guide sends most samples into it (a cone 3 times as wide holds the cells along its
    edge)."""
    rng = np.random.default_rng(3)
    n = 400_000
    p = rng.random((n, 3))
    cos10 = math.cos(math.radians(10))
    d = np.where(rng.random(n)[:, None] < 0.5, unit_sphere(rng, n), cone_directions(rng, n, (0, 1.0, 0), cos10))
    density = 0.5 / (4 * math.pi) + 0.5 * (d[:, 1] >= cos10) / (2 * math.pi * (1 - cos10))
    light = np.array([0.5, 20.0, 0.5])
    to = light - p
    dist = np.linalg.norm(to, axis=1)
    cos_in = np.einsum("ij,ij->i", d, to / dist[:, None])
    w = np.where(cos_in >= np.cos(np.arcsin(1.0 / dist)), 1.0, 1e-5) / density
    g = build_guide(p, d, w, LO, HI)
    gf, gi = g["guide_f"], g["guide_i"]
    points = np.array([[0.1, 0.2, 0.3], [0.9, 0.8, 0.1], [0.5, 0.5, 0.9]])
    for q, leaf in zip(points, calls.leaves(gf, gi, points)):
        assert leaf >= 0
        s = calls.samples(gf, gi, int(leaf), rng.random((20_000, 2)))
        axis = (light - q) / np.linalg.norm(light - q)
        inside = s[:, :3] @ axis >= math.cos(3 * math.asin(1.0 / 20.0))
        assert inside.mean() > 0.95, (q, inside.mean())
        # The disc's own cone from q: 85 to 92% here (the leaf's records saw it from points up
        # to half a unit away, 1.4 degrees off), some 1,000 times the uniform sphere's density.
        disc = s[:, :3] @ axis >= math.cos(math.asin(1.0 / 20.0))
        assert disc.mean() > 0.75, (q, disc.mean())


def test_a_spatial_split_keeps_two_regions_apart():
    """Light from +y over x < 0.5 and from -y over x > 0.5: each side's leaves sample their own."""
    rng = np.random.default_rng(8)
    n = 80_000
    p = rng.random((n, 3))
    d = unit_sphere(rng, n)
    up = np.where(p[:, 0] < 0.5, 1.0, -1.0)
    w = np.where(d[:, 1] * up > 0.9, 1.0, 0.0)
    g = build_guide(p, d, w, LO, HI, max_records=10_000)
    gf, gi = g["guide_f"], g["guide_i"]
    assert guide_summary(g)["guided"] >= 2
    points = rng.random((40, 3))
    for q, leaf in zip(points, calls.leaves(gf, gi, points)):
        assert leaf >= 0
        s = calls.samples(gf, gi, int(leaf), rng.random((2_000, 2)))
        side = 1.0 if q[0] < 0.5 else -1.0
        # The lobe is y > 0.9 (or < -0.9): some 500 records with energy in a leaf of 10,000 or
        # fewer, so cells of 16 of them (cell_records) along its edge reach past it.
        assert np.all(s[:, 1] * side > 0.5), q
        assert np.mean(s[:, 1] * side > 0.88) > 0.8, (q, np.mean(s[:, 1] * side > 0.88))


def random_records(seed, n):
    rng = np.random.default_rng(seed)
    p = rng.random((n, 3)) * [4.0, 2.0, 1.0]
    d = unit_sphere(rng, n)
    w = rng.exponential(size=n) * (1 + 50 * (d[:, 1] > 0.9))
    return p, d, w


def test_the_same_records_give_the_same_bits():
    p, d, w = random_records(1, 30_000)
    a = build_guide(p, d, w, np.zeros(3), np.array([4.0, 2.0, 1.0]), max_records=2_000)
    b = build_guide(p.copy(), d.copy(), w.copy(), np.zeros(3), np.array([4.0, 2.0, 1.0]), max_records=2_000)
    for key in ("guide_f", "guide_i"):
        assert a[key].dtype == b[key].dtype and a[key].tobytes() == b[key].tobytes()
    assert guide_summary(a)["nodes"] > 1 and guide_summary(a)["guided"] > 1


def test_records_not_finite_or_of_negative_weight_change_nothing():
    p, d, w = random_records(2, 20_000)
    lo, hi = np.zeros(3), np.array([4.0, 2.0, 1.0])
    clean = build_guide(p, d, w, lo, hi, max_records=2_000)
    bad_p = np.array([[np.nan, 0.5, 0.5], [0.5, np.inf, 0.5], [0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [0.5, 0.5, 0.5],
                      [0.5, 0.5, 0.5], [1e9, 0.5, 0.5]])
    bad_d = np.array([[0, 0, 1], [0, 0, 1], [np.nan, 0, 1], [0, 0, 0], [0, 0, 1], [0, 0, 1], [0, 0, 1]], float)
    bad_w = np.array([1.0, 1.0, 1.0, 1.0, -1.0, np.inf, 1.0])
    dirty = build_guide(np.r_[bad_p[:3], p, bad_p[3:]], np.r_[bad_d[:3], d, bad_d[3:]], np.r_[bad_w[:3], w, bad_w[3:]],
                        lo, hi, max_records=2_000)
    for key in ("guide_f", "guide_i"):
        assert clean[key].tobytes() == dirty[key].tobytes()
    # Weights near the largest double: their sums would overflow; only their shares count.
    huge = build_guide(p, d, w * (1e308 / w.max()), lo, hi, max_records=2_000)
    assert np.isfinite(huge["guide_f"]).all() and guide_summary(huge) == guide_summary(clean)


def says_nothing(g, points):
    return np.all(calls.leaves(g["guide_f"], g["guide_i"], points) == -1)


@pytest.mark.parametrize("case", ["no records", "no energy", "all dropped", "too few"])
def test_a_guide_that_learned_nothing_says_nothing(case):
    rng = np.random.default_rng(4)
    n = {"no records": 0, "too few": 50}.get(case, 1_000)
    p, d = rng.random((n, 3)), unit_sphere(rng, n)
    w = {"no energy": np.zeros(n), "all dropped": np.full(n, np.nan)}.get(case, np.ones(n))
    g = build_guide(p, d, w, LO, HI)
    assert np.isfinite(g["guide_f"]).all()
    assert g["guide_i"].shape[0] >= 2  # the header and a root, which has no distribution
    assert says_nothing(g, rng.random((100, 3)))
    assert says_nothing(build_guide(p, d, np.ones(n), LO, HI, min_records=n + 1), rng.random((100, 3)))


def test_the_empty_guide_and_points_outside_the_box_have_no_leaf():
    e = empty_guide()
    assert says_nothing(e, np.array([[0.5, 0.5, 0.5]]))
    p, d, w = random_records(6, 5_000)
    g = build_guide(p, d, w, np.zeros(3), np.array([4.0, 2.0, 1.0]))
    outside = np.array([[-1.0, 0.5, 0.5], [0.5, 9.0, 0.5], [np.nan, 0.5, 0.5], [0.5, 0.5, np.inf]])
    assert says_nothing(g, outside)
    assert not says_nothing(g, np.array([[2.0, 1.0, 0.5]]))


def test_every_record_at_one_point_stays_within_the_depth_cap():
    rng = np.random.default_rng(7)
    n = 50_000
    p = np.tile([0.25, 0.5, 0.75], (n, 1))
    d = unit_sphere(rng, n)
    w = cone_weights(d, (0, 0, 1), 0.9, 1.0, 0.01)
    g = build_guide(p, d, w, LO, HI, max_records=100, max_depth=20)
    s = guide_summary(g)
    assert s["nodes"] <= 2 * 20 + 1 and s["records"] == n
    leaf = calls.leaves(g["guide_f"], g["guide_i"], p[:1])[0]
    assert leaf >= 0
    # 84% of the energy is in the cone z >= 0.9; the cells along its edge spread a little of it.
    samples = calls.samples(g["guide_f"], g["guide_i"], int(leaf), rng.random((5_000, 2)))
    assert (samples[:, 2] >= 0.85).mean() > 0.8


def test_the_caps_hold_whatever_the_records():
    p, d, w = random_records(9, 60_000)
    lo, hi = np.zeros(3), np.array([4.0, 2.0, 1.0])
    for max_nodes, max_quads in ((1, 0), (7, 5), (31, 200), (1 << 16, 1 << 18)):
        # threshold 0: every cell with any energy asks to be cut, down to the depth cap.
        g = build_guide(p, d, w, lo, hi, max_records=1, min_records=1, max_nodes=max_nodes, max_quads=max_quads,
                        threshold=0.0, cell_records=1, quad_depth=6)
        s = guide_summary(g)
        assert s["nodes"] <= max_nodes and s["quads"] <= max_quads, s
        assert g["guide_f"].shape == (1 + s["nodes"] + s["quads"], GUIDE_F_HEAD.width)
        assert g["guide_i"].shape == (1 + s["nodes"] + s["quads"], GUIDE_I_HEAD.width)
        assert np.isfinite(g["guide_f"]).all()
        assert_consistent(g)
    # Settings out of range are clamped, not obeyed into a crash.
    g = build_guide(p, d, w, lo, hi, max_records=-5, min_records=0, max_depth=10_000, max_nodes=0, threshold=math.nan,
                    quad_depth=99, max_quads=-1)
    assert guide_summary(g)["nodes"] == 1 and guide_summary(g)["quads"] == 0


def test_a_lucky_record_does_not_make_a_spike():
    """20,000 records of uniform light and one that carries as much energy as all of them: a cell
    is cut only while it holds `cell_records` records with energy, so the lucky record's cell is
    a quarter of one that held about cell_records of them, and its density (half the energy over
    that area) at most about 0.5 x 4 x 20,000 / cell_records / 4 pi (a factor 2 left for the
    records' scatter); cut on energy alone (cell_records 1, the
    rule of Mueller et al., who judge each cut by the next iteration's records) it becomes a cell
    of the finest depth holding half the energy, 4^12 / 2 / 4 pi."""
    rng = np.random.default_rng(12)
    n = 20_000
    p = rng.random((n + 1, 3))
    d = unit_sphere(rng, n + 1)
    w = np.r_[np.ones(n), float(n)]
    for cell_records, low, high in ((8, 0.5 * n / 8 / 2, 0.5 * 4 * n / 8 * 2), (1, 0.49 * 4 ** 12, 0.51 * 4 ** 12)):
        g = build_guide(p, d, w, LO, HI, max_records=2 * n, cell_records=cell_records)
        density = calls.densities(g["guide_f"], g["guide_i"], the_leaf(g), d[-1:])[0] * 4 * math.pi
        assert low <= density <= high, (cell_records, density)


def assert_consistent(g):
    """Every row a row refers to exists and is of the right kind; shares sum to 1 in every cell."""
    gf, gi = g["guide_f"], g["guide_i"]
    s = guide_summary(g)
    nodes = slice(1, 1 + s["nodes"])
    quads = slice(1 + s["nodes"], None)
    child = gi[nodes, G_CHILD]
    assert np.all((child == -1) | ((child >= 2) & (child + 1 <= s["nodes"])))
    root = gi[nodes, G_QUAD]
    assert np.all((root == -1) | ((root > s["nodes"]) & (root < gi.shape[0])))
    assert np.all(root[child >= 0] == -1)
    qc = gi[quads, :4]
    assert np.all((qc == -1) | ((qc > s["nodes"]) & (qc < gi.shape[0])))
    if s["quads"]:
        share = gf[quads, G_SHARE:G_SHARE + 4]
        assert np.all(share >= 0) and np.allclose(share.sum(axis=1), 1.0, rtol=1e-12)
        assert np.all(share[qc >= 0] > 0)


def test_the_layouts_fit_their_tables():
    for layout in (GUIDE_F_HEAD, GUIDE_F_NODE, GUIDE_F_QUAD):
        assert layout.width == GUIDE_F_HEAD.width and layout.dtype == "float64"
    for layout in (GUIDE_I_HEAD, GUIDE_I_NODE, GUIDE_I_QUAD):
        assert layout.width == GUIDE_I_HEAD.width and layout.dtype == "int64"
    p, d, w = random_records(10, 20_000)
    g = build_guide(p, d, w, np.zeros(3), np.array([4.0, 2.0, 1.0]), max_records=1_000)
    assert g["guide_f"].dtype == np.float64 and g["guide_i"].dtype == np.int64
    assert_consistent(g)


@pytest.mark.parametrize("scale", [1e-40, 1.0, 1e40])
def test_the_guide_is_the_same_at_every_scale(scale):
    """The box follows the records' size (from 1e-60 to 1e60, as scenefmt.bounds allows): scaled
    records give the same tree, and a point far outside them has no leaf; coordinates past
    1e100 are dropped."""
    p, d, w = random_records(13, 20_000)
    lo, hi = np.zeros(3), np.array([4.0, 2.0, 1.0])
    base = build_guide(p, d, w, lo, hi, max_records=1_000)
    g = build_guide(p * scale, d, w, lo * scale, hi * scale, max_records=1_000)
    assert guide_summary(g) == guide_summary(base)
    assert np.array_equal(g["guide_i"], base["guide_i"])
    # Node rows hold places (scaled); quadtree rows hold shares (not).
    is_node = np.arange(g["guide_f"].shape[0] - 1)[:, None] < guide_summary(g)["nodes"]
    np.testing.assert_allclose(g["guide_f"][1:] / np.where(is_node, scale, 1.0), base["guide_f"][1:], rtol=1e-12)
    points = np.array([[2.0, 1.0, 0.5], [40.0, 1.0, 0.5]]) * scale
    found = calls.leaves(g["guide_f"], g["guide_i"], points)
    assert found[0] >= 0 and found[1] == -1
    huge = build_guide(np.r_[p, [[1e200, 0.0, 0.0]]], np.r_[d, d[:1]], np.r_[w, 1.0], np.full(3, -np.inf), np.full(3, np.inf),
                       max_records=1_000)
    assert guide_summary(huge)["records"] == len(w) and np.isfinite(huge["guide_f"]).all()
