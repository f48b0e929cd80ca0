"""The new lights as a user meets them, in a fresh process after the README's install: `rt validate`
lists them, and `rt render` of each shipped scene that shows one (a spot, the sun and sky, the
12,480 bulbs of the light tree) writes an image whose mean is the converged one within noise.
Slow: it renders (with the general kernel the other slow tests compile, so no compile of its own)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from renderer.film import read_pfm

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = ROOT / "tests" / "renderer" / "references"
SPP = 64

pytestmark = pytest.mark.slow


def rt(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("stem, listed", [("cornell_spot", "spot: 1"), ("sun_sky", "sun: 1"),
                                          ("many_lights", "many lights: on (12,480 lights")])
def test_each_new_light_scene_validates_and_renders_to_its_reference_mean(tmp_path, stem, listed):
    scene = ROOT / "scenes" / f"{stem}.yaml"
    check = rt("validate", str(scene), cwd=tmp_path)
    assert check.returncode == 0 and listed in check.stdout, check.stdout + check.stderr
    out = rt("render", str(scene), "--width", "48", "--spp", str(SPP), "--kernel", "general", "-o", "out.png",
             "--hdr", "out.pfm", cwd=tmp_path)
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    image = read_pfm(tmp_path / "out.pfm")
    assert np.isfinite(image).all() and (tmp_path / "out.png").stat().st_size > 0
    # The reference (tests/renderer/references.py: 4,096 spp at this size) keeps block means and the
    # variance of single samples per block; the image mean's standard error at SPP follows from it.
    ref = np.load(REFERENCES / f"{stem}.npz")
    mean, var, n = ref["mean"], ref["var"], int(ref["n"])
    blocks = mean.shape[0] * mean.shape[1]
    h, w = mean.shape[0] * (ref["shape"][0] // mean.shape[0]), mean.shape[1] * (ref["shape"][1] // mean.shape[1])
    ours = image[:h, :w].reshape(-1, 3).mean(axis=0)
    expected = mean.reshape(-1, 3).mean(axis=0)
    per_block_spp = n * SPP // 4096  # the samples of one block at SPP (n holds 4,096 spp)
    se = np.sqrt((var.reshape(-1, 3) / per_block_spp).sum(axis=0) + (var.reshape(-1, 3) / n).sum(axis=0)) / blocks
    z = (ours - expected) / np.maximum(se, 1e-12)
    assert np.all(np.abs(z) < 5.0), f"{stem}: mean {ours} against {expected} (z {z})"
