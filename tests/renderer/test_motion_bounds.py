"""Moving transforms on the numpy side: keyframes split into translation, rotation and stretch give
back their maps, interpolation follows pbrt-v4's rule, and the bounds of a moving box hold every
intermediate position (randomised, seeded)."""

import math

import numpy as np
import pytest

from renderer.motion import BOUND_SAMPLES, KEY_Q, keyframe_rows, map_at_numpy, motion_bounds
from scenefmt import affine


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def random_map(rng, mirror=False):
    """A rotation after a non-uniform scale (perhaps a mirror), then a translation: 3x4."""
    scale = rng.uniform(0.3, 3.0, size=3) * (np.array([-1.0, 1.0, 1.0]) if mirror else 1.0)
    m = np.zeros((3, 4))
    m[:, :3] = random_rotation(rng) @ np.diag(scale)
    m[:, 3] = rng.uniform(-10, 10, size=3)
    return m


@pytest.mark.parametrize("seed", range(20))
def test_each_keyframe_gives_back_its_map(seed):
    rng = np.random.default_rng(seed)
    maps = [random_map(rng, mirror=seed % 2 == 1) for _ in range(3)]
    rows = keyframe_rows([0.0, 0.5, 2.0], maps)
    for t, m in zip((0.0, 0.5, 2.0), maps):
        assert np.allclose(map_at_numpy(rows, t), m, atol=1e-12 * (1 + np.abs(m).max()))
    # Held before the first keyframe and after the last.
    assert np.allclose(map_at_numpy(rows, -3.0), maps[0], atol=1e-12 * 30)
    assert np.allclose(map_at_numpy(rows, 9.0), maps[2], atol=1e-12 * 30)


def test_rotation_is_slerped_at_a_constant_rate_and_translation_is_linear():
    """A quarter turn about y with a move along x: a quarter of the way, a 22.5 degree turn and a
    quarter of the move (the books' rotate_y, as affine.rotation gives it)."""
    start = np.array(affine.IDENTITY)
    end = np.array(affine.compose(((1.0, 0, 0, 4.0), (0, 1.0, 0, 0), (0, 0, 1.0, 0)), affine.rotation("y", 90.0)))
    rows = keyframe_rows([0.0, 1.0], [start, end])
    expected = np.array(affine.compose(((1.0, 0, 0, 1.0), (0, 1.0, 0, 0), (0, 0, 1.0, 0)), affine.rotation("y", 22.5)))
    assert np.allclose(map_at_numpy(rows, 0.25), expected, atol=1e-12)


def test_quaternions_take_the_shorter_way():
    """A turn of 350 degrees written as its end is a turn of -10: the keyframes' quaternions sit
    on one side, so the object turns the short way."""
    rows = keyframe_rows([0.0, 1.0], [np.array(affine.IDENTITY), np.array(affine.rotation("z", 350.0))])
    assert np.dot(rows[0, KEY_Q:KEY_Q + 4], rows[1, KEY_Q:KEY_Q + 4]) > 0
    assert np.allclose(map_at_numpy(rows, 0.5), np.array(affine.rotation("z", -5.0)), atol=1e-12)


@pytest.mark.parametrize("seed", range(30))
def test_bounds_of_rotating_instances_hold_every_intermediate_position(seed):
    """Random keyframes (large turns about random axes, non-uniform scales, far from the origin)
    and a random object box: at random times, and at the midpoints between the times the bounds
    were sampled at (where a point strays farthest from its samples), the box's corners and
    random points inside it land inside the bounds."""
    rng = np.random.default_rng(1000 + seed)
    keys = int(rng.integers(2, 5))
    times = np.sort(rng.uniform(-1, 2, size=keys))
    maps = [random_map(rng, mirror=seed % 5 == 0) for _ in range(keys)]
    if seed % 3 == 0:  # a big turn about a far axis: the box sweeps an arc
        maps = [np.array(affine.compose(((1, 0, 0, 30.0), (0, 1, 0, 0), (0, 0, 1, 0)), affine.rotation("y", 170.0 * k)))
                for k in range(keys)]
    rows = keyframe_rows(times, maps)
    lo = rng.uniform(-3, 0, size=3)
    hi = lo + rng.uniform(0.1, 4, size=3)
    b_lo, b_hi = motion_bounds(rows, lo, hi)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    inside = lo + rng.uniform(size=(32, 3)) * (hi - lo)
    points = np.concatenate([corners, inside])
    between = [t0 + (t1 - t0) * (j + 0.5) / BOUND_SAMPLES for t0, t1 in zip(times, times[1:]) for j in range(BOUND_SAMPLES)]
    for t in np.concatenate([rng.uniform(times[0] - 0.5, times[-1] + 0.5, size=200), between]):
        m = map_at_numpy(rows, t)
        world = points @ m[:, :3].T + m[:, 3]
        assert (world >= b_lo).all() and (world <= b_hi).all(), (t, world.min(axis=0) - b_lo, b_hi - world.max(axis=0))


def test_bounds_are_tight_for_a_slide():
    """A pure translation: the box of the two ends, padded by no more than a hair."""
    rows = keyframe_rows([0.0, 1.0], [np.array(affine.IDENTITY), np.array(((1, 0, 0, 5.0), (0, 1, 0, 0), (0, 0, 1, 0)))])
    lo, hi = motion_bounds(rows, (0, 0, 0), (1, 1, 1))
    assert np.allclose(lo, (0, 0, 0), atol=0.05) and np.allclose(hi, (6, 1, 1), atol=0.05)
    assert (lo <= 0).all() and (hi >= (6, 1, 1)).all()


@pytest.mark.parametrize("stem", ["bouncing_spheres", "final_scene", "cornell_knot"])
def test_the_books_moving_spheres_and_still_scenes_flatten_no_keyframes(stem):
    """Pay only for what is used: the books' moving spheres keep their own rows, and no instance
    or camera of a scene without `motion:` names a keyframe."""
    from pathlib import Path

    from renderer.camera import CAM_FIRST_KEY, CAM_KEYS
    from renderer.compile import compile_scene
    from renderer.trees import INST_FIRST_KEY, INST_KEYS
    from scenefmt.validation import load

    flat = compile_scene(load(Path(__file__).resolve().parents[2] / "scenes" / f"{stem}.yaml").graph)
    assert flat.motion_f.shape[0] == 0
    assert (flat.inst_i[:, INST_KEYS] == 0).all() and (flat.inst_i[:, INST_FIRST_KEY] == -1).all()
    assert flat.camera[CAM_KEYS] == 0 and flat.camera[CAM_FIRST_KEY] == -1
