"""Adaptive sampling on a Dask cluster (rt/cluster.py): chunks carry the stopping rule set after
the pilot, and the image is the local adaptive render's bit for bit. One LocalCluster of two
single-thread workers; a tiny image."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")

import rt  # noqa: E402
from rt.cluster import package_scene, render_on_cluster  # noqa: E402

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CORNELL = ROOT / "scenes" / "cornell_box.yaml"
WIDTH = 16


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with Client(cluster, set_as_default=False) as c:
            yield c


def test_an_adaptive_render_on_the_cluster_is_the_local_one(client):
    from renderer.flat import Frame
    from renderer.render import render_flat
    from renderer.session import flatten_loaded
    from renderer.variants import GENERAL
    from scenefmt.files import recording_reads

    with recording_reads() as reads:
        loaded = rt.load(CORNELL)
        graph, flat = flatten_loaded(loaded, WIDTH)
    package = package_scene(str(CORNELL), reads, loaded, flat, width=WIDTH)
    frame = Frame.of(graph)
    remote = render_on_cluster(client, package, flat, frame, features=GENERAL, samples=4096, noise_target=0.08,
                               adaptive=True, chunk_seconds=0.05)
    here = render_flat(flat, frame, samples=4096, noise_target=0.08, adaptive=True, features=GENERAL)
    assert remote.stats.stop_reason == here.stats.stop_reason == "noise"
    assert here.film.stopping is not None and here.film.done.any()
    assert remote.film.samples == here.film.samples and remote.film.stopping[:3] == here.film.stopping[:3]
    assert np.array_equal(remote.film.stopping[3], here.film.stopping[3])
    for name, a, b in zip(here.film.sums._fields, remote.film.sums, here.film.sums):
        assert np.array_equal(a, b), name
