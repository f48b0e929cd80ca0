"""The messages of `rt render` (rt/render_job.py): budgets, noise targets, resumed states,
empty scenes, the progress bar's last line and --explain, as a new user reads them."""

import pytest
from typer.testing import CliRunner

from rt.cli import app
from rt.render_job import budget_text, noise_reached
from tests.test_cli import write

runner = CliRunner()

SMALL = """
camera: {look_from: [0, 1, 5], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 16, aspect_ratio: 2, samples_per_pixel: 4, max_depth: 4, seed: 5}
materials: {m: {type: lambertian, albedo: [0.6, 0.3, 0.2]}}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: m}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: m}
"""


def test_a_time_budget_names_its_unit():
    assert budget_text("2") == "2 s"
    assert budget_text("2.5") == "2.5 s"
    assert [budget_text(t) for t in ("30s", "2m", "1h30m", "1.5h")] == ["30s", "2m", "1h30m", "1.5h"]


def test_a_noise_target_reached_never_reads_as_equal():
    assert noise_reached(0.019996, 0.02) == "the estimated noise 1.9996% is below the 2.0000% target"
    assert noise_reached(0.0199, 0.02) == "the estimated noise 1.99% is below the 2.00% target"
    assert noise_reached(0.02, 0.02) == "the estimated noise has reached the 2.00% target"


@pytest.mark.slow
def test_a_time_budget_without_unit_is_reported_in_seconds(tmp_path):
    path = write(tmp_path, "ball.yaml", SMALL)
    result = runner.invoke(app, ["render", str(path), "-o", str(tmp_path / "b.png"), "--time", "1"])
    assert result.exit_code == 0, result.output
    assert "stopped: the 1 s time budget is spent" in result.stderr


def test_the_last_progress_line_shows_the_final_noise(capsys):
    from renderer.render import RenderStats
    from rt.render_job import Progress

    bar = Progress(8)
    bar(RenderStats(samples=4, seconds=0.5, rays=1000))  # no estimate yet: once a second at most
    bar(RenderStats(samples=8, seconds=1.0, rays=2000, noise=0.05))
    bar.finish(RenderStats(samples=8, seconds=1.0, rays=2000, noise=0.0412))
    bar.close()
    lines = capsys.readouterr().err.splitlines()
    assert lines[-1].endswith("noise 4.12%") and "8/8 spp" in lines[-1]
    # Nothing new to show: no second line with the same figures.
    bar.finish(RenderStats(samples=8, seconds=1.1, rays=2000, noise=0.0412))
    assert capsys.readouterr().err == ""


@pytest.mark.slow
def test_a_render_ends_its_progress_with_the_noise_of_its_summary(tmp_path):
    path = write(tmp_path, "ball.yaml", SMALL)
    result = runner.invoke(app, ["render", str(path), "-o", str(tmp_path / "b.png"), "--spp", "6"])
    assert result.exit_code == 0, result.output
    (summary,) = [line for line in result.stdout.splitlines() if line.startswith("noise: ")]
    final = summary.split()[1]  # "noise: 12.34% relative RMS ..."
    progress = [line for line in result.stderr.splitlines() if line.startswith("[")]
    assert progress[-1].startswith("[" + "#" * 30 + "] 6/6 spp") and progress[-1].endswith(f"noise {final}")


@pytest.mark.slow
def test_resuming_a_state_with_more_samples_than_asked_says_so(tmp_path):
    path = write(tmp_path, "ball.yaml", SMALL)
    state = tmp_path / "s.npz"
    first = runner.invoke(app, ["render", str(path), "-o", str(tmp_path / "a.png"), "--spp", "6", "--save-state", str(state)])
    assert first.exit_code == 0, first.output
    for spp, words in ((["--spp", "2"], "more than --spp 2"), (["--spp", "6"], "as many as --spp 6"),
                       ([], "more than the scene's samples_per_pixel 4")):
        again = runner.invoke(app, ["render", str(path), "-o", str(tmp_path / "b.png"), *spp, "--resume", str(state)])
        assert again.exit_code == 0, again.output
        assert (f"warning: --resume {state} already holds 6 samples per pixel, {words} asks for: nothing more is "
                "rendered, and the images hold all 6 (a saved state cannot drop samples)") in again.stderr
        assert "16x8, 6 spp" in again.stdout


def test_validate_and_render_warn_about_an_empty_scene(tmp_path, capsys):
    from rt.render_job import RenderOptions, prepare

    empty = write(tmp_path, "empty.yaml", "")
    result = runner.invoke(app, ["validate", str(empty)])
    assert result.exit_code == 0, result.output
    assert (f"{empty}:1:1: warning: (top level): the scene is empty: the image will show only the background "
            "(write shapes: [] if that is meant)") in result.stderr
    no_shapes = write(tmp_path, "bare.yaml", "# a sky\ncamera: {vfov: 30}\n")
    prepare(RenderOptions(scene=no_shapes, output=tmp_path / "bare.png"))  # what `rt render` reads before rendering
    assert (f"{no_shapes}:2:1: warning: (top level): the scene has no shapes key: the image will show only the "
            "background (write shapes: [] if that is meant)") in capsys.readouterr().err


def test_explain_says_that_the_render_follows(tmp_path, capsys):
    from rt.render_job import RenderOptions, prepare

    result = runner.invoke(app, ["render", "--help"], env={"COLUMNS": "200", "TERM": "dumb"})
    text = " ".join(result.stdout.replace("│", " ").split())
    assert "about 15 s in all), then render as usual (rt validate lists the effects without rendering)" in text
    path = write(tmp_path, "ball.yaml", SMALL)
    prepare(RenderOptions(scene=path, output=tmp_path / "ball.png", explain=True))
    first = capsys.readouterr().err.splitlines()[0]
    assert first == ("explain: the effects this scene uses, the kernel that renders it and what each expensive effect "
                     "costs; the render follows (rt validate lists the effects without rendering)")
