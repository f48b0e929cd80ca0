"""Render a scene in this process: the render session (session.py) with the local executor.

`render` takes a scene graph, `render_flat` its flat tables; both render in progressive passes
into a Film (local_passes.LocalPasses: passes of about a quarter of a second, a long pass in bands
of rows, a stop honoured between bands) and return a RenderResult. Because the random numbers
are keyed by (seed, pixel, sample, dimension), neither the passes' nor the bands' split changes
the image.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Optional

from .film import Film
from .flat import FlatScene, Frame
from .local_passes import PASS_SECONDS, Bands, LocalPasses
from .rare_paths import rare_path_prior
from .session import RenderResult, RenderStats, render_progressively
from .variants import GENERAL, KernelFeatures, features_of

if TYPE_CHECKING:
    from scenefmt.graph import SceneGraph

__all__ = ["render", "render_flat", "RenderResult", "RenderStats", "Bands", "PASS_SECONDS"]


def render(graph: SceneGraph, *, flat: Optional[FlatScene] = None, **options) -> RenderResult:
    """Render `graph` (its image settings, unless overridden) until `samples` per pixel are done.

    `flat` is the graph already flattened (compile.compile_scene); `options` are those of
    `render_flat` (samples, max_depth, seed, film, progress, should_stop, pass_seconds,
    time_budget, noise_target, features).
    """
    if flat is None:
        from .compile import compile_scene

        flat = compile_scene(graph)
    return render_flat(flat, Frame.of(graph), needed=features_of(graph), **options)


def render_flat(
    flat: FlatScene,
    frame: Frame,
    *,
    samples: Optional[int] = None,
    max_depth: Optional[int] = None,
    seed: Optional[int] = None,
    film: Optional[Film] = None,
    progress: Optional[Callable[[RenderStats], None]] = None,
    should_stop: Optional[Callable[[], bool]] = None,
    pass_seconds: float = PASS_SECONDS,
    time_budget: Optional[float] = None,
    noise_target: Optional[float] = None,
    needed: KernelFeatures = GENERAL,
    features: Optional[KernelFeatures] = None,
    kernel: str = "auto",
    notify: Optional[Callable[[str], None]] = None,
    adaptive: bool = False,
) -> RenderResult:
    """Render the flat scene `flat` with the settings of `frame` (unless overridden) until
    `samples` per pixel are done, in this process.

    `film` continues an earlier render with the same seed; `should_stop`, `time_budget`,
    `noise_target`, `progress`, `notify`, and the kernel's choice (`needed`, `kernel`,
    `features`) and `adaptive` are those of `session.render_progressively`. `pass_seconds` is about how long a
    pass, and a band of a pass, should take.
    """
    executor = LocalPasses.for_frame(flat, frame, seed=seed, max_depth=max_depth, pass_seconds=pass_seconds)
    if film is None:
        film = Film.empty(frame.width, frame.height)
    target = samples if samples is not None else frame.samples
    return render_progressively(executor, film, target=target, needed=needed, kernel=kernel, features=features,
                                progress=progress, should_stop=should_stop, time_budget=time_budget,
                                noise_target=noise_target, notify=notify, adaptive=adaptive, prior=rare_path_prior(flat))
