"""The Python API: `rt.render`, `rt.load`, `rt.validate` and the `Image` a render returns.

A process that calls `rt.render` more than once pays for imports and kernel loading once: the
second call of a small image takes milliseconds, not the second or so of a new `rt render`
process. It also keeps the scenes it prepared last (`_prepare`), so rendering an unchanged scene
again skips loading and flattening it. The steps are those of `rt render` (the render session's
`flatten_loaded`, and rt/rendering.py's `option_problem`, `sample_target`, `render_scene`), so the
same scene, seed and sample count give the same image bit for bit as `rt render --hdr out.pfm`.

Nothing heavy is imported here at module level: `import rt` stays as quick as `rt validate`.
"""

from __future__ import annotations

import math
import os
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Optional, Union

from scenefmt.assets import file_identity  # a file's identity and version: what a kept scene depends on

if TYPE_CHECKING:
    import numpy as np

    from renderer.film import Film, NoiseEstimate
    from renderer.render import RenderStats
    from scenefmt.diagnostics import Diagnostic
    from scenefmt.scene import Scene
    from scenefmt.validation import LoadedScene

SceneLike = Union[str, Path, dict, "Scene", "LoadedScene"]

DICT_NAME = "<dict>"  # the file name diagnostics give for a scene passed as a dict or a model


def _plain(value: Any) -> Any:
    """Data as the file loaders make it: dicts, lists, str, int, float, bool, None (tuples and numpy
    values become lists and Python numbers)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # a numpy array or scalar
        return _plain(value.tolist())
    if isinstance(value, Path):
        return str(value)
    return value


def load(scene: SceneLike, overrides: Iterable[str] = (), syntax: Optional[str] = None,
         allow_paths: Iterable[Union[str, Path]] = ()) -> "LoadedScene":
    """The checked scene: `.scene` (the pydantic models), `.graph` (names resolved) and `.warnings`.

    `scene` is a file name (YAML or JSON), a `scenefmt` `Scene` model, or a dict of the file's
    data; `overrides` are `--set` arguments (`"image.width=64"`). The files a scene names
    (includes, textures, meshes) are read only from the scene file's folder (the current folder
    for a dict or a model) and the folders in `allow_paths`, as `rt render --allow-path`. Raises
    `rt.SceneError`, whose `.diagnostics` list every problem with its file, line, column and key path.
    """
    from scenefmt.validation import LoadedScene
    from scenefmt.validation import load as load_file

    if isinstance(scene, LoadedScene):
        if overrides:
            raise ValueError("overrides apply to a scene file, a model or a dict, not to a scene loaded already")
        return scene
    if isinstance(scene, (str, Path)):
        return load_file(scene, overrides, syntax, allow_paths)
    return _load_data(_scene_data(scene), overrides, allow_paths)


def _load_data(data: Any, overrides: Iterable[str] = (), allow_paths: Iterable[Union[str, Path]] = ()) -> "LoadedScene":
    """The checked scene of a model's or a dict's data (`_scene_data`)."""
    from scenefmt.files import reading_within
    from scenefmt.loading import SourceDocument
    from scenefmt.validation import allowed_folders, check_document, compose

    # Relative file names in it (textures, meshes, includes) resolve from the current folder,
    # which is also where its files may be read from (with `allow_paths`).
    with reading_within(allowed_folders(Path.cwd(), allow_paths)):
        return check_document(compose(SourceDocument(DICT_NAME, data, base_dir=Path.cwd()), overrides))


def _scene_data(scene) -> Any:
    """A `scenefmt` Scene model or a dict of a scene, as the data a scene file loads to."""
    from pydantic import BaseModel

    if isinstance(scene, BaseModel):
        from scenefmt.writing import to_data

        return to_data(scene)
    if isinstance(scene, dict):
        return _plain(scene)
    raise TypeError(f"expected a scene file name, a scenefmt Scene or a dict, not {type(scene).__name__}")


@dataclass
class Validation:
    """What `rt.validate` found: `errors` (the scene cannot render) and `warnings`; `ok` if no errors."""

    errors: list["Diagnostic"] = field(default_factory=list)
    warnings: list["Diagnostic"] = field(default_factory=list)
    loaded: Optional["LoadedScene"] = None  # the scene, when it is valid

    @property
    def ok(self) -> bool:
        return not self.errors

    def __str__(self) -> str:
        lines = [str(d) for d in self.errors + self.warnings]
        return "\n".join(lines) if lines else "valid"


def validate(scene: SceneLike, overrides: Iterable[str] = (), syntax: Optional[str] = None,
             allow_paths: Iterable[Union[str, Path]] = ()) -> Validation:
    """Check a scene as `rt validate` does, without raising: the errors and warnings, each a
    `Diagnostic` with `file`, `line`, `column`, `path` and `message` (and `str()` of the lot).
    `allow_paths` as for `load`."""
    from scenefmt.diagnostics import SceneError

    try:
        loaded = load(scene, overrides, syntax, allow_paths)
    except SceneError as exc:
        return Validation(errors=list(exc.diagnostics))
    return Validation(warnings=list(loaded.warnings), loaded=loaded)


class Image:
    """A rendered image: linear radiance, its noise estimate and the render's statistics.

    - `array`: (height, width, 3) float32 linear RGB radiance, unclamped (what `--hdr` writes).
    - `samples`, `width`, `height`; `noise`: the relative RMS noise estimated from the samples
      (inf below 2 samples per pixel); `noise_interval`: (low, high), which holds the true
      relative RMS error of this image at 95%; `noise_warning`: None, or one sentence saying why
      the estimate cannot be trusted (rare bright paths dominate it); `noise_estimate`: the whole
      `renderer.film.NoiseEstimate` (with `suspect`, the pixels the warning is about, and
      `error_high`, each pixel's 95% upper bound); `noise_map`: each pixel's standard error (height, width);
      `counts`: each pixel's samples (height, width), fewer than `samples` where adaptive sampling stopped it;
      `stats`: the render's `RenderStats` (seconds, rays, stop reason, kernel).
    - `passes`: the render passes asked for with `rt.render(passes=...)`, name -> float32 array
      (rt/passes.py, docs/passes.md): "albedo" and "normal" (height, width, 3), "depth",
      "samples" and "error" (height, width); empty if none was asked for.
    - `denoised`: with `rt.render(..., denoise=True)`, Open Image Denoise's version of `array`
      (height, width, 3) float32, guided by the albedo and normal passes (rt/denoise.py,
      rt/denoised_files.py; its error is measured in docs/accuracy.md); else None.
    - `save(path)`: .png (8-bit, made with the display transform `display`), .pfm or .exr (linear
      float32), as `rt render`.
    - `display`: the PNG's display transform (renderer/display.py: gamma2, the books' and the
      default, srgb, agx or aces): `rt.render(display=)`, else the scene's `image.display`.
    - A notebook shows it (`_repr_png_`); `numpy.asarray(image)` is `array`.
    """

    def __init__(self, film: "Film", stats: "RenderStats", name: str = "", integrator: str = "mis",
                 passes: Optional[dict] = None, display: str = "gamma2"):
        self.film = film
        self.stats = stats
        self.name = name
        self.display = display
        self.integrator = integrator
        self.passes: dict = dict(passes or {})
        self._array: Optional["np.ndarray"] = None
        self._estimate: Optional["NoiseEstimate"] = None
        self.denoised: Optional["np.ndarray"] = None  # rt.render(..., denoise=True) sets it

    @property
    def array(self) -> "np.ndarray":
        if self._array is None:
            import numpy as np

            self._array = self.film.mean().astype(np.float32)
            self._array.flags.writeable = False
        return self._array

    def __array__(self, dtype=None, copy=None):
        import numpy as np

        return np.array(self.array, dtype=dtype, copy=True)

    @property
    def counts(self) -> "np.ndarray":
        """Each pixel's sample count (height, width), int64: all `samples` unless adaptive
        sampling stopped some pixels early."""
        return self.film.counts

    @property
    def width(self) -> int:
        return self.film.width

    @property
    def height(self) -> int:
        return self.film.height

    @property
    def samples(self) -> int:
        return self.film.samples

    @property
    def noise_estimate(self) -> "NoiseEstimate":
        if self._estimate is None:
            from renderer.film import estimate_noise

            self._estimate = estimate_noise(self.film)
        return self._estimate

    @property
    def noise(self) -> float:
        return self.noise_estimate.relative_rms

    @property
    def noise_interval(self) -> tuple[float, float]:
        estimate = self.noise_estimate
        return estimate.low, estimate.high

    @property
    def noise_warning(self) -> Optional[str]:
        """The estimate's own warning, else the render's (the error fell more slowly than samples were added)."""
        if self.film.samples < 2:
            return None
        return self.noise_estimate.warning or getattr(self.stats, "noise_warning", None)

    @property
    def noise_map(self) -> "np.ndarray":
        return self.noise_estimate.error

    def save(self, path: Union[str, Path], exposure: Optional[float] = None, display: Optional[str] = None) -> Path:
        """Write the image by the file's suffix: .png (exposure in stops scales it first, then the
        display transform `display`, by default the image's own, makes its 8-bit values; the PNG's
        metadata names it), .pfm or .exr (linear, unchanged). Written atomically; returns the path."""
        from renderer.film import write_image

        path = Path(path)
        image = self.film.mean()
        display = self._display(display)
        if exposure or display != self.display:
            from .outputs import format_of

            found = format_of(path)
            if found is None or found.role != "image":
                what = "exposure" if exposure else "display"
                raise ValueError(f"{what} applies to a PNG only; .pfm and .exr keep the rendered radiance")
        if exposure:
            image = image * 2.0 ** exposure
        write_image(path, image, display, {"rt:exposure": f"{exposure:g}"} if exposure else None)
        return path

    def png_bytes(self, exposure: Optional[float] = None, display: Optional[str] = None) -> bytes:
        """The 8-bit PNG `save` would write, as bytes."""
        from renderer.film import png_bytes

        image = self.film.mean()
        display = self._display(display)
        if exposure:
            image = image * 2.0 ** exposure
        return png_bytes(image, display, {"rt:exposure": f"{exposure:g}"} if exposure else None)

    def _display(self, display: Optional[str]) -> str:
        """`display`, checked (ValueError in one sentence for an unknown name), or the image's own."""
        if display is None:
            return self.display
        from renderer.display import DISPLAYS, unknown_display

        if display not in DISPLAYS:
            raise ValueError(unknown_display(display))
        return display

    def _repr_png_(self) -> bytes:
        return self.png_bytes()

    def __repr__(self) -> str:
        noise = f"noise {100 * self.noise:.2f}%" if math.isfinite(self.noise) else "noise not estimated"
        name = f" {self.name}" if self.name else ""
        return f"<rt.Image{name} {self.width}x{self.height}, {self.samples} spp ({self.integrator}), {noise}>"


def _seconds(time: Union[None, float, int, str]) -> Optional[float]:
    if time is None:
        return None
    if isinstance(time, str):
        from .rendering import parse_duration

        seconds = parse_duration(time)
        if seconds is None:
            raise ValueError(f"time={time!r}: expected seconds or a duration such as 30s, 2m, 1h30m")
        return seconds
    if not (isinstance(time, (int, float)) and math.isfinite(time) and time > 0):
        raise ValueError(f"time={time!r}: expected a positive number of seconds")
    return float(time)


def _check_int(name: str, value: Optional[int], low: int, high: int) -> None:
    if value is not None and (isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high):
        raise ValueError(f"{name}={value!r}: expected a whole number from {low} to {high}")


# The scenes `rt.render` keeps prepared (loaded, checked and flattened) for its next calls: a second
# render of an unchanged scene skips the load and the flattening, most of a large scene's time.
# A scene file's entry lasts while every file its load read (the scene, its includes, textures,
# meshes) keeps its device, inode, size and modification time; a dict's or a model's is keyed by
# its content. At most PREPARED_SCENES entries and PREPARED_BYTES of tables are kept.
PREPARED_SCENES = 2
PREPARED_BYTES = 1 << 30


@dataclass
class _Prepared:
    files: tuple  # (path, file_identity(path)) of every file the load read
    loaded: "LoadedScene"
    graph: Any
    flat: Any
    reads: list  # the paths, for a cluster's workers
    nbytes: int  # of the flat tables


_prepared: "OrderedDict[tuple, _Prepared]" = OrderedDict()
_prepared_lock = threading.Lock()


def _data_key(data: Any) -> Optional[str]:
    """A hash of a dict's or a model's data; None if it is not plain data (then it is not kept).

    Pickled rather than written as JSON: the bytes are exactly the data, so 1 and 1.0, or the key
    1 and the key "1", which JSON writes alike and a scene may not accept alike, stay apart."""
    import hashlib
    import pickle

    try:
        return hashlib.sha256(pickle.dumps(data, protocol=4)).hexdigest()
    except (pickle.PicklingError, TypeError, AttributeError, ValueError, RecursionError):
        return None


def _cached(key: Optional[tuple]) -> Optional[_Prepared]:
    """The prepared scene under `key` if none of the files it read has changed since."""
    if key is None:
        return None
    with _prepared_lock:
        entry = _prepared.get(key)
    if entry is None:
        return None
    if any(file_identity(path) != seen for path, seen in entry.files):
        with _prepared_lock:
            if _prepared.get(key) is entry:
                del _prepared[key]
        return None
    with _prepared_lock:
        if key in _prepared:
            _prepared.move_to_end(key)
    return entry


def _keep(key: tuple, entry: _Prepared) -> None:
    with _prepared_lock:
        _prepared[key] = entry
        _prepared.move_to_end(key)
        while _prepared and (len(_prepared) > PREPARED_SCENES or sum(e.nbytes for e in _prepared.values()) > PREPARED_BYTES):
            _prepared.popitem(last=False)  # the least recently used first (this one last, if it alone is too big)


def forget_prepared_scenes() -> None:
    """Drop the scenes `rt.render` keeps prepared (to free their memory at once)."""
    with _prepared_lock:
        _prepared.clear()


def _prepare(scene: SceneLike, overrides: tuple, width: Optional[int], integrator: Optional[str],
             allow_paths: tuple = ()) -> _Prepared:
    """The scene loaded, checked and flattened with these options: kept from an earlier call when
    its source is unchanged (see PREPARED_SCENES), else prepared now and kept."""
    import numpy as np

    from scenefmt.files import recording_reads
    from scenefmt.validation import LoadedScene

    from renderer.session import flatten_loaded

    data = key = None
    if isinstance(scene, (str, Path)):
        key = ("file", os.path.abspath(scene))
    elif not isinstance(scene, LoadedScene):  # a loaded scene may have been changed in place: never kept
        data = _scene_data(scene)
        digest = _data_key(data)
        # Relative file names in the data resolve from the current folder.
        key = ("data", digest, os.getcwd()) if digest is not None else None
    if key is not None:  # the folders a scene may read decide whether it loads: they are part of the key
        key += (overrides, width, integrator, tuple(os.path.realpath(p) for p in allow_paths))
    entry = _cached(key)
    if entry is not None:
        return entry
    with recording_reads() as reads:  # the files a cluster's workers need, and those the entry depends on
        loaded = load(scene, overrides, allow_paths=allow_paths) if data is None else _load_data(data, overrides, allow_paths)
        graph, flat = flatten_loaded(loaded, width, integrator)
    files = tuple((path, file_identity(path)) for path in dict.fromkeys(reads))
    nbytes = sum(a.nbytes for a in flat if isinstance(a, np.ndarray))
    entry = _Prepared(files, loaded, graph, flat, list(reads), nbytes)
    if key is not None:
        _keep(key, entry)
    return entry


def render(
    scene: SceneLike,
    *,
    spp: Optional[int] = None,
    width: Optional[int] = None,
    seed: Optional[int] = None,
    time: Union[None, float, str] = None,
    noise: Optional[float] = None,
    adaptive: bool = True,
    integrator: Optional[str] = None,
    sampler: Optional[str] = None,
    max_depth: Optional[int] = None,
    threads: Optional[int] = None,
    overrides: Iterable[str] = (),
    kernel: str = "auto",
    progress: Union[bool, Callable[["RenderStats"], None]] = False,
    should_stop: Optional[Callable[[], bool]] = None,
    cluster: Any = None,
    allow_paths: Iterable[Union[str, Path]] = (),
    denoise: bool = False,
    passes: Iterable[str] = (),
    display: Optional[str] = None,
) -> Image:
    """Render a scene and return its `Image`; the options are those of `rt render`.

    `scene`: a file name, a `scenefmt` `Scene`, a dict of a scene's data, or `rt.load`'s result.
    `spp`, `width`, `seed`, `max_depth`, `integrator` ("mis", "path" or "guided"), `sampler`
    ("independent" or "sobol") override the file's values; `time` (seconds, or "30s", "2m") and `noise` (relative RMS, 0.02 = 2%) are budgets,
    with `spp` then the cap; with `noise`, `adaptive` (the default) spends samples where the
    noise is (`Image.counts` says how many each pixel took), `adaptive=False` gives every pixel
    every sample; `overrides` are `--set` arguments; `progress=True` shows the
    progress bar on standard error (or pass a function of `RenderStats`); `should_stop` is polled
    between passes and ends the render early with what is rendered; `allow_paths`: folders besides
    the scene file's own (the current folder for a dict) that the files it names may be read from.

    `passes`: render passes to return in `Image.passes` (docs/passes.md), any of "albedo",
    "normal", "depth" (traced after the render by camera rays of their own: the image is the
    same with or without them; Intel Open Image Denoise's definitions), "samples" (each pixel's
    count) and "error" (each pixel's standard error); a list or "albedo,normal".

    `cluster`: render on a Dask cluster (docs/cluster.md): a `dask.distributed.Client`, a
    scheduler address ("tcp://host:8786") or "local"; the image is the same, bit for bit.
    A Client is used as is and left open; a cluster started for "local" is closed at the end.

    `display`: the display transform the image's PNG is made with (`Image.display`; "gamma2",
    "srgb", "agx" or "aces"), overriding the scene's `image.display`; the radiance is not changed.

    `denoise=True`: also denoise the image with Intel Open Image Denoise (`Image.denoised`, beside
    the raw `Image.array`); needs the denoise extra, whose absence raises `rt.denoise.DenoiserMissing`
    (an ImportError) before anything renders; a failure of the filter raises `rt.denoise.DenoiseError`.

    Raises `rt.SceneError` (with `.diagnostics`) for an invalid scene and ValueError for an
    invalid option or a scene the renderer cannot use (an image that does not decode).
    """
    import sys

    from .rendering import limit_blas_threads

    limit_blas_threads()  # before numpy loads, if it has not yet
    from renderer.flat import Frame, integrator_choices
    from renderer.variants import KERNEL_CHOICES, features_of

    from .progress import Progress
    from .rendering import max_threads, option_problem, render_scene, sample_target, sampler_override

    _check_int("spp", spp, 1, 1_000_000)
    _check_int("width", width, 1, 32768)
    _check_int("max_depth", max_depth, 1, 10_000)
    _check_int("seed", seed, 0, 2**63 - 1)
    _check_int("threads", threads, 1, 1 << 16)
    problem = option_problem(kernel, integrator, threads)
    if problem == "integrator":
        raise ValueError(f"integrator={integrator!r}: expected {integrator_choices(quote=True)}")
    if problem == "kernel":
        raise ValueError(f"kernel={kernel!r}: expected one of {', '.join(KERNEL_CHOICES)}")
    if problem == "threads":
        raise ValueError(f"threads={threads}: at most {max_threads()} threads are available")
    if noise is not None and not (isinstance(noise, (int, float)) and math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise={noise!r}: expected a relative noise such as 0.02")
    budget = _seconds(time)
    if display is not None:
        from renderer.display import DISPLAYS, unknown_display

        if display not in DISPLAYS:
            raise ValueError(unknown_display(display))
    if denoise:  # before rendering: a render spent for a denoise that cannot run is time lost
        from .denoise import check_available

        check_available()
    from .passes import parse_passes

    wanted_passes = parse_passes(passes)  # ValueError for an unknown name, before any rendering

    overrides = tuple(overrides) + sampler_override(sampler)
    prepared = _prepare(scene, overrides, width, integrator, tuple(allow_paths))
    loaded, graph, flat, reads = prepared.loaded, prepared.graph, prepared.flat, prepared.reads
    frame = Frame.of(graph)
    target = sample_target(spp, frame, budget is not None or noise is not None)
    connection = package = None
    if cluster is not None:  # raises rt.cluster.ClusterError (a RuntimeError) with a sentence
        from .cluster import connect, package_scene

        is_file = isinstance(scene, (str, Path)) and str(scene) != "-"
        package = package_scene(str(scene) if is_file else None, reads, loaded, flat, overrides, None, width, integrator)
        connection = connect(cluster)
    bar = Progress(target, budget, noise) if progress is True else None

    def notify(message: str) -> None:
        if bar is not None:
            bar.notify(message)
        else:
            sys.stderr.write(message + "\n")

    try:
        result = render_scene(
            flat, frame, features_of(graph), target=target, kernel=kernel, threads=threads, connection=connection,
            package=package, progress=bar if bar is not None else (progress or None), max_depth=max_depth, seed=seed,
            should_stop=should_stop, time_budget=budget, noise_target=noise, notify=notify, adaptive=adaptive,
        )
    finally:
        if connection is not None:
            connection.close()
    name = Path(str(scene)).stem if isinstance(scene, (str, Path)) else ""
    computed = None
    if wanted_passes:
        from .passes import compute_passes

        computed = compute_passes(wanted_passes, flat, result.film, seed=seed if seed is not None else frame.seed,
                                  notify=notify)
    image = Image(result.film, result.stats, name, frame.integrator, computed,
                  display if display is not None else graph.image.display)
    if denoise:  # guided by the albedo and normal passes: the image's own where asked for (passes=), else rendered
        from .denoised_files import guided_denoise

        image.denoised, _ = guided_denoise(image.array, flat, image.passes)
        image.denoised.flags.writeable = False
    return image

