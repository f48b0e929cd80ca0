"""The forecast and the costs of effects as users meet them: `rt render --dry-run` in a fresh
process, and `--explain`'s costs on a scene with a medium and defocus (rt/dry_run.py,
rt/effect_costs.py). Slow: they render."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

# Lit by the sky; a fog ball (a medium with no surface of its own), a lens of aperture 0.2, depth 4:
# of the effects --explain measures, media and defocus only.
FOGGY = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40, aperture: 0.2}
image: {width: 40, aspect_ratio: 1.5, samples_per_pixel: 4, max_depth: 4, seed: 5}
background: {type: sky}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}}
media: {fog: {type: constant, density: 2.0, albedo: [0.9, 0.9, 0.9]}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.6, 0], radius: 0.6, interior: fog}
"""


def seconds_of(spoken: str) -> float:
    """Seconds in a duration as rt.progress.spoken_seconds says it: '0.4 s', '2 min 10 s', '1 h 05 min'."""
    units = {"h": 3600, "min": 60, "s": 1}
    parts = re.fullmatch(r"(?:([\d.]+) h)? ?(?:([\d.]+) min)? ?(?:([\d.]+) s)?", spoken.strip())
    assert parts and any(parts.groups()), spoken
    return sum(float(v) * u for v, u in zip(parts.groups(), units.values()) if v)


@pytest.mark.slow
def test_a_dry_run_says_a_time_to_the_target_and_writes_nothing(tmp_path):
    """Its -o names a folder that does not exist: a dry run neither needs it nor makes it."""
    (tmp_path / "foggy.yaml").write_text(FOGGY)
    out = subprocess.run([sys.executable, "-m", "rt", "render", "foggy.yaml", "--dry-run", "--noise", "0.0005",
                          "--kernel", "general", "-o", "renders/foggy.png"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr
    pilot = re.search(r"pilot: (\d+) samples per pixel at 40x26 \(the image's own size\)", out.stdout)
    assert pilot and int(pilot.group(1)) >= 4, out.stdout
    line = re.search(r"forecast: about (.+?) to 0.05% noise \((.+?) to (.+?), 95% range\), "
                     r"about ([\d,]+) samples per pixel", out.stdout)
    assert line, out.stdout
    middle, low, high = (seconds_of(line.group(k)) for k in (1, 2, 3))
    assert 0 < low <= middle <= high
    samples = int(line.group(4).replace(",", ""))
    assert samples > int(pilot.group(1))  # 0.05% is far below what a pilot of a few seconds reaches
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foggy.yaml"]  # no image, no folder for it


@pytest.mark.slow
def test_explain_measures_the_costs_of_the_effects_the_scene_has_and_no_others(tmp_path):
    from renderer.variants import GENERAL
    from rt.effect_costs import costs
    from scenefmt.validation import load_source

    scene = tmp_path / "foggy.yaml"
    scene.write_text(FOGGY)
    graph = load_source(scene).graph
    lines = []
    found = costs(graph, GENERAL, width=24, seconds_each=1.0, say=lines.append)
    assert [c.effect for c in found] == ["media", "defocus"]
    assert "explain: measuring what each effect costs (media, defocus): 3 renders of 1.0 s at 24 px" in lines[0]
    media, defocus = found
    # Taking the fog away changes the image well beyond its noise; a lens only blurs it, keeping its mean.
    assert abs(media.bias) > 3 * media.bias_error
    assert abs(defocus.bias) < 4 * defocus.bias_error + 0.01
    for cost in found:
        assert 0.2 < cost.time < 20 and 0.2 < cost.noise < 20
        assert cost.sentence().startswith(f"{cost.effect} (")
    assert "time per sample x" in media.sentence() and "the time to the same noise" in media.sentence()
