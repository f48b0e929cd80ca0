"""`--sampler` as a user types it, in a fresh process after the README's install: it is the `--set
image.sampler=` it stands for, the Sobol image differs from the independent one, a wrong name is one
line with the names allowed, and a saved state remembers its sampler. Slow: it renders."""

from __future__ import annotations

import subprocess
import sys

import pytest

from renderer.film import read_pfm

SCENE = """
camera: {look_from: [0, 1, 4], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 12, height: 8, samples_per_pixel: 16, max_depth: 4, seed: 3}
background: {type: sky}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: m}
"""

pytestmark = pytest.mark.slow


def rt(*args, cwd):
    return subprocess.run([sys.executable, "-m", "rt", *args], cwd=cwd, capture_output=True, text=True, timeout=600)


def test_sampler_option_is_the_set_it_stands_for_and_changes_the_points(tmp_path):
    (tmp_path / "s.yaml").write_text(SCENE)
    images = {}
    for name, option in (("sobol", ["--sampler", "sobol"]), ("set", ["--set", "image.sampler=sobol"]), ("independent", [])):
        out = rt("render", "s.yaml", "--kernel", "general", "-o", f"{name}.png", "--hdr", f"{name}.pfm", *option, cwd=tmp_path)
        assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
        images[name] = read_pfm(tmp_path / f"{name}.pfm")
    assert (images["sobol"] == images["set"]).all()
    assert not (images["sobol"] == images["independent"]).all()
    # The same scene, so the same mean within noise: a check that the points are not broken.
    assert abs(images["sobol"].mean() - images["independent"].mean()) < 0.1 * images["independent"].mean()


def test_a_wrong_sampler_is_one_line_and_a_state_keeps_its_sampler(tmp_path):
    (tmp_path / "s.yaml").write_text(SCENE)
    out = rt("render", "s.yaml", "--sampler", "sobl", "-o", "x.png", cwd=tmp_path)
    assert out.returncode != 0 and "Traceback" not in out.stderr
    assert "sampler" in out.stderr and "sobol" in out.stderr and "independent" in out.stderr, out.stderr
    assert not (tmp_path / "x.png").exists()
    out = rt("render", "s.yaml", "--kernel", "general", "--spp", "8", "--sampler", "sobol", "-o", "a.png",
             "--save-state", "a.npz", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    out = rt("render", "s.yaml", "--kernel", "general", "--spp", "16", "--resume", "a.npz", "-o", "b.png", cwd=tmp_path)
    assert out.returncode != 0 and "Traceback" not in out.stderr
    assert "sampler sobol (now independent)" in out.stderr, out.stderr
