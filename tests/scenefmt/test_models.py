"""Model-level rules and the derived values the renderer relies on."""

import math

import pytest
from pydantic import ValidationError

from scenefmt.models import Box, Camera, Disk, Image, MatrixStep, Quad, ScaleStep, Shutter, Sphere, Triangle


def test_image_height_follows_width_and_aspect_ratio():
    assert Image(width=400, aspect_ratio=16 / 9).pixel_height == 225
    assert Image(width=400, aspect_ratio="16:9").pixel_height == 225
    assert Image(width=400, aspect_ratio="16/9").pixel_height == 225
    assert Image(width=600).pixel_height == 600
    assert Image(width=1, aspect_ratio=10).pixel_height == 1
    assert Image(width=200, height=50).pixel_height == 50


def test_defocus_angle_and_aperture_give_the_books_lens_radius():
    cam = Camera(look_from=(13, 2, 3), look_at=(0, 0, 0), defocus_angle=0.6, focus_distance=10)
    assert cam.lens_radius == pytest.approx(0.05236, abs=1e-5)
    assert Camera(aperture=2.0, look_from=(3, 3, 2), look_at=(0, 0, -1)).lens_radius == 1.0
    pinhole = Camera(look_from=(3, 3, 2), look_at=(0, 0, -1))
    assert pinhole.lens_radius == 0.0
    assert pinhole.focus == pytest.approx(math.sqrt(27))


@pytest.mark.parametrize("make, words", [
    (lambda: Camera(look_from=(1, 2, 3), look_at=(1, 2, 3)), "same point"),
    (lambda: Camera(look_from=(0, 5, 0), look_at=(0, 0, 0)), "parallel to the view direction"),
    (lambda: Camera(up=(0, 0, 0)), "zero vector"),
    (lambda: Camera(vfov=180), "less than 180"),
    (lambda: Camera(defocus_angle=1, aperture=0.1), "not both"),
    (lambda: Image(width=0), "greater than or equal to 1"),
    (lambda: Image(samples_per_pixel=0), "greater than or equal to 1"),
    (lambda: Image(width=10**6), "less than or equal to 32768"),
    (lambda: Image(height=10, aspect_ratio=2), "not both"),
    (lambda: Image(aspect_ratio="0:1"), "must be > 0"),
    (lambda: Shutter(open=1, close=0), "before it opens"),
    (lambda: Sphere(center=(0, 0, 0), radius=-1, material="m"), "hollow glass"),
    (lambda: Sphere(center=(0, 0, 0), radius=0, material="m"), "greater than 0"),
    (lambda: Sphere(center=(0, 0, 0), radius=1), "material"),
    (lambda: Quad(q=(0, 0, 0), u=(1, 0, 0), v=(-2, 0, 0), material="m"), "zero area"),
    (lambda: Quad(q=(0, 0, 0), u=(0, 0, 0), v=(0, 1, 0), material="m"), "zero area"),
    (lambda: Triangle(vertices=((0, 0, 0), (1, 1, 1), (2, 2, 2)), material="m"), "zero area"),
    (lambda: Disk(center=(0, 0, 0), normal=(0, 0, 0), radius=1, material="m"), "zero vector"),
    (lambda: Box(min=(0, 0, 0), max=(1, 0, 1), material="m"), "along y"),
    (lambda: ScaleStep(scale=(1, 0, 1)), "scale factor of 0"),
    (lambda: MatrixStep(matrix=[[1, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]]), "singular"),
    (lambda: MatrixStep(matrix=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]), "4th row"),
])
def test_semantic_rules_reject_degenerate_input(make, words):
    with pytest.raises(ValidationError, match=words):
        make()


def test_strings_and_booleans_are_not_numbers():
    with pytest.raises(ValidationError):
        Sphere(center=(0, 0, 0), radius="2", material="m")
    with pytest.raises(ValidationError):
        Sphere(center=(0, 0, 0), radius=True, material="m")
    with pytest.raises(ValidationError):
        Sphere(center=(0, 0, float("nan")), radius=1, material="m")
