"""`rt render --denoise`: the denoised images, written beside the raw ones once those are written.

The raw PNG (and --hdr image) is written first, by rt/outputs.py; then `write_denoised` denoises
the film's mean (rt/denoise.py) and writes `NAME.denoised.png` beside the PNG and, with --hdr,
`HDRNAME.denoised.exr|pfm` beside that, each atomically (renderer/film.py). The names were
checked with the other outputs before rendering (RenderOptions.denoised, outputs._outputs). A
failure here ends the command with one sentence that says the raw images are written.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:
    from renderer.film import Film

    from .render_job import RenderOptions


@dataclass(frozen=True)
class Denoised:
    """What --denoise did: which passes guided it and how long each step took."""

    passes: tuple[str, ...]  # the auxiliary passes given to the denoiser ("albedo", "normal"), or none
    pass_seconds: float  # rendering them
    denoise_seconds: float  # the filter itself

    def sentence(self) -> str:
        guided = f"guided by the {' and '.join(self.passes)} passes ({self.pass_seconds:.2f} s)" if self.passes else "colour only"
        return f"Open Image Denoise, {guided}, {self.denoise_seconds:.2f} s"


def write_denoised(opts: "RenderOptions", film: "Film", flat, fail: Callable[[str], Exception]) -> Denoised:
    """Denoise `film`'s image and write the files of `opts.denoised`; on a failure raise
    `fail(message)`, the raw images staying as written."""
    from renderer.film import write_image
    from scenefmt.files import describe_os_error

    from .denoise import DenoiseError, DenoiserMissing, denoise

    written = [str(p) for p in (opts.out, opts.hdr) if p is not None]
    raw = f"the raw image {written[0]} is written" if len(written) == 1 else f"the raw images {' and '.join(written)} are written"
    started = time.perf_counter()
    try:
        image = denoise(film.mean())
    except (DenoiseError, DenoiserMissing) as exc:
        raise fail(f"error: --denoise: {exc}; {raw}")
    seconds = time.perf_counter() - started
    exposed = image if not opts.exposure else image * 2.0 ** opts.exposure  # the PNG only, as the raw one
    for path, linear in zip(opts.denoised, (exposed, image)):
        try:
            write_image(path, linear)
        except (OSError, ValueError) as exc:
            reason = describe_os_error(exc) if isinstance(exc, OSError) else str(exc)
            raise fail(f"error: cannot write {path}: {reason}; {raw}")
    return Denoised((), 0.0, seconds)
