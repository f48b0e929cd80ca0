"""`rt render a.yaml b.yaml c.yaml`: several scenes in one process."""

import pytest
from typer.testing import CliRunner

from rt.cli import app

runner = CliRunner()

SCENE = """
camera: {{look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}}
image: {{width: 16, aspect_ratio: 2, samples_per_pixel: 3, max_depth: 5, seed: {seed}}}
materials: {{m: {{type: lambertian, albedo: {albedo}}}, g: {{type: {top}}}}}
shapes:
  - {{type: sphere, center: [0, -100, 0], radius: 100, material: m}}
  - {{type: sphere, center: [0, 0.5, 0], radius: 0.5, material: g}}
"""


def three_scenes(tmp_path):
    texts = {
        "a.yaml": SCENE.format(seed=1, albedo="[0.6, 0.3, 0.2]", top="metal"),
        "b.yaml": SCENE.format(seed=2, albedo="[0.2, 0.6, 0.3]", top="dielectric"),
        "c.yaml": SCENE.format(seed=3, albedo="[0.5, 0.5, 0.5]", top="lambertian"),
    }
    for name, text in texts.items():
        (tmp_path / name).write_text(text)
    return [str(tmp_path / name) for name in texts]


@pytest.mark.slow
def test_a_batch_gives_the_images_of_separate_renders(tmp_path):
    scenes = three_scenes(tmp_path)
    (tmp_path / "out").mkdir()
    batch = runner.invoke(app, ["render", *scenes, "-o", str(tmp_path / "out"), "--hdr", "pfm", "--spp", "4"])
    assert batch.exit_code == 0, batch.output
    assert batch.stderr.count("[") >= 3 and "[3/3]" in batch.stderr
    for scene in scenes:
        stem = scene[-6:-5]
        one = runner.invoke(app, ["render", scene, "-o", str(tmp_path / f"{stem}.png"), "--hdr", str(tmp_path / f"{stem}.pfm"),
                                  "--spp", "4"])
        assert one.exit_code == 0, one.output
        for suffix in (".png", ".pfm"):
            assert (tmp_path / "out" / f"{stem}{suffix}").read_bytes() == (tmp_path / f"{stem}{suffix}").read_bytes()


@pytest.mark.slow
def test_a_failing_scene_is_reported_and_the_others_still_render(tmp_path, monkeypatch):
    a, b, c = three_scenes(tmp_path)
    (tmp_path / "b.yaml").write_text("shapes: [{type: sphere, radious: 1}]\n")
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["render", a, b, c, "--spp", "1"])
    assert result.exit_code == 1
    assert "b.yaml:1:25: error: shapes[0].radious: unknown key 'radious'" in result.stderr
    assert "error: 1 of 3 scenes failed: " in result.stderr and result.stderr.rstrip().endswith("b.yaml")
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["a.png", "c.png"]
    assert "wrote a.png" in result.stdout and "wrote c.png" in result.stdout


def test_a_batch_refuses_options_that_name_one_file_and_images_that_share_a_name(tmp_path):
    a, b, _ = three_scenes(tmp_path)
    for option in (["--save-state", "s.npz"], ["--resume", "s.npz"], ["--noise-map", "n.png"]):
        result = runner.invoke(app, ["render", a, b, *option])
        assert result.exit_code == 2 and f"{option[0]} names one file" in result.stderr
    result = runner.invoke(app, ["render", a, b, "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 1 and "with several scenes, -o names the folder" in result.stderr
    result = runner.invoke(app, ["render", a, b, "--hdr", "out.exr"])
    assert result.exit_code == 1 and "--hdr exr or --hdr pfm" in result.stderr
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "a.yaml").write_text((tmp_path / "a.yaml").read_text())
    result = runner.invoke(app, ["render", a, str(tmp_path / "sub" / "a.yaml"), "-o", str(tmp_path)])
    assert result.exit_code == 1 and "would both write" in result.stderr
    result = runner.invoke(app, ["render", "-", a, "-"])
    assert result.exit_code == 2 and "standard input (-) can be read only once" in result.stderr
    assert not list(tmp_path.glob("*.png"))
