"""The film: per-pixel sums of samples and of their squares, and the image files made from them."""

from __future__ import annotations

import errno
import math
import os
import secrets
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, NamedTuple, Optional

import numpy as np

from .config import BATCHES
from .error_estimate import NoiseEstimate, estimate  # NoiseEstimate: callers import it from here too


class PixelSums(NamedTuple):
    """The arrays the kernels add samples into (film_sums.add_sample), all image-shaped (h, w, ...):
    the whole film's, or one tile's (rt/chunks.py)."""

    total: np.ndarray  # (h, w, 3) float64 sum of samples
    total_sq: np.ndarray  # (h, w, 3) float64 sum of squared samples
    batch: np.ndarray  # (h, w, BATCHES, 3) float64 sum of each batch's samples (sample s is in batch s % BATCHES)
    peak: np.ndarray  # (h, w, 3) float64 the sample with the largest r^2 + g^2 + b^2
    counts: np.ndarray  # (h, w) int64 samples the pixel holds (a dropped, non-finite one included)
    done: np.ndarray  # (h, w) uint8 1 once adaptive sampling stopped the pixel


# The film's arrays, in the order PixelSums holds them: what a state file and a cluster's chunk carry.
SUM_ARRAYS = PixelSums._fields


@dataclass
class Film:
    """Running sums of a render, per pixel (see PixelSums). `samples` is the sample index every
    pixel that is not done has reached: without adaptive sampling, how many samples every pixel
    holds. A film made from `total`, `total_sq` and `samples` alone starts its batches and peaks
    empty (its error is then judged from the samples' own spread)."""

    total: np.ndarray  # (h, w, 3) float64 sum of sample radiance
    total_sq: np.ndarray  # (h, w, 3) float64 sum of squared sample radiance
    samples: int = 0
    batch: Optional[np.ndarray] = None
    peak: Optional[np.ndarray] = None
    counts: Optional[np.ndarray] = None
    done: Optional[np.ndarray] = None
    # Adaptive sampling's rule (threshold, floor, tail, guard: sampling.Sampling's fields), fixed once by
    # the pilot (adaptive_plan.py) and saved with the film, so a resume stops pixels the same way;
    # None: no pixel of this film was judged.
    stopping: Optional[tuple] = None

    def __post_init__(self):
        h, w = self.total.shape[:2]
        if self.batch is None:
            self.batch = np.zeros((h, w, BATCHES, 3))
        if self.peak is None:
            self.peak = np.zeros((h, w, 3))
        if self.counts is None:
            self.counts = np.full((h, w), self.samples, np.int64)
        if self.done is None:
            self.done = np.zeros((h, w), np.uint8)

    @classmethod
    def empty(cls, width: int, height: int) -> "Film":
        return cls(np.zeros((height, width, 3)), np.zeros((height, width, 3)), 0)

    @classmethod
    def of_sums(cls, sums: PixelSums, samples: int) -> "Film":
        return cls(sums.total, sums.total_sq, samples, sums.batch, sums.peak, sums.counts, sums.done)

    @property
    def sums(self) -> PixelSums:
        """The arrays the kernels add into (views of this film's own)."""
        return PixelSums(self.total, self.total_sq, self.batch, self.peak, self.counts, self.done)

    @property
    def width(self) -> int:
        return self.total.shape[1]

    @property
    def height(self) -> int:
        return self.total.shape[0]

    @property
    def uniform(self) -> bool:
        """Whether every pixel holds `samples` samples (no pixel was stopped early)."""
        return not self.done.any()

    def mean(self) -> np.ndarray:
        """The image: linear radiance per pixel (h, w, 3)."""
        if self.uniform:
            return self.total / max(self.samples, 1)
        return self.total / np.maximum(self.counts, 1)[:, :, None]

    def mean_variance(self) -> np.ndarray:
        """The variance of each pixel's mean (h, w, 3): the samples' unbiased variance (clamped
        at 0 against rounding) over their number. Needs two samples or more."""
        n = self.samples if self.uniform else np.maximum(self.counts, 2)[:, :, None]
        return np.maximum(self.total_sq - self.total * (self.total / n), 0.0) / (n - 1) / n


def to_srgb8(linear: np.ndarray) -> np.ndarray:
    """8-bit pixels as the books write them: gamma 2 (square root), clamped to [0, 0.999], x256
    (display.py's `gamma2`, the default display transform)."""
    from .display import gamma2

    return gamma2(linear)


def _atomic_write(path: Path, write) -> None:
    """Write through a temporary file in the same folder, then rename: never a truncated file.

    Where the system allows it (Linux, O_TMPFILE), the temporary file has no name while it is
    written, so a process killed in the middle (even by SIGKILL) leaves nothing behind; it is
    given a short random name only once complete, for the instant before the rename. Elsewhere
    a named temporary file is removed on any exception.
    """
    path = Path(path)
    folder = path.parent
    try:
        fd = os.open(folder, os.O_TMPFILE | os.O_WRONLY | os.O_CLOEXEC, 0o666)
    except AttributeError:  # no O_TMPFILE on this system
        return _atomic_write_named(path, write)
    except OSError as exc:
        if exc.errno in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL):  # not on this file system
            return _atomic_write_named(path, write)
        raise
    with os.fdopen(fd, "wb") as fh:
        write(fh)
        fh.flush()
        tmp = folder / f".rt-{secrets.token_hex(6)}.tmp"
        try:
            os.link(f"/proc/self/fd/{fh.fileno()}", tmp)
        except OSError:  # no /proc: write it again, named
            named = True
        else:
            named = False
    if named:
        return _atomic_write_named(path, write)
    try:
        os.replace(tmp, path)
    except BaseException:
        _remove(tmp)
        raise


def _remove(path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _atomic_write_named(path: Path, write) -> None:
    # A short name, so that a file name near the system's length limit still has a temporary one.
    fd, tmp = tempfile.mkstemp(prefix=".rt-", suffix=".tmp", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        # mkstemp makes the file private (0600); give it the mode any new file would get.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        _remove(tmp)
        raise


# The PNG text chunk that names the display transform a PNG was made with (display.py), and the
# one that says what its pixels record, for pictures that are not the image (a noise map).
PNG_DISPLAY_KEY = "rt:display"
PNG_CONTENT_KEY = "rt:content"


def software_name() -> str:
    """"rt VERSION", as a PNG's Software chunk gives it ("rt" alone when rt is not installed)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return f"rt {version('rt-render')}"
    except PackageNotFoundError:  # run from a checkout that is not installed
        return "rt"


def png_bytes(linear: np.ndarray, display: str = "gamma2", text: Optional[dict] = None) -> bytes:
    """The 8-bit PNG of a linear image under the display transform `display` (display.py; the
    default is the books' gamma 2, `to_srgb8`), as bytes: what `write_png` writes. Its text
    chunks say which transform made it (PNG_DISPLAY_KEY) and which program ("Software"), then
    `text`'s entries (plain ASCII keys and values)."""
    import io

    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    from .display import DESCRIPTIONS, to_display8

    pixels = to_display8(linear, display)  # refuses an unknown name before anything is encoded
    info = PngInfo()
    info.add_text("Software", software_name())
    info.add_text(PNG_DISPLAY_KEY, display)
    info.add_text("Comment", f"display transform {display}: {DESCRIPTIONS[display]}")
    for key, value in (text or {}).items():
        info.add_text(key, value)
    buffer = io.BytesIO()
    Image.fromarray(pixels, "RGB").save(buffer, format="PNG", pnginfo=info)
    return buffer.getvalue()


def write_png(path: Path, linear: np.ndarray, display: str = "gamma2", text: Optional[dict] = None) -> None:
    data = png_bytes(linear, display, text)  # encoded in memory first: a failure leaves no file behind
    _atomic_write(path, lambda fh: fh.write(data))


def write_pfm(path: Path, linear: np.ndarray) -> None:
    """Portable float map: linear RGB float32, little-endian, rows bottom to top (read by most HDR
    tools); an (height, width) array is written as a grey one ("Pf", one channel: a render pass)."""
    grey = linear.ndim == 2
    if not grey and (linear.ndim != 3 or linear.shape[2] != 3):
        raise ValueError(f"expected an (height, width, 3) image, found shape {linear.shape}")
    h, w = linear.shape[:2]
    header = f"{'Pf' if grey else 'PF'}\n{w} {h}\n-1.0\n".encode("ascii")
    data = np.ascontiguousarray(linear[::-1].astype("<f4"))
    _atomic_write(path, lambda fh: (fh.write(header), fh.write(data.tobytes())))


def write_exr(path: Path, linear: np.ndarray) -> None:
    """OpenEXR: linear RGB float32, ZIP-compressed scanlines (needs the optional `openexr` package)."""
    from scenefmt.hdr_files import exr_bytes

    data = exr_bytes(linear)  # encoded in memory first: a failure leaves no file behind
    _atomic_write(path, lambda fh: fh.write(data))


def write_exr_layers(path: Path, linear: np.ndarray, layers: dict) -> None:
    """OpenEXR as `write_exr`, with extra channels beside R, G and B: `layers` maps a full channel
    name ("albedo.R", "depth.Z") to an (height, width) array (scenefmt.hdr_files.exr_layers_bytes)."""
    from scenefmt.hdr_files import exr_layers_bytes

    data = exr_layers_bytes(linear, layers)  # encoded in memory first: a failure leaves no file behind
    _atomic_write(path, lambda fh: fh.write(data))


def write_exr_channels(path: Path, channels: dict) -> None:
    """OpenEXR of named (height, width) float channels ("R", "Y", ...), written atomically."""
    from scenefmt.hdr_files import exr_channels_bytes

    data = exr_channels_bytes(channels)
    _atomic_write(path, lambda fh: fh.write(data))


def read_pfm(path: Path) -> np.ndarray:
    """The linear image (h, w, 3) of a PFM file written by `write_pfm` (rows top to bottom); (h, w)
    for a grey one ("Pf")."""
    raw = Path(path).read_bytes()
    parts = raw.split(b"\n", 3)
    if parts[0] not in (b"PF", b"Pf"):
        raise ValueError(f"{path}: not a PFM file")
    w, h = (int(x) for x in parts[1].split())
    scale = float(parts[2])
    dtype = "<f4" if scale < 0 else ">f4"
    if parts[0] == b"Pf":
        return np.frombuffer(parts[3], dtype=dtype, count=w * h).reshape(h, w)[::-1].astype(np.float64)
    return np.frombuffer(parts[3], dtype=dtype, count=w * h * 3).reshape(h, w, 3)[::-1].astype(np.float64)


@dataclass(frozen=True)
class FileFormat:
    """A kind of file a render writes, known by its suffix."""

    suffix: str
    role: str  # "image": 8-bit, for display (the image, a noise map); "hdr": linear float; "state": a resumable render
    needs_exr: bool = False  # written with the optional OpenEXR library (scenefmt.hdr_files.exr_available)
    # An image's writer (an "image" role's also takes the display transform and text: write_png); a
    # state is written by state.py.
    write: Optional[Callable[..., None]] = None


# Every file format a render writes, in the order messages list them: the one place a suffix is
# spelt (rt/outputs.py checks and names outputs from it, `write_image` writes by it).
FILE_FORMATS = (
    FileFormat(".png", "image", write=write_png),
    FileFormat(".exr", "hdr", needs_exr=True, write=write_exr),
    FileFormat(".pfm", "hdr", write=write_pfm),
    FileFormat(".npz", "state"),
)
FORMAT_BY_SUFFIX = {f.suffix: f for f in FILE_FORMATS}


def write_image(path: Path, linear: np.ndarray, display: str = "gamma2", text: Optional[dict] = None) -> None:
    """The image as the format its file's suffix names (FILE_FORMATS): PNG, OpenEXR or PFM. An
    8-bit image (PNG) is made with the display transform `display` and carries `text` in its
    metadata (png_bytes); a linear one is written as rendered, and neither applies."""
    suffix = Path(path).suffix.lower()
    found = FORMAT_BY_SUFFIX.get(suffix)
    if found is None or found.write is None:
        images = [f.suffix for f in FILE_FORMATS if f.write is not None]
        raise ValueError(f"unsupported image format {suffix!r}: use {', '.join(images[:-1])} or {images[-1]}")
    if found.role == "image":
        found.write(path, linear, display, text)
    else:
        found.write(path, linear)


def relative_noise(film: Film) -> float:
    """The relative RMS noise of `estimate_noise`, computed without its per-pixel map.

    The progress display asks for it about once a second while the render threads wait; with
    two passes over the film and one temporary array it takes a few milliseconds on a 600x600
    image, where the whole estimate took 30 ms.
    """
    n = film.samples
    if not film.uniform:  # adaptive sampling stopped some pixels: each pixel's own count
        n = np.maximum(film.counts, 1).astype(np.float64)[:, :, None]
        if film.counts.min() < 2:
            return float("inf")
        mean = film.total / n
        signal = float(np.square(mean).sum())
        se2_sum = float((np.maximum(film.total_sq - film.total * mean, 0.0) / ((n - 1) * n)).sum())
        if signal > 0:
            return math.sqrt(se2_sum / signal)
        return 0.0 if se2_sum == 0 else float("inf")
    if n < 2:
        return float("inf")
    # Sum over pixels of the unbiased sample variance (clamped at 0 against rounding), / n for
    # the variance of each mean, against the sum of squared means.
    work = np.square(film.total)
    signal = float(work.sum()) / (n * n)
    work /= n
    np.subtract(film.total_sq, work, out=work)
    np.maximum(work, 0.0, out=work)
    se2_sum = float(work.sum()) / (n - 1) / n
    if signal > 0:
        return math.sqrt(se2_sum / signal)
    return 0.0 if se2_sum == 0 else float("inf")


def estimate_noise(film: Film) -> NoiseEstimate:
    """The error of the image with its interval at 95% confidence, each pixel's standard error
    and its upper bound, and a warning when rare bright samples make the estimate untrustworthy
    (renderer/error_estimate.py: from the film's batch means, or from its single samples when it
    has no batches)."""
    return estimate(film)


def noise_map_image(estimate: NoiseEstimate) -> np.ndarray:
    """A greyscale picture of the per-pixel error, linear in the error: black is none, white is the
    99th percentile and above (a few fireflies would otherwise leave everything else black)."""
    err = np.where(np.isfinite(estimate.error), estimate.error, 0.0)
    top = float(np.percentile(err, 99)) if err.size else 0.0
    grey = np.clip(err / top, 0.0, 1.0) if top > 0 else np.zeros_like(err)
    # Square so that the books' gamma-2 PNG output shows error linearly (NOISE_MAP_CONTENT).
    return np.repeat((grey * grey)[:, :, None], 3, axis=2)


# What a noise map's PNG records (its PNG_CONTENT_KEY chunk): it is always encoded with gamma2,
# whatever the image's display transform, so that its grey stays linear in the error.
NOISE_MAP_CONTENT = ("noise map: each pixel's estimated standard error, grey linear in the error, black none, "
                     "white the 99th percentile and above")
