"""The mask the light-sampling benchmarks measure error over (benchmarks/light_pixels.py): it must
leave out every pixel a light covers, wholly or in part, and keep the pixels no light reaches."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scenefmt import models as m
from scenefmt.graph import build_graph
from tests.renderer.scenes import pixel_rays, render_scene, scene

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from light_pixels import kept_pixels, sees_light  # noqa: E402

# Renders or runs the compiled kernels (tests/conftest.py).
pytestmark = pytest.mark.slow

# A small lamp whose edges cut through pixels, in front of a white wall it lights.
LAMP = m.Quad(q=(-0.53, -0.07, 0.0), u=(0.81, 0.0, 0.0), v=(0.0, 0.77, 0.0), material=m.DiffuseLight(emit=(2.0, 2.0, 2.0)))
WALL = m.Quad(q=(-9.0, -9.0, -3.0), u=(18.0, 0.0, 0.0), v=(0.0, 18.0, 0.0), material=m.Lambertian(albedo=(0.7, 0.7, 0.7)))
VIEW = dict(look_from=(0.0, 0.0, 5.0), look_at=(0.0, 0.0, 0.0), vfov=30.0, background=(0.0, 0.0, 0.0), width=24, height=24)


def lamp_coverage(sc) -> np.ndarray:
    """Per pixel, the share of a 16 x 16 grid of its camera rays that meet the lamp (the plane z = 0)."""
    origin, d = pixel_rays(sc, sub=16)
    t = -origin[2] / d[..., 2]
    x = origin[0] + t * d[..., 0]
    y = origin[1] + t * d[..., 1]
    inside = (x >= -0.53) & (x <= 0.28) & (y >= -0.07) & (y <= 0.70)
    return inside.mean(axis=-1)


def test_every_pixel_the_lamp_covers_is_left_out_and_no_other():
    sc = scene([LAMP, WALL], samples=64, max_depth=8, **VIEW)
    graph = build_graph(sc)
    cover = lamp_coverage(sc)
    seen = sees_light(graph)
    # A pixel a tenth covered is missed by all 256 first-hit samples with probability 0.9^256 ~ 2e-12.
    assert seen[cover >= 0.1].all()
    assert not seen[cover == 0.0].any()
    image = render_scene([LAMP, WALL], samples=64, max_depth=8, **VIEW).film.mean()
    keep = kept_pixels(graph, image)
    dark = image.max(axis=2) <= 1.0
    # The rim a test of brightness alone keeps: pixels the lamp covers in part, darker than 1.
    rim = (cover > 0.0) & dark
    assert rim.sum() >= 4
    assert not keep[rim].any()
    assert keep[(cover == 0.0) & dark].all()
