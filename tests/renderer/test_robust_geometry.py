"""Intersection where naive code breaks: on faces and edges, along axes, in planes, at tangents,
from a surface, at extreme sizes, and under instance transforms.

The conventions these tests pin down (docs/robustness.md):
- hits are accepted for t in (t_min, t_max), open at both ends, with t_min = 0; a ray starting
  exactly on a surface does not hit that surface at t = 0;
- faces are closed: a point on a quad's edge or a box's edge hits (both faces, the nearer or
  the first visited wins a tie, with equal t);
- a ray parallel to a plane (|n . d| <= 1e-12 |d|_max) misses it, even when it lies in it; a ray
  lying in a box face therefore hits the two faces it crosses at their edges;
- a ray touching a sphere (discriminant exactly 0) hits it at the touching point;
- the BVH (padded boxes, slab test with 1/0 replaced by a finite 1e300 so 0 * it is 0, not NaN)
  never changes the answer of testing every primitive.
"""

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
from renderer import target

from renderer.compile import compile_scene
from renderer.config import SPAWN_OFFSET
from renderer.shapes.dispatch import spawn_origin
from renderer.tracing.probe import probe_rays
from scenefmt import affine
from scenefmt import models as m
from scenefmt.graph import build_graph
from tests import naive

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

MAT = m.Lambertian(albedo=(0.5, 0.5, 0.5))
EPS = np.finfo(float).eps


def flat_of(*shapes, use_bvh=True):
    return compile_scene(build_graph(m.Scene(shapes=list(shapes))), use_bvh=use_bvh)


def probe(flat, o, d, brute=False, tmin=0.0):
    return probe_rays(flat, np.asarray(o, float).reshape(-1, 3), np.asarray(d, float).reshape(-1, 3), 0.0, tmin, brute)


def grid_rays():
    """Origins on a grid that includes a unit box's faces, edges and corners; directions with
    components in {-1, -0.0, 0, 1} (signed zeros both ways), so many rays run along faces and edges."""
    values = (-1.0, 0.0, 0.5, 1.0, 2.0)
    comps = (-1.0, -0.0, 0.0, 1.0)
    origins, dirs = [], []
    for o in [(x, y, z) for x in values for y in values for z in values]:
        for d in [(a, b, c) for a in comps for b in comps for c in comps]:
            if any(v != 0.0 for v in d):
                origins.append(o)
                dirs.append(d)
    return np.array(origins), np.array(dirs)


def faces_at(lo, hi, p, tol=0.0):
    """Outward normals of the box faces that contain point p."""
    out = []
    for axis in range(3):
        others = [k for k in range(3) if k != axis]
        if all(lo[k] - tol <= p[k] <= hi[k] + tol for k in others):
            for side, value in ((-1.0, lo[axis]), (1.0, hi[axis])):
                if abs(p[axis] - value) <= tol:
                    n = [0.0, 0.0, 0.0]
                    n[axis] = side
                    out.append(tuple(n))
    return out


@pytest.mark.parametrize("lo, hi", [((0, 0, 0), (1, 1, 1)), ((0, 0, 0), (1, 0.5, 2))])
def test_rays_on_box_faces_and_edges_follow_the_convention(lo, hi):
    o, d = grid_rays()
    bvh = flat_of(m.Box(min=lo, max=hi, material=MAT))
    brute = flat_of(m.Box(min=lo, max=hi, material=MAT), use_bvh=False)
    t1, p1, _, x1, n1, _ = probe(bvh, o, d)
    t2, p2, _, x2, n2, _ = probe(brute, o, d, brute=True)
    assert np.array_equal(t1, t2), "the BVH changed a hit distance"
    assert np.isfinite(x1).all() and not np.isnan(t1).any()
    in_plane = on_edge = 0
    for k in range(len(o)):
        ref = naive.box(lo, hi, tuple(o[k]), tuple(d[k]))
        if ref is None:
            assert t1[k] == math.inf, (o[k], d[k], t1[k])
            continue
        assert t1[k] == ref[0], (o[k], d[k], t1[k], ref)
        # The reported face is one of the faces through the hit point (several at an edge).
        faces = faces_at(lo, hi, x1[k])
        assert tuple(n1[k]) in faces and tuple(n2[k]) in faces, (o[k], d[k], n1[k], faces)
        on_edge += len(faces) > 1
        in_plane += any(d[k][a] == 0 and o[k][a] in (lo[a], hi[a]) for a in range(3))
    assert on_edge > 500 and in_plane > 500  # the grid did exercise the delicate cases


def test_examples_of_the_convention():
    box = flat_of(m.Box(min=(0, 0, 0), max=(1, 1, 1), material=MAT))
    cases = [
        # (origin, direction, t, normal)
        ((-1, 0.5, 1), (1, 0, 0), 1.0, (-1, 0, 0)),  # lying in the top face: enters through the left face's edge
        ((-1, 1, 1), (1, -0.0, 0), 1.0, (-1, 0, 0)),  # along an edge, with a negative zero
        ((0.5, 0.5, 1), (0, 0, -1), 1.0, (0, 0, -1)),  # from the top face inwards: the far face, not t = 0
        ((0.5, 0.5, 1), (0, 0, 1), math.inf, None),  # from the top face outwards: nothing
        ((1, 0.5, -3), (0, 0, 1), 3.0, (0, 0, -1)),  # axis-parallel in the plane x = 1
        ((1 + 1e-15, 0.5, -3), (0, 0, 1), math.inf, None),  # just outside that plane
    ]
    for o, d, t, n in cases:
        tt, prim, _, p, nn, _ = probe(box, o, d)
        assert tt[0] == t, (o, d)
        if n is not None:
            assert tuple(nn[0]) == n


def test_axis_parallel_rays_through_a_bvh_of_many_boxes():
    """Boxes on an integer grid, rays along the axes from grid points (on many node planes),
    with +0 and -0 in the other components: the BVH equals brute force and the reference."""
    boxes = []
    for i in range(4):
        for j in range(4):
            for k in range(3):
                lo = (i * 1.0, j * 1.0, k * 1.5)
                boxes.append((lo, (lo[0] + 0.5, lo[1] + 1.0, lo[2] + 0.5)))  # touching along y
    shapes = [m.Box(min=lo, max=hi, material=MAT) for lo, hi in boxes]
    bvh, brute = flat_of(*shapes), flat_of(*shapes, use_bvh=False)
    origins, dirs = [], []
    coords = np.arange(-1.0, 5.5, 0.5)
    for axis in range(3):
        for a in coords:
            for b in coords:
                for sign in (1.0, -1.0):
                    for zero in (0.0, -0.0):
                        o = [a, b, b]
                        o[axis] = -2.0 if sign > 0 else 8.0
                        d = [zero, zero, zero]
                        d[axis] = sign
                        origins.append(o)
                        dirs.append(d)
    o, d = np.array(origins), np.array(dirs)
    t1, *_ = probe(bvh, o, d)
    t2, *_ = probe(brute, o, d, brute=True)
    assert np.array_equal(t1, t2)
    hits = 0
    for k in range(len(o)):
        refs = [r[0] for lo, hi in boxes if (r := naive.box(lo, hi, tuple(o[k]), tuple(d[k]))) is not None]
        assert t1[k] == (min(refs) if refs else math.inf), (o[k], d[k])
        hits += bool(refs)
    assert hits > len(o) // 4


def test_rays_parallel_to_a_quad_miss_it():
    quad = m.Quad(q=(0, 0, 0), u=(2, 0, 0), v=(0, 1, 1), material=MAT)  # a tilted plane y = z
    flat = flat_of(quad)
    rng = np.random.default_rng(21)
    n = np.array([0.0, -1.0, 1.0]) / math.sqrt(2)
    # Directions exactly in the plane (components chosen so n . d is exactly 0), from points in
    # the plane (many of them on the quad itself, so the ray lies in it), above and below it.
    along = np.array([[rng.uniform(-1, 1), s, s] for s in rng.uniform(-1, 1, 300)])
    starts = np.array([[x, y, y + off] for x, y, off in zip(rng.uniform(-1, 3, 300), rng.uniform(-0.5, 1.5, 300),
                                                            rng.choice([0.0, 1e-9, -1e-9], 300))])
    t, prim, *_ = probe(flat, starts, along)
    assert np.all(t == math.inf)
    # Tilted out of the plane by 1e-6 relative (well above the 1e-12 threshold), from 1e-7 below
    # it over the quad: a proper hit, at a finite t with the point on the plane.
    tilt = along + 1e-6 * n * np.linalg.norm(along, axis=1)[:, None]
    xs, ys = rng.uniform(0.3, 1.7, 300), rng.uniform(0.2, 0.8, 300)
    below = np.stack([xs, ys, ys], axis=1) - 1e-7 * n
    t, prim, _, p, nn, uv = probe(flat, below, tilt)
    hit = prim >= 0
    assert hit.sum() > 200 and np.isfinite(t[hit]).all()
    assert np.abs((p[hit] @ n)).max() < 1e-12
    assert np.allclose(np.abs(nn[hit] @ n), 1.0)


def test_rays_tangent_to_spheres():
    flat = flat_of(m.Sphere(center=(0, 0, 0), radius=1.0, material=MAT))
    # Exactly tangent (discriminant exactly 0): a hit at the touching point, normal across the ray.
    for o, d, p in [((-5, 1, 0), (1, 0, 0), (0, 1, 0)), ((0, -3, -1), (0, 2, 0), (0, 0, -1)), ((2, 0.0, 1), (-1, -0.0, 0), (0, 0, 1))]:
        t, prim, _, x, n, uv = probe(flat, o, d)
        assert prim[0] >= 0 and x[0] == pytest.approx(p, abs=1e-15) and n[0] == pytest.approx(p, abs=1e-15)
    # Nearly tangent from every side, at distances r (1 + k eps) from the centre: never NaN; a
    # hit lies on the sphere with a unit normal; lines clearly outside miss, clearly inside hit.
    rng = np.random.default_rng(22)
    k = rng.integers(-2000, 2001, 4000)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    side = np.cross(d, rng.normal(size=(4000, 3)))
    side /= np.linalg.norm(side, axis=1)[:, None]
    closest = side * (1.0 + k * EPS)[:, None]
    o = closest - d * rng.uniform(2, 50, (4000, 1))
    t, prim, _, x, n, uv = probe(flat, o, d)
    assert not np.isnan(t).any() and np.isfinite(x).all() and np.isfinite(uv).all()
    hit = prim >= 0
    assert np.allclose(np.linalg.norm(n[hit], axis=1), 1.0, rtol=0, atol=4 * EPS)
    assert np.allclose(np.linalg.norm(x[hit], axis=1), 1.0, rtol=0, atol=4 * EPS)
    # Rounding o = closest - L d moves the line by ~ulp(50) = 32 eps: beyond 1000 eps the side is certain.
    assert not hit[k >= 1000].any() and hit[k <= -1000].all()
    assert 0 < hit[np.abs(k) < 1000].sum() < (np.abs(k) < 1000).sum()


SURFACES = {
    "sphere": lambda s, c: m.Sphere(center=c, radius=0.7 * s, material=MAT),
    "quad": lambda s, c: m.Quad(q=c, u=(s, 0.2 * s, 0), v=(0.1 * s, 0.3 * s, 0.9 * s), material=MAT),
    "box": lambda s, c: m.Box(min=c, max=tuple(x + 0.8 * s for x in c), material=MAT),
    "ellipsoid": lambda s, c: m.Instance(group=m.Group(shapes=[m.Sphere(center=(0, 0, 0), radius=0.5, material=MAT)]),
                                         transform=[m.ScaleStep(scale=(s, 1.7 * s, 0.6 * s)),
                                                    m.RotateStep(rotate=m.Rotation(axis=(1, 2, 3), degrees=40)),
                                                    m.TranslateStep(translate=c)]),
}


@target.kernel
def _spawn_all(p, o, n, d, offset):
    out = np.empty_like(p)
    for k in range(p.shape[0]):
        if offset:
            q = spawn_origin((p[k, 0], p[k, 1], p[k, 2]), (o[k, 0], o[k, 1], o[k, 2]), (n[k, 0], n[k, 1], n[k, 2]),
                             (d[k, 0], d[k, 1], d[k, 2]))
            out[k, 0], out[k, 1], out[k, 2] = q[0], q[1], q[2]
        else:
            out[k] = p[k]
    return out


def surface_hits(flat, scale, center, rng, n):
    """Hit points, normals and the incoming rays' origins of n random rays aimed at the shape."""
    c = np.array(center)
    o = c + scale * rng.uniform(-3, 3, (n, 3))
    target = c + scale * rng.uniform(-0.2, 0.9, (n, 3))
    t, prim, inst, p, normal, _ = probe(flat, o, target - o)
    hit = prim >= 0
    return o[hit], p[hit], normal[hit]


def hits_and_directions(model, scale, center, seed):
    """The flat scene of one shape, 3000 random rays' hits on it (origins, points, normals) and
    a random unit direction for each hit."""
    flat = flat_of(model)
    rng = np.random.default_rng(seed)
    o, p, normal = surface_hits(flat, scale, center, rng, 3000)
    assert len(p) > 300
    r = rng.normal(size=p.shape)
    return flat, o, p, normal, r / np.linalg.norm(r, axis=1)[:, None]


def ellipsoid_exit(shape, start, d):
    """Distance along unit d from a point inside a (transformed) sphere to its surface, in numpy."""
    if isinstance(shape, m.Instance):
        world = affine.from_steps(shape.transform)
        radius, centre = shape.group.shapes[0].radius, np.zeros(3)
    else:
        world = affine.IDENTITY
        radius, centre = shape.radius, np.array(shape.center)
    inv = np.array(naive.inverse(world))
    f = (start @ inv[:, :3].T + inv[:, 3]) - centre
    dd = d @ inv[:, :3].T
    a, b, c = (dd * dd).sum(1), (f * dd).sum(1), (f * f).sum(1) - radius * radius
    return (-b + np.sqrt(b * b - a * c)) / a


@pytest.mark.parametrize("scale, center", [(1.0, (0.3, -0.2, 0.1)), (1e-3, (1e-3, 2e-3, -1e-3)), (1e3, (500.0, -200.0, 0.0)),
                                           (1.0, (1e5, -1e5, 1e5)), (1e-4, (7.0, 3.0, -2.0))])
@pytest.mark.parametrize("shape", list(SURFACES))
def test_rays_leaving_a_surface_do_not_hit_it_again(shape, scale, center):
    """From a hit point pushed off by spawn_origin (as the integrator does), a ray leaving the
    surface never meets it again, and a ray going into a closed shape meets its far side, not
    the near side at t ~ 0. The push is relative, so all of this holds at every scale and offset."""
    model = SURFACES[shape](scale, center)
    flat, o, p, normal, r = hits_and_directions(model, scale, center, 23)
    outward = r * np.sign(np.sum(r * normal, axis=1))[:, None]
    leaving = r if shape == "quad" else outward  # a quad is left on either side
    start = _spawn_all(p, o, normal, leaving, True)
    push = np.linalg.norm(start - p, axis=1)
    assert np.allclose(push, SPAWN_OFFSET * (np.abs(p).max(axis=1) + np.abs(o).max(axis=1)), rtol=1e-6)
    t, again, *_ = probe(flat, start, leaving)
    assert (again < 0).all(), f"{(again >= 0).sum()} self-hits"
    if shape == "quad":
        return
    inward = -outward
    start_in = _spawn_all(p, o, normal, inward, True)
    t, far, _, q, n_far, _ = probe(flat, start_in, inward)
    assert (far >= 0).all()
    if shape == "box":
        # A convex polyhedron's face is never met twice: the far hit is on another face.
        assert (np.abs(n_far - normal).max(axis=1) > 0.5).all()
    else:
        # To 1e-9 of the size, plus 1e-13 of the distance from the origin (the coordinates' rounding,
        # in the kernel and in this numpy reference alike).
        exit_t = ellipsoid_exit(model, start_in, inward)
        tol = 1e-9 * scale + 1e-13 * np.abs(center).max()
        assert np.allclose(t, exit_t, rtol=0, atol=tol), np.abs(t - exit_t).max() / tol


@pytest.mark.parametrize("shape", ["sphere", "ellipsoid"])
def test_without_the_push_rays_re_hit_their_surface(shape):
    """The control for the test above: start exactly at the computed hit point with t_min = 0
    and some outward rays meet the surface again at t ~ 0 (shadow acne)."""
    flat = flat_of(SURFACES[shape](1.0, (0.3, -0.2, 0.1)))
    rng = np.random.default_rng(24)
    o, p, normal = surface_hits(flat, 1.0, (0.3, -0.2, 0.1), rng, 6000)
    r = rng.normal(size=p.shape)
    outward = r * np.sign(np.sum(r * normal, axis=1))[:, None]
    t, again, *_ = probe(flat, _spawn_all(p, o, normal, outward, False), outward)
    assert (again >= 0).sum() > 10


UNPUSHED = {
    "sphere": SURFACES["sphere"],
    "quad": SURFACES["quad"],
    "triangle": lambda s, c: m.Triangle(vertices=(c, tuple(x + y for x, y in zip(c, (s, 0.1 * s, 0.2 * s))),
                                                  tuple(x + y for x, y in zip(c, (0.2 * s, 0.9 * s, -0.3 * s)))),
                                        material=MAT),
    "disk": lambda s, c: m.Disk(center=c, normal=(0.3, 1.0, -0.2), radius=0.8 * s, material=MAT),
}


@pytest.mark.parametrize("scale, center", [(1.0, (0.3, -0.2, 0.1)), (1e-3, (1e-3, 2e-3, -1e-3)), (1e3, (1e5, -1e5, 1e5))])
@pytest.mark.parametrize("shape", list(UNPUSHED))
def test_rays_starting_exactly_on_a_surface_stay_finite_and_meet_it_only_at_its_rounding(shape, scale, center):
    """The integrator always pushes a ray's origin off the surface it leaves (the test above).
    A ray that starts exactly at a computed hit point, with no push, breaks that convention, and
    still gets a sound answer: a finite distance or a miss, a unit normal, and if it meets the
    surface it started on at all, only within the rounding of the point it started from
    (a phantom hit farther away would be a bug); a ray going into a sphere meets its far side."""
    flat, o, p, normal, r = hits_and_directions(UNPUSHED[shape](scale, center), scale, center, 31)
    # The rounding of a point is a few ulps of its coordinates' magnitude.
    rounding = 64 * EPS * (np.abs(p).max(axis=1) + scale)
    for d in (r, -r):
        t, prim, _, _, n, _ = probe(flat, p, d)
        assert not np.isnan(t).any()
        hit = prim >= 0
        assert np.isfinite(t[hit]).all() and (t[~hit] == math.inf).all()
        assert np.allclose(np.linalg.norm(n[hit], axis=1), 1.0, atol=1e-12)
        cos = np.sum(d * normal, axis=1)
        # A ray that starts a rounding error off the surface meets it again where it has moved
        # that far across it: at t |cos| within the rounding (t itself is large for grazing rays).
        own = hit & (t * np.abs(cos) <= rounding)
        if shape == "sphere":
            # Every other hit is the far side of the sphere, along the chord 2 r |cos|, for
            # rays going in; rays going out meet nothing else.
            far = hit & ~own
            assert (cos[far] < 0).all()
            chord = -2 * cos * 0.7 * scale  # SURFACES' sphere has radius 0.7 * scale
            assert np.allclose(t[far], chord[far], rtol=0, atol=1e-9 * scale + 1e-13 * abs(center[0]))
            assert far.sum() > 100
        else:
            # A flat shape is met once: any hit of a ray starting on it is its own point again.
            assert (own == hit).all(), (t[hit] * np.abs(cos[hit]) / rounding[hit]).max()


def surface_error(c, r, o, d, t):
    """| |o + t d - c| - r | / r, evaluated in 60-digit decimal arithmetic."""
    getcontext().prec = 60
    q = [Decimal(float(o[i])) + Decimal(float(t)) * Decimal(float(d[i])) - Decimal(float(c[i])) for i in range(3)]
    return float(abs((q[0] ** 2 + q[1] ** 2 + q[2] ** 2).sqrt() - Decimal(float(r))) / Decimal(float(r)))


def unit_rows(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def sphere_rays(c, r, rng, n):
    """Half the rays from far away (1 to 100 times r + 1) at points just inside the sphere
    (many graze it); half from just above the surface (1e-3 to 10 units, or radii if smaller)
    at nearby surface points, as rays scattered off a huge ground sphere are."""
    c = np.asarray(c)
    h = n // 2
    targets = c + r * unit_rows(rng.normal(size=(h, 3))) * rng.uniform(0.0, 1.0, (h, 1)) ** 0.05
    far = targets + rng.normal(size=(h, 3)) * (r + 1.0) * rng.uniform(1, 100, (h, 1))
    foot = unit_rows(rng.normal(size=(n - h, 3)))
    height = 10 ** rng.uniform(-3, 1, (n - h, 1)) * min(1.0, r)
    near = c + (r + height) * foot
    near_targets = c + r * unit_rows(foot + rng.normal(size=(n - h, 3)) * 3 * height / r)
    return np.concatenate([far, near]), np.concatenate([targets - far, near_targets - near])


@pytest.mark.parametrize("c, r", [((0.3, 0.1, -0.2), 1e-4), ((0.0, -1e6, 0.0), 1e6), ((1e3, 0.0, 0.0), 1e-4),
                                  ((0.0, 0.0, 0.0), 1.0)])
def test_tiny_and_huge_spheres_are_hit_on_their_surface(c, r):
    """The stated accuracy: the point o + t d at the returned t lies within 8 eps (1 + |o - c| / r)
    of the sphere, relative to r (a few ulps of the larger of the ray's and the sphere's scale).

    The books' b^2 - 4ac form loses every digit on small spheres seen from afar: it misses this
    bound by orders of magnitude for r = 1e-4 (checked below on the same rays)."""
    flat = flat_of(m.Sphere(center=c, radius=r, material=MAT))
    rng = np.random.default_rng(25)
    o, d = sphere_rays(c, r, rng, 1500)
    t, prim, _, p, n, uv = probe(flat, o, d)
    hit = np.flatnonzero(prim >= 0)
    assert len(hit) > 300
    naive_worst = 0.0
    for k in hit:
        bound = 8 * EPS * (1 + np.linalg.norm(o[k] - c) / r)
        assert surface_error(c, r, o[k], d[k], t[k]) <= bound, k
        ref = naive.sphere(c, r, tuple(o[k]), tuple(d[k]))
        if ref is not None:
            naive_worst = max(naive_worst, surface_error(c, r, o[k], d[k], ref[0]) / bound)
    assert np.allclose(np.linalg.norm(n[hit], axis=1), 1.0, atol=1e-15)
    if r < 1e-3:
        assert naive_worst > 100


def random_rays(rng, n, spread=4.0):
    origins = rng.uniform(-spread, spread, (n, 3)) + rng.choice([-8.0, 8.0], (n, 3)) * (rng.random((n, 1)) < 0.5)
    targets = rng.uniform(-1.5, 1.5, (n, 3))
    return origins, (targets - origins) * rng.uniform(0.2, 3.0, (n, 1))


def rotation_chain(rng, n):
    """n random rotations and translations, then the same undone in reverse: the identity, composed of 2n steps."""
    steps = []
    for _ in range(n):
        if rng.random() < 0.5:
            steps.append((m.RotateStep(rotate=m.Rotation(axis=tuple(rng.normal(size=3)), degrees=float(rng.uniform(-180, 180)))), None))
        else:
            steps.append((m.TranslateStep(translate=tuple(rng.uniform(-5, 5, 3))), None))
    forward = [s for s, _ in steps]
    back = []
    for s in reversed(forward):
        if isinstance(s, m.RotateStep):
            back.append(m.RotateStep(rotate=m.Rotation(axis=s.rotate.axis, degrees=-s.rotate.degrees)))
        else:
            back.append(m.TranslateStep(translate=tuple(-x for x in s.translate)))
    return forward + back


BOX_LO, BOX_HI = (-0.5, -0.3, -0.8), (0.9, 0.6, 0.4)


def transformed_cases():
    """name: transform steps of the box; each case maps it onto an axis-aligned box."""
    rng = np.random.default_rng(26)
    rot = lambda axis, deg: m.RotateStep(rotate=m.Rotation(axis=axis, degrees=deg))  # noqa: E731
    return {
        "rotate_90_y": [rot("y", 90)],
        "rotate_180_x": [rot("x", 180)],
        "rotate_360_skew": [rot((1, 2, 3), 360)],
        "four_quarter_turns": [rot("z", 90)] * 4,
        "thirty_six_tens": [rot("y", 10)] * 36,
        "chain_of_80": rotation_chain(rng, 40),
        "scale_1e-3": [m.ScaleStep(scale=1e-3), m.TranslateStep(translate=(2e-3, 0, -1e-3))],
        "non_uniform": [m.ScaleStep(scale=(2.0, 0.5, 3.0))],
        "mirror": [m.ScaleStep(scale=(-1.0, 1.0, 1.0))],
    }


def box_in_place(steps):
    """The axis-aligned box the steps map BOX_LO..BOX_HI onto, its corners rounded to 12 places
    (the exact image; the composed matrix carries rounding of 1e-14)."""
    world = affine.from_steps(steps)
    corners = np.array([affine.apply_point(world, (x, y, z)) for x in (BOX_LO[0], BOX_HI[0])
                        for y in (BOX_LO[1], BOX_HI[1]) for z in (BOX_LO[2], BOX_HI[2])])
    return tuple(np.round(corners.min(axis=0), 12)), tuple(np.round(corners.max(axis=0), 12))


@pytest.mark.parametrize("how", ["instance", "baked"])
@pytest.mark.parametrize("name", list(transformed_cases()))
def test_transformed_box_equals_the_box_built_in_place(name, how):
    """Hits and normals of a transformed box agree with the same box built without a transform,
    whether the transform is baked into the faces or applied to rays by an instance."""
    steps = transformed_cases()[name]
    lo, hi = box_in_place(steps)
    box = m.Box(min=BOX_LO, max=BOX_HI, material=MAT)
    if how == "instance":
        transformed = flat_of(m.Instance(group=m.Group(shapes=[box]), transform=steps))
        assert transformed.inst_i[0, 1] == 0 or affine.is_identity(affine.from_steps(steps))
    else:
        transformed = flat_of(box.model_copy(update={"transform": steps}))
    direct = flat_of(m.Box(min=lo, max=hi, material=MAT))
    size = max(np.abs(lo).max(), np.abs(hi).max())
    extent = np.subtract(hi, lo)
    o, d = random_rays(np.random.default_rng(27), 3000)
    o, d = np.add(lo, hi) / 2 + o * extent, d * extent  # the same rays around the box, stretched to its shape
    t1, p1, _, x1, n1, _ = probe(transformed, o, d)
    t2, p2, _, x2, n2, _ = probe(direct, o, d)
    compared = 0
    for k in range(len(o)):
        if p2[k] >= 0 and near_edges(lo, hi, x2[k], 1e-9 * size) >= 2:
            continue  # on an edge: either face, or a miss, is right
        assert (p1[k] >= 0) == (p2[k] >= 0), k
        if p2[k] >= 0:
            compared += 1
            assert t1[k] == pytest.approx(t2[k], rel=1e-9, abs=1e-12)
            assert n1[k] == pytest.approx(n2[k], abs=1e-9)
            assert x1[k] == pytest.approx(x2[k], abs=1e-9 * size)
    assert compared > 500


def near_edges(lo, hi, p, tol):
    """On how many axes point p lies within tol of the box's faces (2 or more: on an edge)."""
    return sum(min(abs(p[a] - lo[a]), abs(hi[a] - p[a])) <= tol for a in range(3))


@pytest.mark.parametrize("scale", [(2.0, 0.5, 3.0), (1e-3, 1e-3, 1e-3), (1e-3, 2e-3, 5e-4)])
def test_scaled_sphere_equals_the_ellipsoid(scale):
    """A sphere under a scale (an instance unless the scale is uniform) agrees with the
    ellipsoid x^2/a^2 + y^2/b^2 + z^2/c^2 = r^2 solved directly."""
    a = np.array(scale)
    r = 0.8
    inst = flat_of(m.Instance(group=m.Group(shapes=[m.Sphere(center=(0, 0, 0), radius=r, material=MAT)]),
                              transform=[m.ScaleStep(scale=scale)]))
    baked = flat_of(m.Sphere(center=(0, 0, 0), radius=r, material=MAT, transform=[m.ScaleStep(scale=scale)]))
    rng = np.random.default_rng(28)
    o = rng.uniform(-3, 3, (2000, 3)) * a
    d = (rng.uniform(-0.8, 0.8, (2000, 3)) * a - o) * rng.uniform(0.2, 3, (2000, 1))
    for flat in (inst, baked):
        t, prim, _, x, n, _ = probe(flat, o, d)
        # In the sphere's own space the ray is (o / a) + t (d / a).
        oo, dd = o / a, d / a
        A, B, C = (dd * dd).sum(1), (oo * dd).sum(1), (oo * oo).sum(1) - r * r
        disc = B * B - A * C
        t_ref = np.where(disc >= 0, (-B - np.sqrt(np.maximum(disc, 0))) / A, np.inf)
        t_ref = np.where(t_ref > 0, t_ref, np.where(disc >= 0, (-B + np.sqrt(np.maximum(disc, 0))) / A, np.inf))
        t_ref = np.where(t_ref > 0, t_ref, np.inf)
        clear = np.abs(disc) > 1e-6 * B * B  # away from the silhouette
        assert np.array_equal(np.isfinite(t[clear]), np.isfinite(t_ref[clear]))
        hit = clear & np.isfinite(t_ref)
        assert hit.sum() > 400
        assert np.allclose(t[hit], t_ref[hit], rtol=1e-9)
        grad = (o[hit] + t_ref[hit, None] * d[hit]) / (a * a)  # gradient of the ellipsoid's equation
        assert np.allclose(n[hit], grad / np.linalg.norm(grad, axis=1)[:, None], atol=1e-9)
