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
from typing import Any, Optional

from renderer.executor import ExecutorFailed

from . import chunks

CONNECT_SECONDS = 5.0  # to reach a scheduler given by address
WORKERS_SECONDS = 60.0  # to wait for a first worker to join
POLL_SECONDS = 0.2  # between checks of Ctrl-C and the time budget while chunks run
WORKERS_POLL_SECONDS = 2.0  # between asks to the scheduler whether any worker is left, while none finishes
MISSING = "rendering on a cluster needs dask.distributed: pip install '.[cluster]' in rt's folder (or pip install distributed)"


class ClusterError(ExecutorFailed):
    """The cluster cannot be used or a chunk failed; the message is a sentence to show.

    `partial`: for a failure once chunks were submitted, the RenderResult of the samples merged
    before it (what `rt render` saves, as after a failed write); None before that."""


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

    def __post_init__(self):
        # While this process owns a client, distributed's own log records are held back: when a
        # scheduler dies, its background senders and the reconnecting client log tracebacks (at
        # any moment, from their own threads), after or even before the render says in one line
        # what happened. A client the caller passed in keeps the caller's logging.
        self._held_logging = logging.root.manager.disable
        if self.owned:
            logging.disable(logging.CRITICAL)

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
        # and distributed logs the cancellation with a traceback (held back: see __post_init__).
        try:
            self.client.close(timeout=10)
        except Exception:  # noqa: BLE001 - closing after a failure: nothing more to say
            pass
        if self.cluster is not None:
            try:
                self.cluster.close(timeout=10)
            except Exception:  # noqa: BLE001
                pass
        logging.disable(self._held_logging)


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


class ClusterRounds:
    """The executor (renderer/executor.py) of a Dask cluster: rounds of tiles, merged in order.

    Each step waits up to POLL_SECONDS for chunks to finish, merges the next round once every
    tile has finished it (so the film always holds a whole number of samples per pixel) and
    submits the chunks that may run: a tile's rounds form a chain, and a tile may run
    `chunks.LOOKAHEAD` rounds ahead of the merged film. Rounds are sized from the speed measured
    so far (`chunks.next_round_size`) to take about `chunk_seconds` a chunk, within the time left.

    `warm_kernel`: compile the tile kernel here first, into the disk cache that workers on this
    machine load from (Connection.local); workers elsewhere compile or load their own, so for
    them it would only delay the render."""

    can_switch_kernel = False  # every worker would have to compile the other kernel
    stops_on_time_before_first_step = False  # a spent budget still waits for the first round

    def __init__(self, client, package: chunks.ScenePackage, flat, width: int, height: int, *, seed: int, depth: int,
                 estimator: int, chunk_seconds: float = chunks.CHUNK_SECONDS, warm_kernel: bool = True, sampling=None):
        from renderer.sampling import uniform_sampling

        self.client = client
        self.sampling = sampling if sampling is not None else uniform_sampling()
        self.package = package
        self.flat = flat
        self.width, self.height = width, height
        self.seed, self.depth, self.estimator = seed, depth, estimator
        self.chunk_seconds = chunk_seconds
        self.warm_kernel = warm_kernel
        self.address = None  # the scheduler's, named in the message if it goes away
        self.scene = None  # the future that holds the package on the cluster
        self.running: dict = {}  # future -> (tile index, round)
        self.started_chunks = False

    @classmethod
    def for_frame(cls, client, package: chunks.ScenePackage, flat, frame, *, seed: Optional[int] = None,
                  max_depth: Optional[int] = None, chunk_seconds: float = chunks.CHUNK_SECONDS,
                  warm_kernel: bool = True) -> "ClusterRounds":
        """The executor for `flat` with the image settings of `frame`, `seed` and `max_depth`
        overriding the scene's."""
        from renderer.sampling import uniform_sampling

        return cls(client, package, flat, frame.width, frame.height, seed=seed if seed is not None else frame.seed,
                   depth=max_depth if max_depth is not None else frame.max_depth, estimator=frame.estimator,
                   chunk_seconds=chunk_seconds, warm_kernel=warm_kernel, sampling=uniform_sampling(frame.sampler))

    def start(self, film, features, notify=None):
        from renderer.executor import KernelTime
        from renderer.film import PixelSums
        from renderer.variants import compile_wait, is_compiled

        client = self.client
        if client.status != "running":  # it lost its scheduler during an earlier scene of a batch
            raise ClusterLost("the cluster's scheduler went away during an earlier render: nothing more can run on it")
        self.film, self.features = film, features
        spent = KernelTime()
        if self.warm_kernel:  # compiled once, here, rather than by every worker process at once
            if notify is not None and not is_compiled(features, "tile"):
                notify(f"compiling the renderer's {features.tag!r} tile kernel for the workers: {compile_wait(features)}, once")
            started = time.perf_counter()
            chunks.warm_tile_kernel(self.flat, features)
            spent = KernelTime(time.perf_counter() - started)
        self.address = client.scheduler.address
        try:
            client.wait_for_workers(1, timeout=WORKERS_SECONDS)
        except Exception as exc:  # noqa: BLE001 - said in words: a timeout, or a scheduler that went away
            if client.status == "running" and isinstance(exc, TimeoutError):  # (a TimeoutError is an OSError)
                raise ClusterError(f"no worker joined the cluster within {WORKERS_SECONDS:g} s ({exc})") from None
            if client.status != "running" or isinstance(exc, OSError):
                raise ClusterLost(f"the cluster's scheduler at {self.address} went away before the render started") from None
            raise
        self.threads = worker_threads(client.scheduler_info()["workers"]) or 1
        self.tiles = chunks.plan_tiles(self.width, self.height, self.threads)
        self.rounds = chunks.Rounds(film.samples)
        package = self.package
        self.scene = client.submit(chunks.package_value, package, key=f"rt-scene-{package.key}-{os.urandom(4).hex()}",
                                   pure=False)
        # Per tile: its sums after the last round it finished, and those of rounds not merged yet.
        self.latest = [PixelSums(*(t.of(array).copy() for array in film.sums)) for t in self.tiles]
        self.done = [0] * len(self.tiles)  # rounds each tile has finished
        self.ahead: list[dict] = [{} for _ in self.tiles]  # round -> ChunkResult, for rounds past the merged film
        self.merged = 0  # rounds merged into the film
        self.busy: set = set()  # tiles with a chunk running (a tile's rounds form a chain: one at a time)
        self.finished = Finished()
        self.cost = [0.0, 0]  # chunk seconds, pixel-samples: the measured speed
        self.stop_submitting = False
        self.watch = WorkerWatch(client)
        return spent

    def set_sampling(self, sampling) -> None:
        """Chunks submitted from now on render with `sampling` (adaptive sampling's rule, set once
        its pilot is merged: no chunk past the pilot was submitted before, see the session)."""
        self.sampling = sampling

    def switch_kernel(self, features, notify=None):
        raise NotImplementedError("a cluster render keeps the kernel it started with")

    # -- submitting

    def _submit(self, i: int, plan) -> None:
        rounds, tiles = self.rounds, self.tiles
        r = self.done[i]
        if r >= rounds.planned:
            if rounds.last_end() >= plan.target or self.stop_submitting:
                return
            speed = self.cost[0] / self.cost[1] if self.cost[1] else 0.0
            previous = rounds.bounds[-1] - rounds.bounds[-2] if rounds.planned else 0
            budget_left = plan.time_left() if plan.time_left is not None else None
            size = chunks.next_round_size(previous, speed, max(t.pixels for t in tiles), plan.target - rounds.last_end(),
                                          budget_left, self.width * self.height, self.threads, self.chunk_seconds)
            rounds.plan(size)
        start, count = rounds.range(r)
        chunk = chunks.Chunk(tiles[i], start, count, self.width, self.seed, self.depth, self.estimator,
                             chunks.tile_sampling(self.sampling, tiles[i]))
        future = self.client.submit(chunks.render_chunk, self.scene, self.features, chunk, self.latest[i], pure=False,
                                    key=f"rt-chunk-{self.package.key[:8]}-{i}-{r}-{os.urandom(4).hex()}")
        self.running[future] = (i, r)
        self.busy.add(i)
        self.finished.watch(future)

    def _submit_what_may_run(self, plan) -> None:
        for i in range(len(self.tiles)):
            if not self.stop_submitting and self.done[i] < self.merged + chunks.LOOKAHEAD and i not in self.busy:
                self._submit(i, plan)

    # -- failures

    @staticmethod
    def _failure(message: str, lost: bool = False) -> ClusterError:
        """The error that ends the render; the session adds the film merged so far (every whole round)."""
        return (ClusterLost if lost else ClusterError)(message)

    def _gone(self) -> ClusterError:
        return self._failure(f"the cluster's scheduler at {self.address} went away after {self.film.samples} of "
                             f"{self.target} samples per pixel (the connection to it is lost)", lost=True)

    def _chunk_result(self, future) -> chunks.ChunkResult:
        """A finished chunk's result; ClusterError for a chunk that failed, was lost or cancelled."""
        if future.status == "finished":
            try:
                return future.result()
            except Exception as exc:  # noqa: BLE001 - fetching it failed: the scheduler or a worker is gone
                if self.client.status != "running":
                    raise self._gone() from None
                fetch = f"a chunk's result could not be fetched from the cluster: {type(exc).__name__}: {exc}"
                raise self._failure(fetch) from None
        if self.client.status != "running":  # the client cancels every future when it loses the scheduler
            raise self._gone()
        if future.status == "error":  # a task Dask gave up on, as when its workers died too often
            exc = future.exception()
            raise self._failure(f"a chunk could not be rendered on the cluster: {type(exc).__name__}: {exc}")
        raise self._failure(f"a chunk was {future.status} on the cluster before it finished")

    # -- the steps

    def _round_complete(self) -> bool:
        return self.merged < self.rounds.planned and all(self.merged in a for a in self.ahead)

    def _merge_round(self):
        """Merge the next round, which every tile has finished, into the film, in tile order."""
        from renderer.executor import Step

        film = self.film
        rays = bad = 0
        for tile, a in zip(self.tiles, self.ahead):
            result = a.pop(self.merged)
            for array, part in zip(film.sums, result.sums):
                tile.of(array)[...] = part
            rays += result.rays
            bad += result.bad
        self.merged += 1
        added = self.rounds.bounds[self.merged] - film.samples
        film.samples = self.rounds.bounds[self.merged]
        # No round is planned past the session's target of the moment (`_submit`); that target may
        # move on (adaptive sampling's pilot and checkpoints), so reaching it stops nothing here.
        return Step(added, rays, bad, 0.0)

    def advance(self, plan, should_stop=None):
        from renderer.executor import Step

        self.target = plan.target
        try:
            if not self.started_chunks:
                self.started_chunks = True
                self._submit_what_may_run(plan)
            if not self._round_complete():
                self._collect(plan)
            step = self._merge_round() if self._round_complete() else Step(0, 0, 0, 0.0)
            if plan.time_left is not None and plan.time_left() <= 0:
                self.stop_submitting = self.film.samples > self.rounds.start or self.stop_submitting
            self._submit_what_may_run(plan)
            return step
        except ClusterError:
            raise
        except Exception as exc:
            # Submitting or asking the scheduler failed: a connection that broke (an OSError, as
            # distributed's CommClosedError is) or a client that lost the scheduler is said, with the
            # merged samples; anything else is a bug of ours and keeps its traceback.
            if self.client.status != "running" or isinstance(exc, OSError):
                raise self._gone() from None
            raise

    def _collect(self, plan) -> None:
        """Wait up to POLL_SECONDS for chunks to finish and keep their results."""
        ready = [f for f in self.finished.wait(POLL_SECONDS) if f in self.running]
        if not ready:  # none finished: is anyone still there to finish them?
            if self.client.status != "running":
                raise self._gone()
            if self.watch.workerless_for() > WORKERS_SECONDS:
                raise self._failure(f"every worker left the cluster (the scheduler at {self.address}) after {self.film.samples} "
                                    f"of {plan.target} samples per pixel, and none joined within {WORKERS_SECONDS:g} s", lost=True)
        for future in ready:
            if future.status == "lost" and self.client.status == "running":
                # Finished, but the worker that held its result died before it was fetched: the
                # scheduler computes it again for the future we still hold; wait for that.
                self.finished.watch(future)
                continue
            i, r = self.running.pop(future)
            self.busy.discard(i)
            result = self._chunk_result(future)
            if result.error is not None:
                raise self._failure(result.error)
            self.latest[i] = result.sums
            self.ahead[i][r] = result
            self.done[i] = r + 1
            self.cost[0] += result.seconds
            self.cost[1] += self.tiles[i].pixels * self.rounds.range(r)[1]

    def close(self) -> None:
        # Cancel what is still running (a budget, Ctrl-C, a failure): the film keeps every merged
        # round. A scheduler that is gone has nothing to cancel, and is not waited for.
        if self.scene is not None and self.client.status == "running":
            try:
                self.client.cancel([*self.running, self.scene], force=True)
            except Exception:  # noqa: BLE001 - it went away just now: nothing is left to cancel
                pass


def cluster_executor(connection: Connection, package: chunks.ScenePackage, flat, frame, *, seed: Optional[int] = None,
                     max_depth: Optional[int] = None) -> ClusterRounds:
    """The executor of a render on `connection`'s cluster: workers this connection started
    load the tile kernel this process warms (Connection.local)."""
    if frame.integrator == "caustics":
        # Its photons land anywhere in the image, so no tile's samples are complete on their own.
        raise ClusterError("integrator caustics renders in one process, not on a cluster (its photons land anywhere in "
                           "the image, not in one tile): render without --cluster, or with integrator guided or mis")
    _distributed()
    return ClusterRounds.for_frame(connection.client, package, flat, frame, seed=seed, max_depth=max_depth,
                                   warm_kernel=connection.local)


def render_on_cluster(client, package: chunks.ScenePackage, flat, frame, *, features, samples: Optional[int] = None,
                      max_depth: Optional[int] = None, seed: Optional[int] = None, film=None,
                      chunk_seconds: float = chunks.CHUNK_SECONDS, warm_kernel: bool = True, **session_options):
    """Render on the cluster of `client` as `renderer.render.render_flat` renders here, with the
    same options and the same result (a RenderResult): the render session with a ClusterRounds
    executor. The image is the local one bit for bit; `features` is the kernel the workers use;
    `session_options` are renderer.session.render_progressively's (progress, should_stop,
    time_budget, noise_target, notify)."""
    _distributed()
    from renderer.film import Film
    from renderer.session import render_progressively

    from renderer.rare_paths import rare_path_prior

    executor = ClusterRounds.for_frame(client, package, flat, frame, seed=seed, max_depth=max_depth,
                                       chunk_seconds=chunk_seconds, warm_kernel=warm_kernel)
    session_options.setdefault("prior", rare_path_prior(flat))
    return render_progressively(executor, film if film is not None else Film.empty(frame.width, frame.height),
                                target=samples if samples is not None else frame.samples, needed=features, features=features,
                                **session_options)


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
