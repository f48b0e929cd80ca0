"""The guided integrator (integrator: guided): its training records, its determinism, and that it
converges to mis's image (tracing/integrator.py, guide_training.py, guide_records.py).

The guide's own sampler and density are tested in test_guiding.py; here the integrator's use of
them: records that carry exactly the radiance that came back along each direction, the same
guide and image on any number of threads and after a resume, and region z-tests against mis.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import rt
from renderer.guide_records import GUIDE_RECORD, REC_D, REC_L, REC_P, REC_PDF, RECORDS_PER_PATH, record_weights
from renderer.guide_training import TRAINING_PATHS, training_rows, training_seed
from scenefmt.bounds import GUIDE_TRAINING_BYTES

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stats import block_z, film_mean_and_se, z_limit  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell_box.yaml"
CAUSTIC = ROOT / "benchmarks" / "scenes" / "caustic_glass.yaml"

# A matte floor under a plain background (no light to sample): a path that leaves the floor upward
# escapes, so the radiance that came back along its direction is exactly the background's.
SKY_FLOOR = """
camera: {look_from: [0, 2, 4], look_at: [0, 0, 0], vfov: 40}
image: {width: 8, height: 6, samples_per_pixel: 1, max_depth: 2, integrator: guided}
background: {type: solid, color: [0.5, 0.6, 0.7]}
materials:
  floor: {type: lambertian, albedo: [0.8, 0.8, 0.8]}
shapes:
  - {type: quad, q: [-50, 0, -50], u: [100, 0, 0], v: [0, 0, 100], material: floor}
"""


def test_training_rows_spread_the_paths_and_never_pass_the_image():
    for width, height in ((48, 36), (320, 180), (600, 600), (1, 1), (4096, 3)):
        for paths in TRAINING_PATHS:
            rows, spp = training_rows(width, height, paths)
            assert 1 <= rows <= height and spp >= 1
            made = rows * width * spp
            assert made >= min(paths, width * height)  # at least the paths asked for, or the whole image
            assert made < paths + width * spp or rows == height and made <= paths + width * height


def test_training_seeds_differ_by_iteration_and_from_the_render():
    seeds = {training_seed(7, i) for i in range(len(TRAINING_PATHS))}
    assert len(seeds) == len(TRAINING_PATHS) and 7 not in seeds
    assert all(0 <= s < 2**63 for s in seeds)


def test_record_weights_are_luminance_over_density_and_drop_unopened_and_bad_rows():
    rec = np.zeros((4, GUIDE_RECORD.width))
    rec[0, REC_P:REC_P + 3] = (1, 2, 3)
    rec[0, REC_D:REC_D + 3] = (0, 1, 0)
    rec[0, REC_PDF] = 0.5
    rec[0, REC_L:REC_L + 3] = (1.0, 1.0, 1.0)
    rec[1, REC_PDF] = 0.0  # never opened
    rec[2, REC_PDF] = 2.0
    rec[2, REC_L] = np.nan
    rec[3, REC_PDF] = 1.0
    rec[3, REC_L:REC_L + 3] = (0.0, 2.0, 0.0)
    positions, directions, weights = record_weights(rec)
    assert positions.tolist() == [[1, 2, 3], [0, 0, 0]]
    assert directions.tolist() == [[0, 1, 0], [0, 0, 0]]
    assert weights == pytest.approx([1.0 / 0.5, 2 * 0.7152])


def test_the_memory_estimate_covers_the_training_buffers():
    width = 4096  # the widest row rounding a path count up by a row's worth of paths
    rows = max(TRAINING_PATHS) + width
    buffer = rows * RECORDS_PER_PATH * GUIDE_RECORD.width * 8
    kept = rows * RECORDS_PER_PATH * 7 * 8
    assert buffer + kept < GUIDE_TRAINING_BYTES


def _records_of(scene_text, width):
    """The records of one training pass over the whole image of a scene, with its guide empty."""
    from renderer.film import Film
    from renderer.flat import INTEGRATOR_GUIDED, Frame
    from renderer.sampling import Sampling
    from renderer.session import flatten_loaded
    from renderer.variants import GENERAL, kernel_set

    loaded = rt.load(__import__("yaml").safe_load(scene_text))
    graph, flat = flatten_loaded(loaded, width)
    frame = Frame.of(graph)
    spp = 4
    rec = np.zeros((frame.width * frame.height * spp * RECORDS_PER_PATH, GUIDE_RECORD.width))
    film = Film.empty(frame.width, frame.height)
    rays = np.zeros(frame.height, np.int64)
    kernel_set(GENERAL).render_pass(flat, frame.width, frame.height, 3, 0, spp, frame.max_depth, INTEGRATOR_GUIDED,
                                    Sampling(0), film.sums, rays, rays.copy(), 0, frame.height, rec)
    return rec, film


@pytest.mark.slow
def test_a_record_carries_exactly_the_radiance_that_came_back_along_its_direction():
    rec, film = _records_of(SKY_FLOOR, 8)
    opened = rec[rec[:, REC_PDF] > 0]
    # Every path hits the floor and leaves it upward: one record each (max_depth 2 ends it there).
    assert len(opened) == 8 * 6 * 4
    assert np.all(opened[:, REC_D + 1] > 0)
    assert np.allclose(opened[:, REC_P + 1], 0.0, atol=1e-9)
    assert np.allclose(opened[:, REC_L:REC_L + 3], [0.5, 0.6, 0.7], rtol=1e-12)
    # The density is the lambertian's, cos / pi.
    assert np.allclose(opened[:, REC_PDF], opened[:, REC_D + 1] / np.pi, rtol=1e-9)
    # The pixels got 0.8 x the background, as mis renders this scene.
    assert np.allclose(film.total / 4, 0.8 * np.array([0.5, 0.6, 0.7]), rtol=1e-12)


@pytest.mark.slow
def test_the_guide_and_the_image_are_the_same_on_any_thread_count():
    one = rt.render(CAUSTIC, spp=8, width=24, seed=4, integrator="guided", kernel="general", threads=1)
    two = rt.render(CAUSTIC, spp=8, width=24, seed=4, integrator="guided", kernel="general", threads=2)
    assert one.stats.guide_training.guide_rows > 1  # a guide was learned
    assert np.array_equal(one.film.total, two.film.total) and np.array_equal(one.film.total_sq, two.film.total_sq)


@pytest.mark.slow
def test_rt_render_guided_resumed_is_the_whole_render_bit_for_bit(tmp_path):
    """As a user runs it, in fresh processes: the resumed render trains the same guide again."""
    import subprocess

    def run(*args):
        out = subprocess.run([sys.executable, "-m", "rt", "render", str(CAUSTIC), "--width", "16", "--seed", "9",
                              "--integrator", "guided", "--kernel", "general", *args], cwd=tmp_path,
                             capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        return out

    run("--spp", "4", "--save-state", "s.npz", "-o", "first.png")
    resumed = run("--spp", "8", "--resume", "s.npz", "--hdr", "b.pfm", "-o", "b.png")
    assert "resuming s.npz: 4 samples per pixel already rendered" in resumed.stderr
    run("--spp", "8", "--hdr", "c.pfm", "-o", "c.png")
    assert (tmp_path / "b.pfm").read_bytes() == (tmp_path / "c.pfm").read_bytes()


@pytest.mark.slow
def test_guided_converges_to_mis_on_the_cornell_box():
    """Region z-tests: 4x4-pixel blocks and the image mean of two independent renders."""
    mis = rt.render(CORNELL, spp=128, width=32, seed=21, integrator="mis", kernel="general").film
    guided = rt.render(CORNELL, spp=128, width=32, seed=22, integrator="guided", kernel="general").film
    z = block_z(mis, guided, 4)
    assert np.abs(z).max() < z_limit(z.size)
    (ma, sa), (mb, sb) = film_mean_and_se(mis), film_mean_and_se(guided)
    assert np.all(np.abs(ma - mb) < z_limit(3) * np.hypot(sa, sb))
