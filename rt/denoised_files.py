"""`rt render --denoise`: the denoised images, written beside the raw ones once those are written.

The raw PNG (and --hdr image) is written first, by rt/outputs.py; then `write_denoised` renders
the albedo and normal passes (renderer/tracing/aux_passes.py, camera rays of their own: the raw
image is untouched), denoises the film's mean guided by them (`guided_denoise`, rt/denoise.py)
and writes `NAME.denoised.png` beside the PNG and, with --hdr, `HDRNAME.denoised.exr|pfm` beside
that, each atomically (renderer/film.py). The names were checked with the other outputs before
rendering (RenderOptions.denoised, outputs._outputs). A failure here ends the command with one
sentence that says the raw images are written.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:
    from renderer.film import Film

    from .render_job import RenderOptions


# Camera rays per pixel of the albedo and normal passes: their mean is noise-free enough for OIDN
# to read them as they are (64 did no better than 16 on the benchmark's three scenes at 4 to 64
# spp), and they cost a fraction of a render's first few samples (no light is sampled, no path
# followed past the first surface with a density).
PASS_SAMPLES = 16


@dataclass(frozen=True)
class Denoised:
    """What --denoise did: which passes guided it and how long each step took."""

    passes: tuple[str, ...]  # the auxiliary passes given to the denoiser ("albedo", "normal"), or none
    pass_seconds: float  # rendering them
    denoise_seconds: float  # the filter itself

    def sentence(self) -> str:
        guided = f"guided by the {' and '.join(self.passes)} passes ({self.pass_seconds:.2f} s)" if self.passes else "colour only"
        return f"Open Image Denoise, {guided}, {self.denoise_seconds:.2f} s"


def guided_denoise(image, flat, passes=None):
    """`image` (a render of `flat`, (height, width, 3)) denoised guided by its albedo and normal
    passes: those in `passes` (a dict, as rt.render(passes=...) gives them) where present, else
    rendered here (PASS_SAMPLES camera rays per pixel). The denoised image and a Denoised record.
    Raises rt.denoise's DenoiseError or DenoiserMissing."""
    from renderer.tracing.aux_passes import render_aux

    from .denoise import denoise

    height, width = image.shape[:2]
    started = time.perf_counter()
    if passes is None or "albedo" not in passes or "normal" not in passes:
        passes = render_aux(flat, width, height, samples=PASS_SAMPLES)
    pass_seconds = time.perf_counter() - started
    started = time.perf_counter()
    # Read as they are (cleanAux): on a 48-pixel Cornell box at 4 to 64 spp, OIDN's own prefilter of
    # these passes made the denoised error worse than the colour alone gave, and reading them as
    # they are made it better (benchmarks/denoise_error.py's first table).
    out = denoise(image, passes["albedo"], passes["normal"], clean_aux=True)
    return out, Denoised(("albedo", "normal"), pass_seconds, time.perf_counter() - started)


def write_denoised(opts: "RenderOptions", film: "Film", flat, fail: Callable[[str], Exception], passes=None,
                   display: str = "gamma2") -> Denoised:
    """Denoise `film`'s image (a render of `flat`) and write the files of `opts.denoised`; on a
    failure raise `fail(message)`, the raw images staying as written. `passes`: those --passes
    computed (their albedo and normal are reused), or None. The PNG is made with the display
    transform `display`, as the raw one (renderer/display.py)."""
    from renderer.film import write_image
    from scenefmt.files import describe_os_error

    from .denoise import DenoiseError, DenoiserMissing

    written = [str(p) for p in (opts.out, opts.hdr) if p is not None]
    raw = f"the raw image {written[0]} is written" if len(written) == 1 else f"the raw images {' and '.join(written)} are written"
    try:
        image, done = guided_denoise(film.mean(), flat, passes)
    except (DenoiseError, DenoiserMissing) as exc:
        raise fail(f"error: --denoise: {exc}; {raw}")
    except MemoryError:  # the passes' three images, or the filter's own buffers
        raise fail(f"error: --denoise: not enough memory for the denoiser at {film.width}x{film.height}; {raw}")
    exposed = image if not opts.exposure else image * 2.0 ** opts.exposure  # the PNG only, as the raw one
    shown = {"rt:exposure": f"{opts.exposure:g}"} if opts.exposure else None
    for path, linear in zip(opts.denoised, (exposed, image)):
        try:
            write_image(path, linear, display, shown)  # a linear file (beside --hdr) ignores both
        except (OSError, ValueError) as exc:
            reason = describe_os_error(exc) if isinstance(exc, OSError) else str(exc)
            raise fail(f"error: cannot write {path}: {reason}; {raw}")
    return done
