"""One-sided area lights (`diffuse_light` with `sides: front`): only the face the shape's normal
points out of emits.

- The model and the material row: `sides` defaults to the books' `both`; `front` sets the row's
  `one_sided` column, which `one_sided_rows` reads back.
- The power a one-sided light sends is pi A L, half a two-sided light's: its `power` and its
  share of the light choices halve.
- The material's `emitted` is black from behind only; the light sampler never gives a point of a
  one-sided light that turns its back to the shading point (not ok: no shadow ray is cast), and
  the points it does give have the two-sided light's density and radiance.
- Images: a lamp facing what it lights renders bit for bit as the two-sided lamp, facing away it
  renders black; in a closed box, where the back of a two-sided lamp would light the ceiling,
  `mis` converges to what `path` renders (block z-tests at a family-wise level), and the same
  test tells the two-sided lamp's image apart (the control).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from renderer.materials.table import MAT_ONE_SIDED, MATERIAL_I, material_rows, one_sided_rows
from scenefmt.materials import DiffuseLight, Lambertian, Principled
from tests.renderer.stats import block_z, z_limit

LAMP = (4.0, 3.0, 2.0)


# --- the model and the material row (no kernel) ------------------------------------------------


def test_sides_defaults_to_the_books_both_and_refuses_anything_but_front():
    assert DiffuseLight().sides == "both"
    assert DiffuseLight(sides="front").sides == "front"
    with pytest.raises(ValidationError, match="sides"):
        DiffuseLight(sides="back")


def test_only_a_front_light_row_is_one_sided():
    rows = [material_rows(model, 0)[0] for model in
            (DiffuseLight(), DiffuseLight(sides="front"), Lambertian(), Principled(emission=LAMP))]
    assert [row[MAT_ONE_SIDED] for row in rows] == [0, 1, 0, 0]
    mat_i = np.array(rows, np.int32)
    assert mat_i.shape[1] == MATERIAL_I.width
    assert one_sided_rows(mat_i).tolist() == [False, True, False, False]


def test_a_misspelt_side_is_one_sentence_naming_the_key():
    from scenefmt.validation import SceneError, loads

    with pytest.raises(SceneError) as error:
        loads("camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\n"
              "materials: {lamp: {type: diffuse_light, emit: [1, 1, 1], sides: back}}\n"
              "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: lamp}]\n")
    assert str(error.value) == "<string>:2:65: error: materials.lamp.sides: expected 'both' or 'front', found 'back'"


# --- flattened lights and the kernels' answers -------------------------------------------------

CAMERA = "camera: {look_from: [0, 0, 5], look_at: [0, 0, 0]}\nimage: {width: 8, aspect_ratio: 1}\n"


def flat_of(materials: str, shapes: str):
    from renderer.compile import compile_scene
    from scenefmt.validation import loads

    return compile_scene(loads(f"materials: {{{materials}}}\n{CAMERA}shapes: [{shapes}]\n").graph)


def lamps(front: str, back: str = "both") -> str:
    return (f"front: {{type: diffuse_light, emit: [4, 3, 2], sides: {front}}}, "
            f"other: {{type: diffuse_light, emit: [4, 3, 2], sides: {back}}}")


# A unit square at y = 1 facing down (u x v = -y), and one at y = 2 facing up.
DOWN = "{type: quad, q: [0, 1, 0], u: [1, 0, 0], v: [0, 0, 1], material: MAT}"
UP = "{type: quad, q: [0, 2, 0], u: [0, 0, 1], v: [1, 0, 0], material: MAT}"


@pytest.mark.slow
def test_a_one_sided_light_sends_half_the_power_of_a_two_sided_one():
    from renderer.lights import LIGHT_KIND, LIGHT_PMF, LIGHT_POWER, LIGHT_PRIMITIVE
    from renderer.shapes import PRIM_MATERIAL

    flat = flat_of(lamps("front"), DOWN.replace("MAT", "front") + ", " + UP.replace("MAT", "other"))
    one = one_sided_rows(flat.mat_i)[flat.prims_i[flat.light_i[:, LIGHT_PRIMITIVE], PRIM_MATERIAL]]
    assert one.tolist().count(True) == 1 and (flat.light_i[:, LIGHT_KIND] == 1).all()
    luminance = 0.2126 * 4 + 0.7152 * 3 + 0.0722 * 2  # both are unit squares
    power = flat.light_f[:, LIGHT_POWER]
    assert power[one][0] == pytest.approx(math.pi * luminance, rel=1e-12)  # pi A L
    assert power[~one][0] == pytest.approx(2 * math.pi * luminance, rel=1e-12)  # 2 pi A L
    assert flat.light_f[one, LIGHT_PMF][0] == pytest.approx(1 / 3, rel=1e-12)
    assert flat.light_f[~one, LIGHT_PMF][0] == pytest.approx(2 / 3, rel=1e-12)


@pytest.mark.slow
def test_emitted_is_black_from_behind_only_for_a_one_sided_light():
    from tests.renderer.kernel_calls import emission_of

    for model, back in ((DiffuseLight(emit=LAMP), LAMP), (DiffuseLight(emit=LAMP, sides="front"), (0.0, 0.0, 0.0))):
        ints, floats = material_rows(model, 0)
        mat_i, mat_f = np.array([ints], np.int32), np.array([floats])
        emits, seen = emission_of(mat_i, mat_f, np.array(LAMP), True)
        assert emits and seen.tolist() == list(LAMP)
        emits, seen = emission_of(mat_i, mat_f, np.array(LAMP), False)
        assert emits and seen.tolist() == list(back)


def samples_from(flat, p, n=4000, seed=3):
    """`sample_li` from p, with pdf_li of what the ray along each direction meets first
    (kernel_calls.light_samples' rows)."""
    from tests.renderer.kernel_calls import light_samples

    return light_samples(flat, np.array(p, float), 0.0, seed, n)


@pytest.mark.slow
def test_the_light_sampler_gives_no_point_from_behind_and_the_two_sided_density_in_front():
    # Between a one-sided lamp facing down (y = 1) and one facing up (y = 2): from y = 1.5 both
    # turn their back, from below only the lower one faces p, from above only the upper one.
    shapes = DOWN.replace("MAT", "front") + ", " + UP.replace("MAT", "other")
    one = flat_of(lamps("front", "front"), shapes)
    two = flat_of(lamps("both", "both"), shapes)
    between = samples_from(one, [0.5, 1.5, 0.5])
    assert not between[:, 0].any(), "a point sampled from behind a one-sided light"
    for p, facing in (([0.3, 0.2, 0.6], 1.0), ([0.7, 2.9, 0.4], 2.0)):
        a, b = samples_from(one, p), samples_from(two, p)  # the same random numbers
        ok = a[:, 0] == 1.0
        hit_y = p[1] + a[:, 4] * a[:, 2]  # y of the point drawn: p + dist wi
        assert np.all(np.abs(hit_y[ok] - facing) < 1e-9), "a one-sided lamp gave a point of its back"
        # Both lamps have the same power, so about half the choices go to the one facing p;
        # what the two-sided scene drew on that lamp is drawn alike, with its density and radiance.
        on_facing = (b[:, 0] == 1.0) & (np.abs(p[1] + b[:, 4] * b[:, 2] - facing) < 1e-9)
        assert np.array_equal(ok, on_facing)
        assert abs(ok.mean() - 0.5) < 0.05
        assert np.array_equal(a[ok, 1:9], b[ok, 1:9])
        # And pdf_li of the hit agrees with the density the sampler gave (pdf_area_light unchanged).
        assert np.allclose(a[ok, 9], a[ok, 5], rtol=1e-6)


@pytest.mark.slow
def test_a_one_sided_sphere_lights_nothing_inside_it_and_everything_it_faces_outside():
    flat = flat_of(lamps("front"), "{type: sphere, center: [0, 0, 0], radius: 1, material: front}")
    assert not samples_from(flat, [0.2, -0.3, 0.1])[:, 0].any()
    outside = samples_from(flat, [0.5, 2.5, -1.0])
    assert outside[:, 0].all() and np.all(outside[:, 5] > 0)


# --- images ------------------------------------------------------------------------------------


def render_film(scene):
    from renderer.render import render
    from renderer.variants import GENERAL
    from scenefmt.graph import build_graph

    result = render(build_graph(scene), features=GENERAL)
    assert result.stats.bad_samples == 0
    return result.film


def floor_scene(lamp, *, face_down=True, integrator="mis", seed=1, samples=16):
    """A floor under a square lamp at height 1.5, seen from below the lamp, which is in view."""
    from scenefmt import models as m

    u, v = ((1, 0, 0), (0, 0, 1)) if face_down else ((0, 0, 1), (1, 0, 0))  # u x v: -y, +y
    return m.Scene(
        camera=m.Camera(look_from=(0.0, 1.0, 4.0), look_at=(0.0, 0.6, 0.0), vfov=60.0),
        image=m.Image(width=16, height=16, samples_per_pixel=samples, max_depth=4, seed=seed, integrator=integrator),
        background=m.SolidBackground(color=(0.0, 0.0, 0.0)),
        shapes=[
            m.Quad(q=(-3, 0, -3), u=(6, 0, 0), v=(0, 0, 6), material=Lambertian(albedo=(0.7, 0.7, 0.7))),
            m.Quad(q=(-0.5, 1.5, -0.5), u=u, v=v, material=lamp),
        ],
    )


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["mis", "path"])
def test_a_lamp_facing_the_floor_renders_as_the_two_sided_one_and_facing_away_black(integrator):
    two = render_film(floor_scene(DiffuseLight(emit=LAMP), integrator=integrator))
    front = render_film(floor_scene(DiffuseLight(emit=LAMP, sides="front"), integrator=integrator))
    away = render_film(floor_scene(DiffuseLight(emit=LAMP, sides="front"), face_down=False, integrator=integrator))
    assert two.total.sum() > 0
    # Nothing reaches the two-sided lamp's back (nothing is above it): the same paths, the same bits.
    assert np.array_equal(front.total, two.total) and np.array_equal(front.total_sq, two.total_sq)
    assert not away.total.any(), "light from the back of a one-sided lamp"


def box_scene(lamp, *, integrator, seed, samples):
    """A closed white box of side 2 with a square lamp hanging at 3/4 of its height, facing down
    (u x v = -y), its back to the ceiling; seen from inside near the front wall."""
    from scenefmt import models as m

    white = Lambertian(albedo=(0.75, 0.75, 0.75))
    red, green = Lambertian(albedo=(0.7, 0.1, 0.1)), Lambertian(albedo=(0.1, 0.6, 0.1))
    walls = [
        m.Quad(q=(-1, 0, -1), u=(2, 0, 0), v=(0, 0, 2), material=white),  # floor
        m.Quad(q=(-1, 2, -1), u=(2, 0, 0), v=(0, 0, 2), material=white),  # ceiling
        m.Quad(q=(-1, 0, -1), u=(2, 0, 0), v=(0, 2, 0), material=white),  # back
        m.Quad(q=(-1, 0, 1), u=(2, 0, 0), v=(0, 2, 0), material=white),  # front, behind the camera
        m.Quad(q=(-1, 0, -1), u=(0, 2, 0), v=(0, 0, 2), material=red),
        m.Quad(q=(1, 0, -1), u=(0, 2, 0), v=(0, 0, 2), material=green),
    ]
    return m.Scene(
        camera=m.Camera(look_from=(0.0, 1.0, 0.95), look_at=(0.0, 1.0, 0.0), vfov=90.0),
        image=m.Image(width=16, height=16, samples_per_pixel=samples, max_depth=6, seed=seed, integrator=integrator),
        background=m.SolidBackground(color=(0.0, 0.0, 0.0)),
        shapes=walls + [m.Quad(q=(-0.3, 1.5, -0.3), u=(0.6, 0, 0), v=(0, 0, 0.6), material=lamp)],
    )


@pytest.mark.slow
def test_mis_converges_to_path_in_a_box_lit_by_a_one_sided_lamp():
    front = DiffuseLight(emit=(6.0, 6.0, 6.0), sides="front")
    mis = render_film(box_scene(front, integrator="mis", seed=11, samples=64))
    path = render_film(box_scene(front, integrator="path", seed=12, samples=256))
    z = block_z(mis, path, block=4)
    limit = z_limit(z.size)
    assert np.abs(z).max() < limit
    # Control: the two-sided lamp lights the ceiling from its back, and the same test sees it.
    two = render_film(box_scene(DiffuseLight(emit=(6.0, 6.0, 6.0)), integrator="path", seed=13, samples=256))
    assert np.abs(block_z(mis, two, block=4)).max() > limit
