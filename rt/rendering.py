"""The render steps every front end shares: option rules, the sample target, and `render_scene`.

`rt render` (render_job.py), `rt.render` (api.py) and the cluster go from options to an image
through these and through the render session (renderer/session.py: flattening, the kernel's
choice, the progressive loop); each front end only loads the scene its own way and presents
the result. Nothing heavy is imported at module level.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Optional

if TYPE_CHECKING:
    from renderer.flat import FlatScene, Frame
    from renderer.variants import KernelFeatures

BUDGET_SAMPLE_CAP = 1_000_000

# numpy's BLAS threads spin after a call; on a 2-core machine they would take a core from the
# renderer's own threads. The renderer does no heavy linear algebra, so one BLAS thread suffices.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")


def limit_blas_threads() -> None:
    """Ask for one BLAS thread, unless the environment says otherwise. It takes effect only if
    numpy is not loaded yet: the command line calls it first thing (rt/__main__.py), rt.render
    when a render starts. `import rt` itself changes nothing in the process."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


def parse_duration(text: str) -> Optional[float]:
    """Seconds in '45', '30s', '2m', '1h30m', '1.5h'; None if it is not a duration."""
    import re

    text = text.strip().lower()
    if re.fullmatch(r"\d+(\.\d+)?", text):
        return float(text)
    parts = re.findall(r"(\d+(?:\.\d+)?)([hms])", text)
    if not parts or "".join(n + u for n, u in parts) != text:
        return None
    return sum(float(n) * {"h": 3600, "m": 60, "s": 1}[u] for n, u in parts)


def max_threads() -> int:
    """The most render threads this process can run."""
    from renderer import target

    return target.max_thread_count()


def option_problem(kernel: str, integrator: Optional[str], threads: Optional[int]) -> Optional[str]:
    """The first of a render's options whose value cannot be used: "kernel" (not one of
    KERNEL_CHOICES), "integrator" (not one of flat.INTEGRATORS) or "threads" (more than
    `max_threads`); None when every one can. `rt render` and rt.render check these rules here
    and word the error each their own way."""
    from renderer.flat import INTEGRATORS
    from renderer.variants import KERNEL_CHOICES

    if kernel not in KERNEL_CHOICES:
        return "kernel"
    if integrator is not None and integrator not in INTEGRATORS:
        return "integrator"
    if threads is not None and threads > max_threads():
        return "threads"
    return None


def sampler_override(sampler: Optional[str]) -> tuple[str, ...]:
    """`--sampler NAME` (and rt.render's `sampler=`) as the `--set` it stands for: the scene's
    validation checks the name, and the sampler travels with the scene to a cluster's workers."""
    return () if sampler is None else (f"image.sampler={sampler}",)


def sample_target(spp: Optional[int], frame: Frame, budgeted: bool) -> int:
    """The samples per pixel to render: `spp`, else the scene's; with a time or noise budget
    (`budgeted`) the count is only a cap, BUDGET_SAMPLE_CAP unless `spp` says."""
    if spp is not None:
        return spp
    return BUDGET_SAMPLE_CAP if budgeted else frame.samples


def render_scene(flat: FlatScene, frame: Frame, features: KernelFeatures, *, target: int, kernel: str = "auto",
                 threads: Optional[int] = None, connection=None, package=None, progress=None, max_depth: Optional[int] = None,
                 seed: Optional[int] = None, film=None, **options):
    """Render a flattened scene: on the cluster of `connection` (rt.cluster.Connection, with the
    scene's `package`) if one is given, else in this process. The one way `rt render` and
    rt.render render: the render session (renderer/session.py) with the cluster's executor or
    the local one; a RenderResult.

    `features`: the kernel paths the scene needs (variants.features_of); `kernel`: one of
    KERNEL_CHOICES; `target`: samples per pixel (`sample_target`); `threads` (checked by
    `option_problem`): Numba's threads for this render only; `max_depth`, `seed` override the
    scene's; `film` continues a resumed render. A `Progress` given as `progress` draws its final
    figures and is closed. `options` are the session's: should_stop, time_budget, noise_target, notify.
    """
    from renderer import target as kernel_target
    from renderer.film import Film
    from renderer.local_passes import LocalPasses
    from renderer.rare_paths import rare_path_prior
    from renderer.session import render_progressively

    from .progress import Progress

    before = kernel_target.thread_count()
    try:
        if threads is not None:
            kernel_target.set_thread_count(threads)
        if connection is not None:
            from .cluster import cluster_executor

            executor = cluster_executor(connection, package, flat, frame, seed=seed, max_depth=max_depth)
        else:
            executor = LocalPasses.for_frame(flat, frame, seed=seed, max_depth=max_depth)
        if film is None:
            film = Film.empty(frame.width, frame.height)
        result = render_progressively(executor, film, target=target, needed=features, kernel=kernel, progress=progress,
                                      prior=rare_path_prior(flat),
                                      **options)
        if isinstance(progress, Progress):
            progress.finish(result.stats)
        return result
    finally:
        kernel_target.set_thread_count(before)
        if isinstance(progress, Progress):
            progress.close()
