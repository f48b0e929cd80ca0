"""Rendering on a Dask cluster: `rt render --cluster local|tcp://HOST:PORT` and `rt.render(cluster=...)`.

The client (this process) reads and flattens the scene as a local render does, so a scene
error is reported here, once, before any worker is asked; it then ships the scene's files as
bytes (`chunks.ScenePackage`), submits chunks (a tile and a range of samples each, see
rt/chunks.py) and merges their sums into the film in a fixed order. Dask runs the chunks,
moves the data and computes again whatever a dead worker lost.

dask.distributed is an optional dependency (the `cluster` extra: `pip install '.[cluster]'` in rt's folder): it is
imported only here, only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
import queue
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from . import chunks

CONNECT_SECONDS = 5.0  # to reach a scheduler given by address
WORKERS_SECONDS = 60.0  # to wait for a first worker to join
POLL_SECONDS = 0.2  # between checks of Ctrl-C and the time budget while chunks run
WORKERS_POLL_SECONDS = 2.0  # between asks to the scheduler whether any worker is left, while none finishes
MISSING = "rendering on a cluster needs dask.distributed: pip install '.[cluster]' in rt's folder (or pip install distributed)"


class ClusterError(RuntimeError):
    """The cluster cannot be used or a chunk failed; the message is a sentence to show.

    `partial`: for a failure once chunks were submitted, the RenderResult of the samples merged
    before it (what `rt render` saves, as after a failed write); None before that."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


class ClusterLost(ClusterError):
    """The cluster itself went away in the middle of a render: its scheduler (or the connection
    to it), or every worker. The message names the cluster rather than the scene."""


class Finished:
    """The futures that have finished, in the order they did, handed over by each future's own
    callback. Waiting this way needs no default client, which `distributed.wait` looks up: the
    clients made here are never the default one, so that a render never uses or replaces a
    client its caller made (and two renders in one process never share one by accident)."""

    def __init__(self):
        self._queue: queue.Queue = queue.Queue()

    def watch(self, future) -> None:
        future.add_done_callback(self._queue.put)

    def wait(self, timeout: float) -> list:
        """Those finished since the last call, waiting up to `timeout` seconds for a first one."""
        try:
            done = [self._queue.get(timeout=timeout)]
        except queue.Empty:
            return []
        while True:
            try:
                done.append(self._queue.get_nowait())
            except queue.Empty:
                return done


def _distributed():
    try:
        import distributed
    except ImportError:
        raise ClusterError(MISSING) from None
    return distributed


@dataclass
class Connection:
    """A client and, for `local`, the cluster this process started (closed with it)."""

    client: Any
    cluster: Any = None
    owned: bool = True

    @property
    def local(self) -> bool:
        """Whether the workers are processes this connection started on this machine ("local"):
        they load the kernels from this machine's disk cache."""
        return self.cluster is not None

    @property
    def description(self) -> str:
        workers = self.client.scheduler_info().get("workers", {})
        where = "a local cluster" if self.cluster is not None else f"the scheduler at {self.client.scheduler.address}"
        return f"{where}: {len(workers)} workers, {worker_threads(workers)} threads"

    def close(self) -> None:
        if not self.owned:
            return
        # A client that lost its scheduler is still trying to reconnect: closing it cancels that,
        # and distributed logs the cancellation with a traceback, after the render has said
        # in one line what happened. Logging is held back for that moment only.
        lost = self.client.status != "running"
        held = logging.root.manager.disable
        if lost:
            logging.disable(logging.CRITICAL)
        try:
            self.client.close(timeout=10)
        except Exception:  # noqa: BLE001 - closing after a failure: nothing more to say
            pass
        finally:
            if lost:
                logging.disable(held)
        if self.cluster is not None:
            try:
                self.cluster.close(timeout=10)
            except Exception:  # noqa: BLE001
                pass


def worker_threads(workers: dict) -> int:
    """The threads of a scheduler's workers (`Client.scheduler_info()["workers"]`), all together."""
    return sum(w.get("nthreads", 0) for w in workers.values())


def connect(spec, workers: Optional[int] = None) -> Connection:
    """A connection to the cluster `spec` names: "local" (a LocalCluster of worker processes on
    this machine, one single-thread worker per core unless `workers` says), an address
    ("tcp://HOST:PORT") of a running scheduler, or a `dask.distributed.Client` (used as is,
    never closed here). Raises ClusterError within about CONNECT_SECONDS if none answers."""
    distributed = _distributed()
    if isinstance(spec, distributed.Client):
        return Connection(spec, owned=False)
    if not isinstance(spec, str):
        raise ClusterError(f"cluster={spec!r}: expected 'local', a scheduler address such as tcp://host:8786, or a dask Client")
    if spec == "local":
        count = workers or os.cpu_count() or 1
        cluster = distributed.LocalCluster(
            n_workers=count, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0",
            silence_logs=logging.ERROR,
        )
        return Connection(distributed.Client(cluster, set_as_default=False), cluster)
    if "://" not in spec and ":" not in spec:
        raise ClusterError(f"--cluster {spec!r}: expected local or a scheduler address such as tcp://host:8786")
    try:
        client = distributed.Client(spec, timeout=CONNECT_SECONDS, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise ClusterError(f"--cluster {spec}: no Dask scheduler answers there within {CONNECT_SECONDS:g} s ({exc})") from None
    except ValueError as exc:
        raise ClusterError(f"--cluster {spec}: {exc}") from None
    return Connection(client)


def package_scene(main: Optional[str], reads: list, loaded, flat, overrides=(), syntax=None, width=None,
                  integrator=None) -> chunks.ScenePackage:
    """The scene as data for the workers. `main` is the scene file read (None for standard input,
    a dict or a model: then its canonical JSON is sent, overrides applied); `reads` the files the
    load opened (scenefmt.files.recording_reads)."""
    from scenefmt.files import FileProblem, read_regular_file

    files = {}
    if main is None:
        from scenefmt.writing import dumps

        main = os.path.join(os.getcwd(), ".rt-cluster-scene.json")
        files[main] = dumps(loaded.scene, "json").encode("utf-8")
        overrides, syntax = (), "json"
    else:
        main = os.path.abspath(main)
    for path in reads:
        if path in files:
            continue
        try:
            files[path] = read_regular_file(path, 1 << 32)
        except FileProblem:
            continue  # a file the load tried and did without
    return chunks.ScenePackage(
        main=main, files=tuple(sorted(files.items())), overrides=tuple(overrides), syntax=syntax, width=width,
        integrator=integrator, digest=chunks.flat_digest(flat), renderer=chunks.renderer_version(),
    )


def render_on_cluster(
    client,
    package: chunks.ScenePackage,
    flat,
    frame,
    *,
    features,
    samples: Optional[int] = None,
    max_depth: Optional[int] = None,
    seed: Optional[int] = None,
    film=None,
    progress: Optional[Callable] = None,
    should_stop: Optional[Callable[[], bool]] = None,
    time_budget: Optional[float] = None,
    noise_target: Optional[float] = None,
    notify: Optional[Callable[[str], None]] = None,
    chunk_seconds: float = chunks.CHUNK_SECONDS,
    warm_kernel: bool = True,
):
    """Render on the cluster of `client` as `renderer.render.render_flat` renders here, with the
    same options and the same result (a RenderResult); the image is the local one bit for bit.

    `warm_kernel`: compile the tile kernel here first, into the disk cache that workers on this
    machine load from (Connection.local); workers elsewhere compile or load their own, so for
    them it would only delay the render."""
    distributed = _distributed()
    from renderer.film import Film, relative_noise
    from renderer.render import RenderResult, RenderStats, report_progress
    from renderer.variants import is_compiled

    if client.status != "running":  # it lost its scheduler during an earlier scene of a batch
        raise ClusterLost("the cluster's scheduler went away during an earlier render: nothing more can run on it")
    width, height = frame.width, frame.height
    target = samples if samples is not None else frame.samples
    depth = max_depth if max_depth is not None else frame.max_depth
    seed = seed if seed is not None else frame.seed
    estimator = frame.estimator
    stats = RenderStats(target_samples=target, features=features)
    if film is None:
        film = Film.empty(width, height)
    stats.samples = film.samples

    if warm_kernel:  # compiled once, here, rather than by every worker process at once
        if notify is not None and not is_compiled(features, "tile"):
            notify(f"compiling the renderer's {features.tag!r} tile kernel for the workers: 8 to 30 seconds on 2 cores, once")
        started = time.perf_counter()
        chunks.warm_tile_kernel(flat, features)
        stats.kernel_seconds = time.perf_counter() - started

    address = client.scheduler.address  # named in the message if the scheduler goes away
    try:
        client.wait_for_workers(1, timeout=WORKERS_SECONDS)
    except Exception as exc:  # noqa: BLE001 - said in words: a timeout, or a scheduler that went away
        if client.status == "running" and isinstance(exc, TimeoutError):  # (a TimeoutError is an OSError)
            raise ClusterError(f"no worker joined the cluster within {WORKERS_SECONDS:g} s ({exc})") from None
        if client.status != "running" or isinstance(exc, OSError):
            raise ClusterLost(f"the cluster's scheduler at {address} went away before the render started") from None
        raise
    threads = worker_threads(client.scheduler_info()["workers"]) or 1
    tiles = chunks.plan_tiles(width, height, threads)
    rounds = chunks.Rounds(film.samples)
    scene = client.submit(chunks.package_value, package, key=f"rt-scene-{package.key}-{os.urandom(4).hex()}", pure=False)

    # Per tile: its sums after the last round it finished, and those of rounds not merged yet.
    latest = [(t.of(film.total).copy(), t.of(film.total_sq).copy()) for t in tiles]
    done = [0] * len(tiles)  # rounds each tile has finished
    ahead: list[dict] = [{} for _ in tiles]  # round -> ChunkResult, for rounds past the merged film
    merged = 0  # rounds merged into the film
    running: dict = {}  # future -> (tile index, round)
    busy: set = set()  # tiles with a chunk running (a tile's rounds form a chain: one at a time)
    finished = Finished()
    cost = [0.0, 0]  # chunk seconds, pixel-samples: the measured speed
    render_start = time.perf_counter()
    last_noise = render_start
    stop_submitting = film.samples >= target
    watch = WorkerWatch(client)

    def budget_left() -> Optional[float]:
        return None if time_budget is None else time_budget - (time.perf_counter() - render_start)

    def submit(i: int) -> None:
        r = done[i]
        if r >= rounds.planned:
            if rounds.last_end() >= target or stop_submitting:
                return
            speed = cost[0] / cost[1] if cost[1] else 0.0
            previous = rounds.bounds[-1] - rounds.bounds[-2] if rounds.planned else 0
            size = chunks.next_round_size(previous, speed, max(t.pixels for t in tiles), target - rounds.last_end(),
                                          budget_left(), width * height, threads, chunk_seconds)
            rounds.plan(size)
        start, count = rounds.range(r)
        chunk = chunks.Chunk(tiles[i], start, count, width, seed, depth, estimator)
        total, total_sq = latest[i]
        future = client.submit(chunks.render_chunk, scene, features, chunk, total, total_sq, pure=False,
                               key=f"rt-chunk-{package.key[:8]}-{i}-{r}-{os.urandom(4).hex()}")
        running[future] = (i, r)
        busy.add(i)
        finished.watch(future)

    def may_submit(i: int) -> bool:
        return not stop_submitting and done[i] < merged + chunks.LOOKAHEAD and i not in busy

    def failure(message: str, lost: bool = False) -> ClusterError:
        """The error that ends the render, holding the film merged so far (every whole round)."""
        stats.seconds = time.perf_counter() - render_start
        stats.noise = relative_noise(film)
        kind = ClusterLost if lost else ClusterError
        return kind(message, RenderResult(film, stats))

    def gone() -> ClusterError:
        return failure(f"the cluster's scheduler at {address} went away after {film.samples} of {target} samples per "
                       f"pixel (the connection to it is lost)", lost=True)

    def chunk_result(future) -> chunks.ChunkResult:
        """A finished chunk's result; ClusterError for a chunk that failed, was lost or cancelled."""
        if future.status == "finished":
            try:
                return future.result()
            except Exception as exc:  # noqa: BLE001 - fetching it failed: the scheduler or a worker is gone
                if client.status != "running":
                    raise gone() from None
                fetch = f"a chunk's result could not be fetched from the cluster: {type(exc).__name__}: {exc}"
                raise failure(fetch) from None
        if client.status != "running":  # the client cancels every future when it loses the scheduler
            raise gone()
        if future.status == "error":  # a task Dask gave up on, as when its workers died too often
            exc = future.exception()
            raise failure(f"a chunk could not be rendered on the cluster: {type(exc).__name__}: {exc}")
        raise failure(f"a chunk was {future.status} on the cluster before it finished")

    try:
        for i in range(len(tiles)):
            if may_submit(i):
                submit(i)
        while running:
            if should_stop is not None and should_stop():
                stats.interrupted = True
                stats.stop_reason = "interrupted"
                break
            left = budget_left()
            if left is not None and left <= 0 and film.samples > rounds.start:
                stats.stop_reason = "time"
                break
            ready = [f for f in finished.wait(POLL_SECONDS) if f in running]
            if not ready:  # none finished: is anyone still there to finish them?
                if client.status != "running":
                    raise gone()
                if watch.workerless_for() > WORKERS_SECONDS:
                    raise failure(f"every worker left the cluster (the scheduler at {address}) after {film.samples} of "
                                  f"{target} samples per pixel, and none joined within {WORKERS_SECONDS:g} s", lost=True)
            for future in ready:
                i, r = running.pop(future)
                busy.discard(i)
                result = chunk_result(future)
                if result.error is not None:
                    raise failure(result.error)
                latest[i] = (result.total, result.total_sq)
                ahead[i][r] = result
                done[i] = r + 1
                cost[0] += result.seconds
                cost[1] += tiles[i].pixels * rounds.range(r)[1]
            # Merge every round that all tiles have finished, in tile order.
            while merged < rounds.planned and all(merged in a for a in ahead):
                for tile, a in zip(tiles, ahead):
                    result = a.pop(merged)
                    tile.of(film.total)[...] = result.total
                    tile.of(film.total_sq)[...] = result.total_sq
                    stats.rays += result.rays
                    stats.bad_samples += result.bad
                merged += 1
                film.samples = rounds.bounds[merged]
                stats.samples = film.samples
                stats.seconds = time.perf_counter() - render_start
                if stats.first_pass_seconds == 0.0:
                    stats.first_pass_seconds = stats.seconds
                reached, last_noise = report_progress(film, stats, progress, noise_target, last_noise)
                if reached:
                    stats.stop_reason = "noise"
                    stop_submitting = True
                    break
                if film.samples >= target:
                    stop_submitting = True
            if stats.stop_reason == "noise":
                break
            if left is not None and left <= 0:
                stop_submitting = film.samples > rounds.start or stop_submitting
            for i in range(len(tiles)):
                if may_submit(i):
                    submit(i)
    except ClusterError:
        raise
    except Exception as exc:
        # Submitting or asking the scheduler failed: a connection that broke (an OSError, as
        # distributed's CommClosedError is) or a client that lost the scheduler is said, with the
        # merged samples; anything else is a bug of ours and keeps its traceback.
        if client.status != "running" or isinstance(exc, OSError):
            raise gone() from None
        raise
    finally:
        # Cancel what is still running (a budget, Ctrl-C, a failure): the film keeps every merged
        # round. A scheduler that is gone has nothing to cancel, and is not waited for.
        if client.status == "running":
            try:
                client.cancel([*running, scene], force=True)
            except Exception:  # noqa: BLE001 - it went away just now: nothing is left to cancel
                pass
    stats.seconds = time.perf_counter() - render_start
    stats.noise = relative_noise(film)
    return RenderResult(film, stats)


class WorkerWatch:
    """How long the cluster has had no worker at all, asked of the scheduler at most every
    WORKERS_POLL_SECONDS (only while no chunk finishes). A worker that dies is replaced by its
    nanny, or its chunks go to the others; with none left, chunks would wait for ever."""

    def __init__(self, client):
        self.client = client
        self.asked = time.monotonic()
        self.since: Optional[float] = None  # when it was first seen without workers

    def workerless_for(self) -> float:
        now = time.monotonic()
        if now - self.asked >= WORKERS_POLL_SECONDS:
            self.asked = now
            if self.client.nthreads():
                self.since = None
            elif self.since is None:
                self.since = now
        return 0.0 if self.since is None else now - self.since
