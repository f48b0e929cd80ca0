"""A render cut into chunks for a Dask cluster, and the chunks' results merged into one film.

How the work is cut, and why the image is the local render's bit for bit:

- The image is cut into tiles (rectangles of pixels) and the samples into rounds (ranges of
  sample indices, the same for every tile). A chunk is one tile and one round.
- A chunk does not return the sums of its own samples: it is given the tile's sums after the
  previous round and continues them, sample index ascending, with `tracing.tile.render_tile`.
  A pixel's sum is therefore built by exactly the additions, in exactly the order, of a local
  render (`integrator.render_pass` adds each pixel's samples in ascending order into the same
  sums, pass after pass): floating-point addition is not associative, and summing each range
  apart and adding the partial sums would differ from the local image in the last bits.
- So the chunks of one tile form a chain (round r needs round r - 1), while tiles run in
  parallel. The film merged so far holds every tile after the same round, so it is always an
  image of a whole number of samples per pixel: what progress shows, what a noise target
  tests and what Ctrl-C or --save-state keep. Tiles may run ahead of it by `LOOKAHEAD` rounds.
- A chunk is a pure function of its inputs (the scene's bytes, the tile, the sample range and
  the sums it continues), so a chunk lost with a worker is computed again, with the same bits.

The worker side (`render_chunk`) builds the scene from the files the client read (a
`ScenePackage`), once per process, and keeps it; the dask side (submitting, waiting,
cancelling) is `rt/cluster.py`. Nothing here imports dask.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import tempfile
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

# A chunk should take about this long on one worker thread: long enough that the per-chunk
# overhead of the scheduler (a few milliseconds) is noise, short enough that a lost worker
# costs little and a time budget is kept closely.
CHUNK_SECONDS = 2.0
# Rounds a tile may run ahead of the merged film (memory: one film's sums per round ahead).
LOOKAHEAD = 2
# Tiles per worker thread, at least, so that a slow tile does not leave threads idle.
TILES_PER_THREAD = 4
MAX_TILE = 64  # pixels on a side
MIN_TILE = 8


@dataclass(frozen=True)
class Tile:
    x0: int
    y0: int
    width: int
    height: int

    @property
    def pixels(self) -> int:
        return self.width * self.height

    def of(self, array: np.ndarray) -> np.ndarray:
        """This tile's part of an image-shaped array (a view)."""
        return array[self.y0:self.y0 + self.height, self.x0:self.x0 + self.width]


def plan_tiles(width: int, height: int, threads: int) -> list[Tile]:
    """Square tiles of at most MAX_TILE pixels a side, smaller (down to MIN_TILE) until there are
    TILES_PER_THREAD per worker thread; row-major, the order they are merged in."""
    side = MAX_TILE
    while side > MIN_TILE and math.ceil(width / side) * math.ceil(height / side) < TILES_PER_THREAD * max(1, threads):
        side //= 2
    return [
        Tile(x0, y0, min(side, width - x0), min(side, height - y0))
        for y0 in range(0, height, side)
        for x0 in range(0, width, side)
    ]


def tile_sampling(sampling, tile: Tile):
    """A render's sampling (renderer.sampling.Sampling) as a chunk of `tile` takes it: adaptive
    sampling's per-pixel guard cut to the tile, whose kernel indexes pixels within the tile."""
    if sampling.guard.size == 0:
        return sampling
    return sampling._replace(guard=np.ascontiguousarray(tile.of(sampling.guard)))


def renderer_version() -> str:
    """A name for the renderer's compiled code: the hash of its sources that names the kernel
    cache folder (jit_cache). A worker with other sources would render other bits: it refuses."""
    from renderer import jit_cache

    return jit_cache.source_version()


def flat_digest(flat) -> str:
    """sha256 of every table of a flat scene: the client and each worker must build the same one."""
    digest = hashlib.sha256()
    for name, array in zip(flat._fields, flat):
        array = np.ascontiguousarray(array)
        digest.update(f"{name}:{array.dtype.str}:{array.shape};".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


@dataclass(frozen=True)
class ScenePackage:
    """A scene as data, for workers that may not see the client's files: the bytes of the scene
    file and of every file it read (includes, textures, meshes), by the absolute path the client
    read them at, and the options that shape the flat scene. `digest` is the client's
    `flat_digest`, `renderer` its `renderer_version`."""

    main: str
    files: tuple[tuple[str, bytes], ...]
    overrides: tuple[str, ...] = ()
    syntax: Optional[str] = None
    width: Optional[int] = None
    integrator: Optional[str] = None
    digest: str = ""
    renderer: str = ""

    @property
    def key(self) -> str:
        digest = hashlib.sha256(repr((self.main, self.overrides, self.syntax, self.width, self.integrator, self.digest,
                                      self.renderer)).encode())
        for name, data in self.files:
            digest.update(name.encode() + b"\0" + hashlib.sha256(data).digest())
        return digest.hexdigest()[:24]


def _rooted(root: str, path: str) -> str:
    """`path` (absolute) recreated under `root`, so that relative names between files still resolve."""
    drive, rest = os.path.splitdrive(os.path.abspath(path))
    return os.path.join(root, drive.replace(":", ""), rest.lstrip("/\\"))


class ChunkFailed(Exception):
    """A chunk could not run; the message is a sentence for the user (no remote traceback)."""


@dataclass
class _Built:
    flat: object
    kernel: object
    height: int = 0  # the image's height in pixels, at the package's width
    features: object = None


_built: "OrderedDict[tuple, _Built]" = OrderedDict()
_built_lock = threading.Lock()
_KEEP_SCENES = 4  # scenes a worker keeps built (a batch renders one after the other)
# A guided render's flat scene with its guide, per (scene, kernel, seed, depth, sampler): each worker
# trains the guide itself, the same on every worker (guide_training.py), rather than the client
# compiling the training kernel and sending the guide.
_guided: "OrderedDict[tuple, object]" = OrderedDict()
_guide_lock = threading.Lock()


def warm_tile_kernel(flat, features):
    """The tile kernel for `features` (a variants.KernelFeatures), compiled or loaded from the disk
    cache and run once (one pixel, no samples) so that it is ready; marked compiled for the next
    render's message."""
    from renderer.variants import kernel_set, mark_compiled

    kernel = kernel_set(features).render_tile
    from renderer.film import Film
    from renderer.sampling import uniform_sampling

    kernel(flat, 1, 0, 0, 0, 0, 0, 1, 1, uniform_sampling(), Film.empty(1, 1).sums, np.zeros(1, np.int64),
           np.zeros(1, np.int64))
    mark_compiled(features, "tile")
    return kernel


def build(package: ScenePackage, features) -> _Built:
    """The flat scene of `package` and its tile kernel, built once per worker process and kept."""
    cache_key = (package.key, features)
    with _built_lock:
        if cache_key in _built:
            _built.move_to_end(cache_key)
            return _built[cache_key]
        if package.renderer != renderer_version():
            raise ChunkFailed(f"this worker runs other renderer code than the client (kernels {renderer_version()}, "
                              f"the client's {package.renderer}): install the same rt on every machine")
        from renderer.session import flatten_loaded
        from scenefmt.diagnostics import SceneError
        from scenefmt.validation import load_source

        root = tempfile.mkdtemp(prefix="rt-scene-")
        try:
            for name, data in package.files:
                dest = _rooted(root, name)
                os.makedirs(os.path.dirname(dest), exist_ok=True)
                with open(dest, "wb") as fh:
                    fh.write(data)
            try:
                # Every file the client read (it checked what the scene may read) is under root, and only those.
                loaded = load_source(Path(_rooted(root, package.main)), package.overrides, package.syntax, allow_paths=[root])
                graph, flat = flatten_loaded(loaded, package.width, package.integrator)
            except SceneError as exc:
                first = exc.diagnostics[0] if exc.diagnostics else exc
                raise ChunkFailed(f"the scene does not load on a worker: {first}") from None
            except ValueError as exc:
                raise ChunkFailed(f"the scene does not load on a worker: {exc}") from None
        finally:
            shutil.rmtree(root, ignore_errors=True)
        if flat_digest(flat) != package.digest:
            raise ChunkFailed("a worker built another scene than the client from the same files (different versions of "
                              "rt or its dependencies?)")
        built = _Built(flat, warm_tile_kernel(flat, features), graph.image.pixel_height, features)
        _built[cache_key] = built
        while len(_built) > _KEEP_SCENES:
            _built.popitem(last=False)
        return built


@dataclass
class Chunk:
    """One tile, one range of samples: what a worker is asked to render."""

    tile: Tile
    sample_start: int
    sample_count: int
    image_width: int
    seed: int
    max_depth: int
    integrator: int  # flat.INTEGRATORS code
    sampling: tuple  # renderer.sampling.Sampling


@dataclass
class ChunkResult:
    sums: Optional[tuple] = None  # renderer.film.PixelSums of the tile, continued
    rays: int = 0
    bad: int = 0
    seconds: float = 0.0  # rendering only
    error: Optional[str] = None  # a sentence, when the chunk could not run


def guided_flat(package: ScenePackage, built: _Built, chunk: "Chunk"):
    """The worker's flat scene with the guide a guided render learns for the chunk's seed, depth
    and sampler, trained once per worker on its calling thread (guide_training.train_guide)."""
    from renderer.guide_training import train_guide
    from renderer.variants import kernel_set

    key = (package.key, built.features, chunk.seed, chunk.max_depth, chunk.sampling.sampler)
    with _guide_lock:
        if key not in _guided:
            flat, _ = train_guide(built.flat, chunk.image_width, built.height, chunk.seed, chunk.max_depth,
                                  chunk.sampling.sampler, kernel_set(built.features), serial=True)
            _guided[key] = flat
            while len(_guided) > _KEEP_SCENES:
                _guided.popitem(last=False)
        return _guided[key]


def render_chunk(package: ScenePackage, features, chunk: Chunk, sums) -> ChunkResult:
    """The worker's task: continue the tile's sums `sums` (renderer.film.PixelSums, after the
    previous round) with the chunk's samples. Failures come back as `error`, a sentence, rather
    than as an exception: dask would print a worker's traceback, and the user needs one line, once."""
    try:
        from renderer.film import PixelSums

        from renderer.flat import INTEGRATOR_GUIDED

        built = build(package, features)
        flat = guided_flat(package, built, chunk) if chunk.integrator == INTEGRATOR_GUIDED else built.flat
        sums = PixelSums(*(np.array(array, order="C") for array in sums))  # arguments may arrive read-only
        rows = chunk.tile.height
        row_rays = np.zeros(rows, np.int64)
        row_bad = np.zeros(rows, np.int64)
        t0 = time.perf_counter()
        built.kernel(flat, chunk.image_width, chunk.tile.x0, chunk.tile.y0, chunk.seed, chunk.sample_start,
                     chunk.sample_count, chunk.max_depth, chunk.integrator, chunk.sampling, sums, row_rays, row_bad)
        seconds = time.perf_counter() - t0
        return ChunkResult(sums, int(row_rays.sum()), int(row_bad.sum()), seconds)
    except ChunkFailed as exc:
        return ChunkResult(error=str(exc))
    except Exception as exc:  # noqa: BLE001 - reported once, in words, by the client
        return ChunkResult(error=f"a worker failed: {type(exc).__name__}: {exc}")


def package_value(package: ScenePackage) -> ScenePackage:
    """The task that holds a scene's package on the cluster: computed again from its argument if
    the worker that held it dies."""
    return package


@dataclass
class Rounds:
    """The sample ranges of the rounds: round r is [bounds[r], bounds[r + 1]). A round is sized
    when the first tile needs it, from the speed measured so far, so a chunk takes about
    CHUNK_SECONDS (the first round is one sample, to measure)."""

    start: int
    bounds: list = field(default_factory=list)

    def __post_init__(self):
        self.bounds = [self.start]

    @property
    def planned(self) -> int:
        return len(self.bounds) - 1

    def last_end(self) -> int:
        return self.bounds[-1]

    def plan(self, count: int) -> None:
        self.bounds.append(self.bounds[-1] + count)

    def range(self, r: int) -> tuple[int, int]:
        return self.bounds[r], self.bounds[r + 1] - self.bounds[r]


def next_round_size(previous: int, seconds_per_pixel_sample: float, tile_pixels: int, left: int,
                    budget_left: Optional[float], image_pixels: int, threads: int, chunk_seconds: float = CHUNK_SECONDS) -> int:
    """Samples in the next round: a chunk of about `chunk_seconds`, at most four times the last
    round, within the samples `left` and, under a time budget, the time left for the whole image."""
    if previous == 0 or seconds_per_pixel_sample <= 0:
        # No speed measured yet: one sample, to measure it. Never more than `left` either, since
        # a round is planned only while samples are left (left >= 1).
        return 1
    n = int(chunk_seconds / (seconds_per_pixel_sample * max(1, tile_pixels)))
    n = max(1, min(n, 4 * previous))
    if budget_left is not None:
        whole_round = seconds_per_pixel_sample * image_pixels / max(1, threads)
        n = max(1, min(n, int(budget_left / whole_round) if whole_round > 0 else n))
    return max(1, min(n, left))
