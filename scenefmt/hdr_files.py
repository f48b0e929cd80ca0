"""Linear float images on disk: OpenEXR (through the `openexr` package) and PFM.

`rt render --hdr` writes either; an image texture may be either (its values are linear RGB as
stored, so `colorspace` does not apply). Reading is bounded as every input is: a regular file,
at most `MAX_HDR_BYTES`, its size in pixels checked from the header before any pixel is
decoded, and its values checked (finite, not negative) before they are used.

OpenEXR is an optional dependency (`pip install 'rt-render[exr]'`): without it, PFM still works
and an .exr name gets an error saying what to install, before anything is rendered.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from .files import FileProblem, read_regular_file

HDR_SUFFIXES = (".exr", ".pfm")
# A float image of the largest allowed texture, uncompressed, with room for headers and tiles.
MAX_HDR_BYTES = 16384 * 16384 * 12 + (1 << 20)
EXR_MISSING = (
    "reading or writing OpenEXR (.exr) needs the openexr package, which is not installed: "
    "pip install 'rt-render[exr]' (or use .pfm)"
)


class HdrProblem(ValueError):
    """A float image cannot be read or written; the message says why, without the file name."""


def is_hdr(path) -> bool:
    return Path(path).suffix.lower() in HDR_SUFFIXES


def openexr_module():
    """The OpenEXR bindings, or HdrProblem(EXR_MISSING)."""
    try:
        import OpenEXR
    except ImportError:
        raise HdrProblem(EXR_MISSING) from None
    return OpenEXR


def exr_available() -> bool:
    try:
        openexr_module()
    except HdrProblem:
        return False
    return True


def _read(path, limit: int) -> bytes:
    try:
        return read_regular_file(path, limit)
    except FileProblem as exc:
        raise HdrProblem(str(exc)) from None


_PFM_HEADER = re.compile(rb"PF\s+(\d{1,9})\s+(\d{1,9})\s+(\S{1,40})\s")


def _pfm_header(raw: bytes) -> tuple[int, int, str, int]:
    """(width, height, dtype, offset of the pixels) of a colour PFM: 'PF', the size, the scale
    (negative: little-endian), one whitespace character, then float32 RGB rows bottom to top."""
    m = _PFM_HEADER.match(raw)
    if not m:
        raise HdrProblem("is not a colour PFM file (it must start with 'PF', the width, the height and the scale)")
    width, height = int(m.group(1)), int(m.group(2))
    try:
        scale = float(m.group(3))
    except ValueError:
        raise HdrProblem("has a malformed PFM header (the scale is not a number)") from None
    if width < 1 or height < 1 or not np.isfinite(scale) or scale == 0:
        raise HdrProblem("has a malformed PFM header (size or scale)")
    return width, height, "<f4" if scale < 0 else ">f4", m.end()


def _exr_file(raw: bytes, header_only: bool):
    OpenEXR = openexr_module()
    try:
        return OpenEXR.File(io.BytesIO(raw), separate_channels=False, header_only=header_only)
    except (RuntimeError, ValueError, TypeError) as exc:
        raise HdrProblem(f"is not a readable OpenEXR image (the OpenEXR library refused it: {type(exc).__name__})") from None


def _exr_size(exr) -> tuple[int, int]:
    lo, hi = exr.header()["dataWindow"]
    return int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)


def hdr_size(path) -> tuple[int, int]:
    """(width, height) from the header of an .exr or .pfm file."""
    raw = _read(path, MAX_HDR_BYTES)
    if Path(path).suffix.lower() == ".pfm":
        return _pfm_header(raw[:256])[:2]
    return _exr_size(_exr_file(raw, header_only=True))


def read_hdr(path, max_pixels: int) -> np.ndarray:
    """The linear RGB image (h, w, 3) float32 of an .exr or .pfm file, row 0 at the top.

    The size is checked against `max_pixels` from the header before decoding; values must be
    finite and not negative."""
    raw = _read(path, MAX_HDR_BYTES)
    if Path(path).suffix.lower() == ".pfm":
        width, height, dtype, offset = _pfm_header(raw[:256])
        if width * height > max_pixels:
            raise HdrProblem(f"is {width} x {height} pixels, more than the {max_pixels:,} allowed")
        if len(raw) - offset < width * height * 12:
            raise HdrProblem(f"is shorter than its header says ({width} x {height} colour pixels)")
        data = np.frombuffer(raw, dtype=dtype, count=width * height * 3, offset=offset)
        image = data.reshape(height, width, 3)[::-1].astype(np.float32)
    else:
        width, height = _exr_size(_exr_file(raw, header_only=True))
        if width * height > max_pixels:
            raise HdrProblem(f"is {width} x {height} pixels, more than the {max_pixels:,} allowed")
        channels = _exr_file(raw, header_only=False).channels()
        if "RGB" in channels:
            image = channels["RGB"].pixels
        elif "RGBA" in channels:
            image = channels["RGBA"].pixels[..., :3]
        elif "Y" in channels:  # a grey image
            image = np.repeat(channels["Y"].pixels[..., None], 3, axis=2)
        else:
            raise HdrProblem(f"has no R, G and B channels (it has {', '.join(sorted(channels)) or 'none'})")
        image = np.ascontiguousarray(image, dtype=np.float32)
        if image.shape != (height, width, 3):
            raise HdrProblem(f"has pixels of shape {image.shape}, not {height} x {width} RGB")
    if not np.isfinite(image).all():
        raise HdrProblem("holds values that are not finite (inf or NaN)")
    if (image < 0).any():
        raise HdrProblem(f"holds negative values (the least is {float(image.min()):g}); colours must be >= 0")
    return np.ascontiguousarray(image)


def exr_bytes(linear: np.ndarray) -> bytes:
    """An OpenEXR file (float32 RGB, ZIP-compressed scanlines) of the linear image (h, w, 3)."""
    OpenEXR = openexr_module()
    if linear.ndim != 3 or linear.shape[2] != 3:
        raise HdrProblem(f"expected an (height, width, 3) image, found shape {linear.shape}")
    pixels = np.ascontiguousarray(linear, dtype=np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    out = io.BytesIO()
    OpenEXR.File(header, {"RGB": pixels}).write(out)
    return out.getvalue()
