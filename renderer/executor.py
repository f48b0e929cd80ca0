"""The executor protocol: what runs a render session's samples (renderer/session.py).

The session owns the progressive loop (budgets, stop reasons, noise target, progress, the kernel
switch, resume); an executor only turns requests for samples into sums in the film. Every
executor keeps one protocol, so the loop does not know where the samples are computed:

- `start(film, features, notify) -> KernelTime`: get ready to render into `film` (which may hold
  a resumed render) with the kernel of `features`: compile or load it, reach the workers. Time
  spent here is not rendering time; the session starts its clock after it.
- `advance(plan, should_stop) -> Optional[Step]`: add samples to the film and return what was
  added: the film's sums and `film.samples` now hold a whole number of samples per pixel
  (`Step.samples` more, maybe 0 when an asynchronous executor had nothing finished yet).
  `plan` (a `Plan`) says how many samples are still wanted and how much time is left; the
  executor decides how many it adds. None: `should_stop` asked to stop during the step, and
  the film is as it was before it. An executor that cannot go on raises `ExecutorFailed`; the
  session fills in the result so far (`partial`) and lets it through.
- `prepare(notify)` (optional): work the render needs before its first sample, counted as
  rendering time: a guided render's training (guide_training.py); returns what it cost, or None.
- `switch_kernel(features, notify) -> KernelTime`: from the next step on, render with the kernel
  of `features` (only asked of executors whose `can_switch_kernel` is true).
- `close()`: stop whatever still runs (always called, after the last step or a failure).
- `stops_on_time_before_first_step`: whether a spent time budget may end the render before
  any step of this render has finished (False keeps waiting for one).

Two executors exist: `local_passes.LocalPasses` (passes over the whole image in this process, in bands
of rows) and `rt.cluster.ClusterRounds` (rounds of tiles on a Dask cluster). A GPU executor
would launch its passes in `advance` and copy the sums back into the film the same way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Protocol


class ExecutorFailed(RuntimeError):
    """An executor cannot go on; the message is a sentence to show. `partial`: the RenderResult
    of the samples the film held when it failed (set by the session for a failure during the
    render; None for one before any sample was asked for)."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


@dataclass(frozen=True)
class KernelTime:
    """Seconds spent getting a kernel ready, and the part of them spent compiling it."""

    seconds: float = 0.0
    compiling: float = 0.0


@dataclass(frozen=True)
class Plan:
    """What the session still wants when it asks for a step."""

    target: int  # samples per pixel in all
    start: int  # samples per pixel the film held when this render started (a resume)
    steps: int  # steps finished so far in this render
    seconds: float  # rendering seconds so far
    time_left: Optional[Callable[[], float]]  # seconds of the time budget left, now; None without a budget


@dataclass(frozen=True)
class Step:
    """What one step added to the film."""

    samples: int  # samples per pixel
    rays: int
    bad_samples: int  # samples that were not finite, dropped
    seconds: float  # how long the step's own rendering took




class Executor(Protocol):
    """What the session asks of an executor (see the module's docstring)."""

    can_switch_kernel: bool
    stops_on_time_before_first_step: bool

    def start(self, film, features, notify: Optional[Callable[[str], None]] = None) -> KernelTime: ...

    def advance(self, plan: Plan, should_stop: Optional[Callable[[], bool]] = None) -> Optional[Step]: ...

    def switch_kernel(self, features, notify: Optional[Callable[[str], None]] = None) -> KernelTime: ...

    def close(self) -> None: ...
