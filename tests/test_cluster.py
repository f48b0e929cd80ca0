"""Rendering on a Dask cluster (rt/cluster.py, rt/chunks.py): the image is the local render's bit
for bit, with a worker killed in the middle too; budgets, Ctrl-C and saved states; errors in words.

One LocalCluster of two single-thread worker processes serves the module; tiny images and few
samples keep it to seconds. Workers load the kernels from the disk cache the client fills.
"""

from __future__ import annotations

import os
import shutil
from signal import SIGKILL
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")

from typer.testing import CliRunner  # noqa: E402

import rt  # noqa: E402
from rt import chunks  # noqa: E402
from rt.cli import app  # noqa: E402
from rt.cluster import ClusterError, connect, package_scene, render_on_cluster  # noqa: E402

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CORNELL = ROOT / "scenes" / "cornell_box.yaml"
EARTH = ROOT / "scenes" / "earth.yaml"
WIDTH = 16


@pytest.fixture(scope="module")
def client():
    # Not the default client: a render must use the client it is given and never look one up,
    # as `rt render --cluster` has none (tests/test_cluster_cli.py runs that in fresh processes).
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with Client(cluster, set_as_default=False) as c:
            yield c


def local(scene=CORNELL, spp=6, width=WIDTH):
    return rt.render(scene, spp=spp, width=width, kernel="general")


def prepared(scene=CORNELL, width=WIDTH):
    """(package, flat, frame, features) of a scene, as `rt render --cluster` prepares them."""
    from renderer.flat import Frame
    from renderer.variants import GENERAL
    from renderer.session import flatten_loaded as flatten
    from scenefmt.files import recording_reads

    with recording_reads() as reads:
        loaded = rt.load(scene)
        graph, flat = flatten(loaded, width)
    return package_scene(str(scene), reads, loaded, flat, width=width), flat, Frame.of(graph), GENERAL


def same_sums(a, b) -> bool:
    return a.samples == b.samples and np.array_equal(a.total, b.total) and np.array_equal(a.total_sq, b.total_sq)


def test_the_image_is_the_local_render_bit_for_bit(client):
    image = rt.render(CORNELL, spp=6, width=WIDTH, kernel="general", cluster=client)
    reference = local()
    assert same_sums(image.film, reference.film)
    assert image.stats.rays == reference.stats.rays
    assert image.stats.stop_reason == "samples"
    assert image.stats.kernel_seconds == 0.0  # a Client of the caller's: its workers load their own kernel


def test_a_guided_image_is_the_local_render_bit_for_bit(client):
    # Each worker trains the guide itself, on its one thread, from the same rows as a local render.
    caustic = ROOT / "benchmarks" / "scenes" / "caustic_glass.yaml"
    image = rt.render(caustic, spp=4, width=WIDTH, kernel="general", integrator="guided", cluster=client)
    reference = rt.render(caustic, spp=4, width=WIDTH, kernel="general", integrator="guided")
    assert reference.stats.guide_training.guide_rows > 1
    assert same_sums(image.film, reference.film)


def test_a_worker_killed_mid_render_changes_nothing(client):
    import threading

    package, flat, frame, features = prepared()
    address, victim = sorted(client.run(os.getpid).items())[0]
    merged = threading.Event()
    killed = []

    def kill_when_busy():
        # Once a round is merged, as soon as the victim holds chunks: they are lost with it.
        merged.wait(60)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            if client.processing().get(address):
                os.kill(victim, SIGKILL)
                killed.append(time.monotonic())
                return
            time.sleep(0.002)

    killer = threading.Thread(target=kill_when_busy, daemon=True)
    killer.start()
    result = render_on_cluster(client, package, flat, frame, features=features, samples=160,
                               progress=lambda stats: merged.set(), chunk_seconds=0.05)
    killer.join(5)
    assert killed
    assert same_sums(result.film, local(spp=160).film)
    client.wait_for_workers(2, timeout=60)  # the nanny restarts it, for the tests that follow


def test_files_go_to_workers_as_bytes(client, tmp_path):
    # The scene and its texture are copied, packaged, then deleted: workers never read a path.
    folder = tmp_path / "scene"
    folder.mkdir()
    shutil.copy(EARTH, folder / "earth.yaml")
    shutil.copy(EARTH.parent / "earthmap.png", folder / "earthmap.png")
    package, flat, frame, features = prepared(folder / "earth.yaml", width=12)
    assert sorted(Path(name).name for name, _ in package.files) == ["earth.yaml", "earthmap.png"]
    shutil.rmtree(folder)
    result = render_on_cluster(client, package, flat, frame, features=features, samples=3)
    assert same_sums(result.film, local(EARTH, spp=3, width=12).film)


def test_noise_target_stops_on_merged_samples(client):
    package, flat, frame, features = prepared()
    seen = []
    result = render_on_cluster(client, package, flat, frame, features=features, samples=1000, noise_target=0.3,
                               progress=lambda s: seen.append(s.samples), chunk_seconds=0.01)
    assert result.stats.stop_reason == "noise"
    assert result.stats.noise <= 0.3 and result.film.samples >= 8
    assert seen == sorted(seen) and seen[-1] == result.film.samples  # progress counts merged samples
    assert same_sums(result.film, local(spp=result.film.samples).film)


def test_time_budget_and_stop(client):
    package, flat, frame, features = prepared()
    started = time.perf_counter()
    result = render_on_cluster(client, package, flat, frame, features=features, samples=1_000_000, time_budget=2.0,
                               chunk_seconds=0.2)
    assert result.stats.stop_reason == "time"
    assert time.perf_counter() - started < 2.0 + 3.0
    assert same_sums(result.film, local(spp=result.film.samples).film)
    # Ctrl-C: outstanding chunks are cancelled, the merged samples kept.
    calls = []
    result = render_on_cluster(client, package, flat, frame, features=features, samples=1000,
                               should_stop=lambda: len(calls) >= 3, progress=calls.append, chunk_seconds=0.001)
    assert result.stats.interrupted and 1 <= result.film.samples < 1000
    assert same_sums(result.film, local(spp=result.film.samples).film)


def test_a_worker_side_failure_is_one_sentence(client):
    import dataclasses

    package, flat, frame, features = prepared()
    other = dataclasses.replace(package, renderer="0000")
    with pytest.raises(ClusterError, match="other renderer code than the client"):
        render_on_cluster(client, other, flat, frame, features=features, samples=2)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_scheduler_is_a_clear_error_within_seconds(tmp_path):
    address = f"tcp://127.0.0.1:{free_port()}"
    started = time.perf_counter()
    result = CliRunner().invoke(app, ["render", str(CORNELL), "--spp", "1", "--width", "8", "-o", str(tmp_path / "a.png"),
                                      "--cluster", address])
    assert result.exit_code == 1
    assert f"--cluster {address}: no Dask scheduler answers there" in result.output
    assert "Traceback" not in result.output
    assert time.perf_counter() - started < 15
    # A scene error is reported once, as locally, before any cluster is asked.
    bad = tmp_path / "bad.yaml"
    bad.write_text(CORNELL.read_text().replace("samples_per_pixel", "samples_per_pixle"))
    result = CliRunner().invoke(app, ["render", str(bad), "-o", str(tmp_path / "b.png"), "--cluster", address])
    assert result.exit_code == 1
    assert result.output.count("error:") == 1 and "unknown key 'samples_per_pixle'" in result.output
    assert "Dask" not in result.output and "cluster" not in result.output


def test_save_state_and_resume_on_the_cluster(client, tmp_path):
    address = client.scheduler.address
    runner = CliRunner()
    common = [str(CORNELL), "--width", str(WIDTH), "--kernel", "general", "-o", str(tmp_path / "c.png")]
    first = runner.invoke(app, ["render", *common, "--spp", "3", "--save-state", str(tmp_path / "a.npz"), "--cluster", address])
    assert first.exit_code == 0, first.output
    second = runner.invoke(app, ["render", *common, "--spp", "7", "--resume", str(tmp_path / "a.npz"),
                                 "--save-state", str(tmp_path / "b.npz"), "--cluster", address])
    assert second.exit_code == 0, second.output
    assert "7 spp" in second.output
    alone = runner.invoke(app, ["render", *common, "--spp", "7", "--save-state", str(tmp_path / "l.npz")])
    assert alone.exit_code == 0, alone.output
    a, b = np.load(tmp_path / "b.npz"), np.load(tmp_path / "l.npz")
    assert np.array_equal(a["total"], b["total"]) and np.array_equal(a["total_sq"], b["total_sq"])


def test_cluster_local_renders_several_scenes(tmp_path):
    # `--cluster local` starts its own worker processes (two on this machine's two cores).
    out, ref = tmp_path / "cluster", tmp_path / "local"
    out.mkdir()
    ref.mkdir()
    scenes = [str(CORNELL), str(ROOT / "scenes" / "quads.json")]
    common = ["--width", "12", "--spp", "2", "--kernel", "general", "--hdr", "pfm"]
    result = CliRunner().invoke(app, ["render", *scenes, *common, "-o", str(out), "--cluster", "local"])
    assert result.exit_code == 0, result.output
    assert "cluster: a local cluster" in result.output
    assert CliRunner().invoke(app, ["render", *scenes, *common, "-o", str(ref)]).exit_code == 0
    for name in ("cornell_box.pfm", "quads.pfm"):
        assert (out / name).read_bytes() == (ref / name).read_bytes()


def test_separate_scheduler_and_worker_processes(tmp_path):
    dask = str(Path(sys.executable).with_name("dask"))
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    worker = subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                               "--host", "127.0.0.1"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                              cwd=tmp_path)
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                connection = connect(address)
                break
            except ClusterError:
                if time.monotonic() > deadline:
                    raise
        try:
            connection.client.wait_for_workers(1, timeout=30)
        finally:
            connection.close()
        pfm = tmp_path / "c.pfm"
        result = CliRunner().invoke(app, ["render", str(CORNELL), "--width", "12", "--spp", "2", "--kernel", "general",
                                          "-o", str(tmp_path / "c.png"), "--hdr", str(pfm), "--cluster", address])
        assert result.exit_code == 0, result.output
        assert "1 workers, 1 threads" in result.output
        assert CliRunner().invoke(app, ["render", str(CORNELL), "--width", "12", "--spp", "2", "--kernel", "general",
                                        "-o", str(tmp_path / "l.png"), "--hdr", str(tmp_path / "l.pfm")]).exit_code == 0
        assert pfm.read_bytes() == (tmp_path / "l.pfm").read_bytes()
    finally:
        for process in (worker, scheduler):
            process.terminate()
        for process in (worker, scheduler):
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()


def test_tiles_cover_the_image_once():
    for width, height, threads in ((16, 16, 2), (100, 37, 8), (1, 1, 1), (640, 480, 64)):
        tiles = chunks.plan_tiles(width, height, threads)
        cover = np.zeros((height, width), int)
        for tile in tiles:
            tile.of(cover)[...] += 1
        assert (cover == 1).all()
