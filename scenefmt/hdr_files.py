"""Linear float images on disk: OpenEXR (through the `openexr` package) and PFM.

`rt render --hdr` writes either; an image texture may be either (its values are linear RGB as
stored, so `colorspace` does not apply). Reading is bounded as every input is: a regular file,
at most `MAX_HDR_BYTES`, its size in pixels checked from the header before any pixel is
decoded, and its values checked (finite, not negative) before they are used.

OpenEXR is an optional dependency (the `exr` extra: `pip install '.[exr]'` in rt's folder): without it, PFM still works
and an .exr name gets an error saying what to install, before anything is rendered.
"""

from __future__ import annotations

import io
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from .files import FileProblem, open_regular_file, read_regular_file

HDR_SUFFIXES = (".exr", ".pfm")
# A float image of the largest allowed texture, uncompressed, with room for headers and tiles.
MAX_HDR_BYTES = 16384 * 16384 * 12 + (1 << 20)
EXR_MISSING = (
    "reading or writing OpenEXR (.exr) needs the openexr package, which is not installed: "
    "pip install '.[exr]' in rt's folder, or pip install openexr (or use .pfm)"
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


@dataclass(frozen=True)
class HdrHeader:
    """What a float image's header says, read without decoding a pixel."""

    width: int
    height: int
    channels: int  # stored channels (an EXR may hold alpha and others beside R, G, B)
    file_bytes: int

    @property
    def decode_bytes(self) -> int:
        """The most memory decoding it takes: every channel at 4 bytes (EXR's float or uint; half
        is 2), and the float32 RGB made of them (PFM: its pixels as read, and their copy)."""
        return self.width * self.height * (4 * self.channels + 12)


def _open(path):
    try:
        return open_regular_file(path)
    except FileProblem as exc:
        raise HdrProblem(str(exc)) from None


def hdr_header(path) -> HdrHeader:
    """The header of an .exr or .pfm file: its size and channels. Reads a few KiB, never the pixels."""
    with _open(path) as fh:
        size = os.fstat(fh.fileno()).st_size
        if size > MAX_HDR_BYTES:
            raise HdrProblem(f"is larger than the {MAX_HDR_BYTES:,} bytes allowed ({size:,} bytes)")
        if Path(path).suffix.lower() == ".pfm":
            width, height, _, offset = _pfm_header(fh.read(256))
            if size - offset < width * height * 12:
                raise HdrProblem(f"is shorter than its header says ({width} x {height} colour pixels)")
            return HdrHeader(width, height, 3, size)
        exr = _exr_call(lambda: openexr_module().File(fh, separate_channels=True, header_only=True))
        header = _exr_call(exr.header)
        lo, hi = header["dataWindow"]
        width, height = int(hi[0]) - int(lo[0]) + 1, int(hi[1]) - int(lo[1]) + 1
        if width < 1 or height < 1:
            raise HdrProblem(f"has an empty data window ({width} x {height} pixels)")
        return HdrHeader(width, height, max(1, len(header["channels"])), size)


def _exr_call(step):
    """What `step` (a call into the OpenEXR bindings) returns; any failure of theirs is HdrProblem."""
    openexr_module()  # missing bindings are said as such, not as a broken file
    try:
        return step()
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - the bindings raise RuntimeError, ValueError, IndexError, ...
        # the kind of failure only: the library's words may quote what it read
        raise HdrProblem(f"is not a readable OpenEXR image (the OpenEXR library refused it: {type(exc).__name__})") from None


def hdr_size(path) -> tuple[int, int]:
    """(width, height) from the header of an .exr or .pfm file."""
    header = hdr_header(path)
    return header.width, header.height


def check_decode(header: HdrHeader, max_pixels: int, memory: Optional[int] = None) -> None:
    """HdrProblem if the image is larger than `max_pixels`, or decoding it needs more than `memory` bytes."""
    width, height = header.width, header.height
    if width * height > max_pixels:
        raise HdrProblem(f"is {width} x {height} pixels, more than the {max_pixels:,} allowed")
    if memory is not None and header.decode_bytes + header.file_bytes > memory:
        from .bounds import gib, memory_limit_text

        raise HdrProblem(f"is {width} x {height} pixels of {header.channels} channels: decoding it needs about "
                         f"{gib(header.decode_bytes + header.file_bytes)}, more than {memory_limit_text()}")


def _exr_rgb_channels(path) -> list[np.ndarray]:
    """The R, G and B pixel arrays (h, w) of an EXR file as stored (half or float), or its Y three times."""
    with _open(path) as fh:
        channels = _exr_call(lambda: openexr_module().File(fh, separate_channels=True).channels())
        names = sorted(channels)
        if all(c in channels for c in "RGB"):
            picked = [channels[c].pixels for c in "RGB"]
        elif "Y" in channels:  # a grey image
            picked = [channels["Y"].pixels] * 3
        else:
            raise HdrProblem(f"has no R, G and B channels (it has {', '.join(names[:8]) or 'none'}"
                             f"{', ...' if len(names) > 8 else ''})")
    return picked


def _pfm_rgb(path, header: HdrHeader) -> np.ndarray:
    raw = _read(path, MAX_HDR_BYTES)
    width, height, dtype, offset = _pfm_header(raw[:256])
    if len(raw) - offset < width * height * 12:
        raise HdrProblem(f"is shorter than its header says ({width} x {height} colour pixels)")
    data = np.frombuffer(raw, dtype=dtype, count=width * height * 3, offset=offset)
    return data.reshape(height, width, 3)[::-1].astype(np.float32)


# Rows checked at a time for finite, non-negative values: the temporaries stay a few MiB.
_STRIP_TEXELS = 1 << 20


def _check_values(planes) -> float:
    """The largest value of the (h, w) or (h, w, c) arrays in `planes`, after checking each is finite
    and not negative; checked a strip of rows at a time, so no full-size temporary is made."""
    peak = 0.0
    for plane in planes:
        rows = max(1, _STRIP_TEXELS // max(1, plane[0].size if len(plane) else 1))
        for top in range(0, len(plane), rows):
            strip = np.asarray(plane[top:top + rows], dtype=np.float32)
            if not np.isfinite(strip).all():
                raise HdrProblem("holds values that are not finite (inf or NaN)")
            least = float(strip.min(initial=0.0))
            if least < 0:
                raise HdrProblem(f"holds negative values (the least is {least:g}); colours must be >= 0")
            peak = max(peak, float(strip.max(initial=0.0)))
    return peak


def hdr_peak(path, max_pixels: int, memory: Optional[int] = None) -> float:
    """The largest value of an .exr or .pfm image, which must be finite and not negative. Its
    header is checked against `max_pixels` and `memory` first; it is decoded once, and checked
    in strips (no float32 RGB copy is made)."""
    header = hdr_header(path)
    check_decode(header, max_pixels, memory)
    if Path(path).suffix.lower() == ".pfm":
        return _check_values([_pfm_rgb(path, header)])
    return _check_values(_exr_rgb_channels(path))


def read_hdr(path, max_pixels: int, memory: Optional[int] = None) -> np.ndarray:
    """The linear RGB image (h, w, 3) float32 of an .exr or .pfm file, row 0 at the top.

    The size is checked against `max_pixels` (and the memory decoding takes against `memory`)
    from the header before decoding; values must be finite and not negative."""
    header = hdr_header(path)
    check_decode(header, max_pixels, memory)
    if Path(path).suffix.lower() == ".pfm":
        image = _pfm_rgb(path, header)
    else:
        planes = _exr_rgb_channels(path)
        image = np.empty((header.height, header.width, 3), np.float32)
        for c, plane in enumerate(planes):
            if plane.shape != image.shape[:2]:
                raise HdrProblem(f"has pixels of shape {plane.shape}, not {header.height} x {header.width}")
            image[..., c] = plane
        del planes
    _check_values([image])
    return image


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


def exr_channels_bytes(channels: dict) -> bytes:
    """An OpenEXR file (float32, ZIP-compressed scanlines) of the named channels: each an (h, w)
    array of one size, under its full name ("R", "albedo.R", "depth.Z")."""
    OpenEXR = openexr_module()
    shapes = {values.shape for values in channels.values()}
    if not channels or len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise HdrProblem(f"expected channels of one (height, width) size, found shapes {sorted(shapes)}")
    pixels = {name: np.ascontiguousarray(values, dtype=np.float32) for name, values in channels.items()}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    out = io.BytesIO()
    OpenEXR.File(header, pixels).write(out)
    return out.getvalue()


def exr_layers_bytes(linear: np.ndarray, layers: dict) -> bytes:
    """An OpenEXR file of the linear image (h, w, 3) as its R, G and B channels, as `exr_bytes`
    writes it, and beside them the channels of `layers`: a full channel name ("albedo.R",
    "depth.Z") to an (h, w) array. Readers that know no layers (and our own image textures)
    still find the image in R, G and B."""
    if linear.ndim != 3 or linear.shape[2] != 3:
        raise HdrProblem(f"expected an (height, width, 3) image, found shape {linear.shape}")
    if any(name in ("R", "G", "B") for name in layers):
        raise HdrProblem("a layer's channel is named R, G or B, which hold the image")
    return exr_channels_bytes({"R": linear[..., 0], "G": linear[..., 1], "B": linear[..., 2], **layers})
