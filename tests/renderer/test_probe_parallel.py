"""The parallel closest-hit query (probe.closest_hits) answers what the serial probe_rays does."""

import numpy as np
import pytest

from renderer.compile import compile_scene
from renderer.tracing.probe import CLOSEST_HITS_CHUNK, closest_hits, probe_rays
from scenefmt import meshgen
from scenefmt import models as m
from scenefmt.graph import build_graph

pytestmark = pytest.mark.slow

MAT = m.Lambertian(albedo=(0.5, 0.5, 0.5))


def test_parallel_closest_hits_agree_with_probe_rays_on_meshes_spheres_and_instances():
    v, f = meshgen.terrain(12, size=4.0, height=0.4)
    mesh = m.Mesh(vertices=v, faces=f, material=MAT)
    knot_v, knot_f = meshgen.torus_knot(segments=48, sides=8)
    group = m.Group(shapes=[m.Mesh(vertices=knot_v, faces=knot_f, material=MAT), m.Sphere(center=(0, 1, 0), radius=0.5, material=MAT)])
    shapes = [m.Sphere(center=(1, -1, 0), radius=0.7, material=MAT), mesh,
              m.Instance(group="g", transform=[m.RotateStep(rotate=m.Rotation(axis="x", degrees=70))]),
              m.Instance(group="g", transform=[m.TranslateStep(translate=(0.5, 0.3, -1.0))])]
    scene = m.Scene(camera=m.Camera(look_from=(0, 0, 10), look_at=(0, 0, 0)), shapes=shapes, groups={"g": group})
    flat = compile_scene(build_graph(scene))
    rng = np.random.default_rng(8)
    n = 2 * CLOSEST_HITS_CHUNK + 123  # three chunks, the last one short
    o = rng.uniform(-5, 5, (n, 3))
    d = rng.uniform(-1.5, 1.5, (n, 3)) - o
    t1, p1, i1, *_ = probe_rays(flat, o, d, 0.0, 0.0, False)
    t2, p2, i2 = closest_hits(flat, o, d, 0.0, 0.0)
    assert (p1 >= len(flat.prims_f)).sum() > 1000 and (p1 < 0).sum() > 1000  # mesh hits and misses both
    assert len(np.unique(i1[p1 >= 0])) == 3  # the top level and both instances
    # The same search on each ray: the same answers to the bit, whichever thread ran it.
    assert np.array_equal(p1, p2) and np.array_equal(i1, i2) and np.array_equal(t1, t2)
    # Starting further along each ray, the same again.
    t3, p3, i3, *_ = probe_rays(flat, o, d, 0.0, 0.05, False)
    t4, p4, i4 = closest_hits(flat, o, d, 0.0, 0.05)
    assert np.array_equal(p3, p4) and np.array_equal(t3, t4)
