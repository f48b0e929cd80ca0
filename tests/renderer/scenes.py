"""Small scenes built in Python for the robustness, furnace and property tests."""

from __future__ import annotations

import numpy as np

from renderer.variants import GENERAL
from renderer.render import render
from scenefmt import models as m
from scenefmt.graph import build_graph

WHITE = (1.0, 1.0, 1.0)


def scene(shapes, *, look_from=(0.0, 2.5, 5.0), look_at=(0.0, 0.4, 0.0), vfov=40.0, background=WHITE,
          width=16, height=16, samples=16, max_depth=1000, seed=1, defocus_angle=0.0, **image):
    bg = background if isinstance(background, (m.SolidBackground, m.SkyBackground)) else m.SolidBackground(color=background)
    return m.Scene(
        camera=m.Camera(look_from=look_from, look_at=look_at, vfov=vfov, defocus_angle=defocus_angle),
        image=m.Image(width=width, height=height, samples_per_pixel=samples, max_depth=max_depth, seed=seed, **image),
        background=bg,
        shapes=list(shapes),
    )


def render_scene(shapes, **kw):
    """Render a scene of `shapes` (keywords as `scene`); returns the RenderResult."""
    return render(build_graph(scene(shapes, **kw)), features=GENERAL)


def cluster(material, interior=None):
    """A ground quad with spheres, a box, a triangle and a disk on it, all of one material.

    The shapes touch the ground and stand close, so paths bounce between them (crevices, contact
    points, grazing angles on the ground, a box face coplanar with the ground) before they
    escape. They do not overlap: a surface inside a glass box would scatter rays into directions
    that total internal reflection then traps for good (at ior 10 every direction outside a 5.7
    degree cone about each face's normal), a real loss of energy to the depth cut. `interior` fills the closed shapes with a
    medium as well (then `material` may be None: invisible boundaries).
    """
    closed = dict(material=material, interior=interior)
    return [
        m.Quad(q=(-3, 0, -3), u=(6, 0, 0), v=(0, 0, 6), material=material or m.Lambertian(albedo=WHITE)),
        m.Sphere(center=(0, 0.6, 0), radius=0.6, **closed),
        m.Sphere(center=(1.05, 0.4, 0.35), radius=0.4, **closed),
        m.Box(min=(-1.7, 0, -0.6), max=(-0.75, 0.9, 0.3), transform=[m.RotateStep(rotate=m.Rotation(axis="y", degrees=25))],
              **closed),
        m.Triangle(vertices=((0.3, 0, 1.2), (1.4, 0, 1.0), (0.8, 0.9, 0.7)), material=material or m.Lambertian(albedo=WHITE)),
        m.Disk(center=(-0.2, 0.45, 1.5), normal=(0.2, 1, 0.6), radius=0.35, material=material or m.Lambertian(albedo=WHITE)),
    ]


def pixel_rays(graph_scene, sub: int = 8, corners: bool = False):
    """Origins and unit directions of a pinhole camera's rays on a sub x sub grid in every pixel.

    The grid's points are the centres of sub x sub cells, or with `corners` evenly spaced from
    edge to edge (the pixel's four corners are then points 0, sub - 1, -sub and -1).
    Mirrors renderer.compile.camera_values (checked by the sampling tests), so tests can compute
    what each pixel should see by quadrature over its footprint: shape (h, w, sub*sub, 3).
    """
    from renderer.compile import camera_values

    cam = np.array(camera_values(build_graph(graph_scene)))
    h, w = graph_scene.image.pixel_height, graph_scene.image.width
    offs = np.linspace(-0.5, 0.5, sub) if corners else (np.arange(sub) + 0.5) / sub - 0.5
    ox, oy = np.meshgrid(offs, offs, indexing="xy")
    ox, oy = ox.ravel(), oy.ravel()
    j, i = np.mgrid[0:h, 0:w]
    fi = i[..., None] + ox
    fj = j[..., None] + oy
    target = cam[3:6] + fi[..., None] * cam[6:9] + fj[..., None] * cam[9:12]
    d = target - cam[0:3]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return cam[0:3], d
