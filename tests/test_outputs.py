"""Output files of `rt render`: checked before rendering, never lost after it.

Before: a directory or an unwritable folder as output was found only after the render, with a
traceback and the samples lost; a write killed midway left its temporary file behind; a seed
above what the file format allows failed inside Numba.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from rt.cli import app

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()

SMALL = """
image: {width: 4, aspect_ratio: 1, samples_per_pixel: 1, max_depth: 2}
materials: {m: {type: lambertian}}
shapes: [{type: sphere, center: [0, 0, -2], radius: 1, material: m}]
"""


def test_a_write_killed_midway_leaves_no_temporary_file(tmp_path):
    code = (
        "import os, signal, sys\n"
        "from renderer.film import _atomic_write\n"
        "def write(fh):\n"
        "    fh.write(b'x' * 100000)\n"
        "    fh.flush()\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
        "_atomic_write(sys.argv[1], write)\n"
    )
    out = tmp_path / "image.png"
    result = subprocess.run([sys.executable, "-c", code, str(out)], cwd=ROOT, capture_output=True, timeout=60)
    assert result.returncode == -9
    assert os.listdir(tmp_path) == []


def render_args(tmp_path, *args):
    scene = tmp_path / "s.yaml"
    scene.write_text(SMALL)
    return ["render", str(scene), *args]


@pytest.mark.parametrize(
    "option, make, words",
    [
        ("-o", lambda tmp: tmp / "dir.png", "it is a directory, not a file that can be replaced"),
        ("--hdr", lambda tmp: tmp / "dir.pfm", "it is a directory"),
        ("--hdr", lambda tmp: tmp / "dir.exr", "it is a directory"),
        ("--hdr", lambda tmp: tmp / "out.hdr", "the file name must end in .exr or .pfm"),
        ("--save-state", lambda tmp: tmp / "dir.npz", "it is a directory"),
        ("-o", lambda tmp: Path("/sys/rt-test.png"), "cannot write in /sys"),
        ("--noise-map", lambda tmp: Path("/proc/rt-test.png"), "cannot write in /proc"),
        ("-o", lambda tmp: tmp / ("x" * 300 + ".png"), "the file name is longer than the 255 bytes the system allows"),
    ],
)
def test_outputs_that_cannot_be_written_are_refused_before_rendering(tmp_path, option, make, words):
    (tmp_path / "dir.png").mkdir()
    (tmp_path / "dir.pfm").mkdir()
    (tmp_path / "dir.exr").mkdir()
    (tmp_path / "dir.npz").mkdir()
    start = time.perf_counter()
    result = runner.invoke(app, render_args(tmp_path, option, str(make(tmp_path))))
    assert result.exit_code == 1, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert words in result.output
    assert time.perf_counter() - start < 10  # refused before the renderer was loaded


def test_a_seed_beyond_the_file_format_is_a_usage_error(tmp_path):
    result = runner.invoke(app, render_args(tmp_path, "--seed", str(2**63)))
    assert result.exit_code == 2
    assert "--seed" in result.output and "9223372036854775807" in result.output


def test_a_write_that_fails_after_rendering_rescues_the_samples(tmp_path, monkeypatch):
    from renderer import film as film_module
    from renderer.film import Film
    from renderer.state import RenderKey, load_state
    from rt import outputs
    from rt.render_job import RenderOptions, Stop, fail

    film = Film(np.full((2, 3, 3), 0.5), np.full((2, 3, 3), 0.25), 2)
    key = RenderKey("cd" * 32, 3, 2, 4, 1)
    opts = RenderOptions(scene=tmp_path / "s.yaml", output=tmp_path / "out.png", hdr=tmp_path / "out.pfm")

    def full_disk(path, image, *png_options):  # the display transform and text of a PNG
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(film_module, "write_image", full_disk)
    monkeypatch.setattr(outputs.tempfile, "gettempdir", lambda: str(tmp_path))
    with pytest.raises(Stop) as excinfo:
        outputs.write_outputs(opts, film, key, fail)
    assert excinfo.value.status == 1
    rescued = sorted(p.name for p in tmp_path.iterdir())
    assert rescued == [f"rt-rescued-s-{os.getpid()}.npz", f"rt-rescued-s-{os.getpid()}.pfm"]
    assert load_state(tmp_path / rescued[0], key).samples == 2  # the samples can be resumed
    # Without a fingerprint (no --save-state or --resume), the image is rescued.
    for p in tmp_path.iterdir():
        p.unlink()
    with pytest.raises(Stop):
        outputs.write_outputs(opts, film, None, fail)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"rt-rescued-s-{os.getpid()}.pfm"]


def test_with_save_state_the_state_is_written_before_the_images(tmp_path, monkeypatch, capsys):
    from renderer import film as film_module
    from renderer.film import Film
    from renderer.state import RenderKey, load_state
    from rt import outputs
    from rt.render_job import RenderOptions, Stop, fail

    film = Film(np.full((2, 3, 3), 0.5), np.full((2, 3, 3), 0.25), 2)
    key = RenderKey("cd" * 32, 3, 2, 4, 1)
    opts = RenderOptions(scene=tmp_path / "s.yaml", output=tmp_path / "out.png", save_state=tmp_path / "run.npz")
    monkeypatch.setattr(film_module, "write_image", lambda path, image, *png_options: (_ for _ in ()).throw(OSError(errno.EIO, "I/O error")))
    with pytest.raises(Stop):
        outputs.write_outputs(opts, film, key, fail)
    assert f"error: cannot write {tmp_path / 'out.png'}: I/O error; the samples are saved in {tmp_path / 'run.npz'}" in capsys.readouterr().err
    assert load_state(tmp_path / "run.npz", key).samples == 2


def test_a_width_whose_film_this_machine_cannot_hold_is_refused_before_rendering(tmp_path, monkeypatch):
    from scenefmt import bounds

    monkeypatch.setattr(bounds, "physical_memory", lambda: 16 << 30)
    result = runner.invoke(app, render_args(tmp_path, "--width", "32768"))
    assert result.exit_code == 1, result.output
    assert "image.width: rendering this scene needs about 369.0 GiB (film 369.0 GiB), more than the 12.0 GiB allowed" in result.output


def test_error_lines_escape_control_characters(tmp_path, capsys):
    from rt.render_job import fail

    fail("error: \x1b[2Jname\x9b: bad")
    assert capsys.readouterr().err == "error: \\x1b[2Jname\\x9b: bad\n"


def test_validate_reports_the_memory_a_render_needs(tmp_path):
    scene = tmp_path / "s.yaml"
    scene.write_text(SMALL.replace("width: 4", "width: 1000"))
    result = runner.invoke(app, ["validate", str(scene)])
    assert result.exit_code == 0, result.output
    assert "  memory: about 351.9 MiB (film 351.9 MiB); at most " in result.stdout


def test_hdr_is_written_as_openexr_and_exposure_changes_the_png_only(tmp_path):
    from PIL import Image

    from renderer.film import Film, read_pfm
    from rt import outputs
    from rt.render_job import RenderOptions, fail
    from scenefmt.hdr_files import read_hdr

    total = np.zeros((2, 3, 3))
    total[0, 0] = (1.0, 2.0, 100.0)  # 2 samples: a mean of (0.5, 1, 50), above 1 kept in the HDR image
    total[1, 2] = (0.25, 0.125, 0.0)
    film = Film(total, total**2, 2)
    for suffix in (".exr", ".pfm"):
        opts = RenderOptions(scene=tmp_path / "s.yaml", output=tmp_path / "out.png", hdr=tmp_path / f"out{suffix}", exposure=1.0)
        outputs.write_outputs(opts, film, None, fail)
        written = read_hdr(tmp_path / f"out{suffix}", 100)
        assert written.dtype == np.float32 and written.shape == (2, 3, 3)
        assert np.array_equal(written, film.mean().astype(np.float32))
    assert np.array_equal(read_pfm(tmp_path / "out.pfm"), read_hdr(tmp_path / "out.exr", 100))
    with Image.open(tmp_path / "out.png") as img:
        png = np.asarray(img)
    # One stop up: red 0.125 * 2 = 0.25, gamma 2 -> 0.5 -> 128 (90 without --exposure); green 0.0625 * 2 -> 90.
    assert png[1, 2, 0] == 128 and png[1, 2, 1] == 90 and png[0, 0, 2] == 255


def test_an_exr_without_the_openexr_package_is_refused_before_rendering(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "OpenEXR", None)  # import OpenEXR now raises ImportError
    result = runner.invoke(app, render_args(tmp_path, "--hdr", str(tmp_path / "out.exr"), "-o", str(tmp_path / "o.png")))
    assert result.exit_code == 1
    assert "--hdr" in result.output and "needs the openexr package, which is not installed: pip install '.[exr]' in rt's folder" in result.output
    assert list(tmp_path.iterdir()) == [tmp_path / "s.yaml"]


def test_an_exposure_beyond_30_stops_is_refused(tmp_path):
    result = runner.invoke(app, render_args(tmp_path, "--exposure", "31"))
    assert result.exit_code == 1
    assert "--exposure 31: expected a number of stops from -30 to 30" in result.output
