"""The optional denoiser: Intel Open Image Denoise (OIDN) through its Python bindings, `pyoidn`.

`denoise(color, albedo=None, normal=None)` takes a render's linear radiance (what `--hdr` writes)
and returns OIDN's estimate of the converged image, (height, width, 3) float32 and finite. It uses
OIDN's "RT" filter for path-traced images with `hdr` on (our radiance is unbounded: a lamp is 15,
a wall 0.5), and the albedo and normal passes as its auxiliary images when given (OIDN expects the
albedo of the first surface a camera ray meets, in [0, 1], and its shading normal, in [-1, 1]).

A denoiser does not estimate the image: it guesses it, and its guess is biased (it blurs what it
takes for noise). What that costs and buys in error is measured by benchmarks/denoise_error.py
(docs/accuracy.md, "Denoising"); the raw render is always kept beside the denoised one.

pyoidn is an optional dependency (`pip install '.[denoise]'` in rt's folder). Nothing here imports
it until a denoise is asked for, so `import rt` and `rt validate` never load it. Its absence is
`DenoiserMissing` (an ImportError), any failure of the filter `DenoiseError`; each says what
happened in one sentence, which the command line prints as is.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

# What a user without pyoidn is told: the command line prints it after "error: ".
MISSING = "--denoise needs Open Image Denoise: pip install '.[denoise]' in rt's folder"


class DenoiserMissing(ImportError):
    """pyoidn cannot be imported; the message says how to install it."""


class DenoiseError(RuntimeError):
    """The denoiser refused its input or failed; the message is one sentence."""


def _pyoidn():
    """The pyoidn module, or DenoiserMissing. Any failure to load it counts as missing: a module
    blocked in sys.modules (None), a broken installation, a shared library that will not load."""
    try:
        import pyoidn
    except (ImportError, OSError) as exc:
        raise DenoiserMissing(MISSING) from exc
    return pyoidn


def check_available() -> None:
    """Raise DenoiserMissing unless the denoiser can be loaded: asked before rendering, so that a
    render is not spent on a denoise that cannot run."""
    _pyoidn()


def available() -> bool:
    """Whether the denoiser can be loaded here."""
    try:
        _pyoidn()
    except DenoiserMissing:
        return False
    return True


def _image(name: str, value, shape: Optional[tuple], low: float, high: float) -> np.ndarray:
    """`value` as a contiguous (height, width, 3) float32 array, clipped to [low, high], every value
    that is not finite replaced by 0 (OIDN gives NaN out for NaN in, and our pixels stay finite)."""
    array = np.asarray(value)
    if array.ndim != 3 or array.shape[2] != 3 or array.shape[0] < 1 or array.shape[1] < 1:
        raise DenoiseError(f"the {name} image must have the shape (height, width, 3), not {array.shape}")
    if shape is not None and array.shape != shape:
        raise DenoiseError(f"the {name} image is {array.shape[1]}x{array.shape[0]}, the colour image {shape[1]}x{shape[0]}")
    if not np.issubdtype(array.dtype, np.number) or np.issubdtype(array.dtype, np.complexfloating):
        raise DenoiseError(f"the {name} image must hold real numbers, not {array.dtype}")
    out = np.nan_to_num(array.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    return np.ascontiguousarray(np.clip(out, low, high))


def denoise(color, albedo=None, normal=None, *, clean_aux: bool = False) -> np.ndarray:
    """OIDN's denoised version of `color`, linear radiance (height, width, 3); returns a new
    (height, width, 3) float32 array, every value finite and at least 0.

    `albedo` (in [0, 1]) and `normal` (unit vectors, any space, 0 where a camera ray escapes) are
    the auxiliary passes of the same pixels; either may be left out, but a normal pass is used
    only with an albedo pass (OIDN's rule). `clean_aux`: the passes are noise-free, so OIDN need
    not filter them first (true of passes averaged over enough camera rays of a scene without
    defocus or motion blur; say False when unsure, the safe choice).

    Raises DenoiserMissing without pyoidn, DenoiseError if the images do not fit together or the
    filter fails."""
    pyoidn = _pyoidn()
    if normal is not None and albedo is None:
        raise DenoiseError("a normal pass is used only together with an albedo pass")
    rgb = _image("colour", color, None, 0.0, np.inf)
    # A float32 overflow (radiance above 3.4e38) became inf above and 0 here; clip far below it,
    # where OIDN's own arithmetic in half precision is still not reached: its autoexposure scales
    # the image by its mean luminance first.
    rgb = np.minimum(rgb, np.float32(1e30))
    aux = {}
    if albedo is not None:
        aux["albedo"] = _image("albedo", albedo, rgb.shape, 0.0, 1.0)
    if normal is not None:
        aux["normal"] = _image("normal", normal, rgb.shape, -1.0, 1.0)
    try:
        out = pyoidn.denoise(rgb, aux.get("albedo"), aux.get("normal"), hdr=True, clean_aux=bool(clean_aux and aux))
    except (RuntimeError, ValueError, TypeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DenoiseError(f"Open Image Denoise failed: {first}") from exc
    out = np.nan_to_num(np.asarray(out, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    return np.maximum(out, np.float32(0.0))


def denoised_path(path):
    """Where the denoised version of the image file `path` goes: beside it, `.denoised` before its
    suffix (out.png -> out.denoised.png, out.exr -> out.denoised.exr)."""
    from pathlib import Path

    path = Path(path)
    return path.with_name(f"{path.stem}.denoised{path.suffix}")
