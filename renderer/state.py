"""Saving a render's film to continue it later with more samples (`--save-state`, `--resume`).

Random numbers are keyed by sample index, so a render continued from a saved state gives the
very same image as one render with the total number of samples. A state records a
fingerprint of the scene and the settings that shape the image; resuming with anything else
is refused rather than mixing two different images.

A state file comes from outside and its arrays go to the kernels, which index them without
bounds checks, so it is read as hostile input (`load_state`): a regular file, opened member by
member as a zip archive, no read larger than a state of this render's image can need. Its saved
key is read first, so a state of another scene or image size is refused by saying which; a file
larger than this render's state can be is refused after that. Each member's declared size is checked against what
the scene's image needs before a byte is decompressed, and decompression stops at that size;
each array's header (shape, type, order) is checked before its data is read; the data must be
finite, sums of squares non-negative, and the metadata exactly the fields and types written by
`save_state`. Every problem is a `StateError` (a ValueError) with a sentence to show.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenefmt.bounds import MAX_RADIANCE

from .config import BATCHES
from .film import SUM_ARRAYS, Film, _atomic_write

STATE_VERSION = 3  # 2: the key holds the integrator; 3: the sampler, and the batches, peaks and counts of every pixel
# Samples per pixel a state may hold (the command line's cap, `--spp`).
MAX_STATE_SAMPLES = 1_000_000
_HEADER_BYTES = 4096  # an .npy header is at most this long here
_META_BYTES = 4096


class StateError(ValueError):
    """A saved render state that cannot be used; the message names the file and says why."""


@dataclass(frozen=True)
class RenderKey:
    """What must match for two renders' samples to be added together."""

    scene: str  # sha256 of the scene in canonical JSON
    width: int
    height: int
    max_depth: int
    seed: int
    integrator: str = "mis"  # samples of different estimators have the same mean but are not one render
    sampler: str = "independent"  # the samples' points: a render continues only with the same sampler


def scene_fingerprint(scene_json: str) -> str:
    return hashlib.sha256(scene_json.encode("utf-8")).hexdigest()


def save_state(path: Path, film: Film, key: RenderKey) -> None:
    meta = {"version": STATE_VERSION, **key.__dict__, "samples": film.samples}
    extra = {}
    if film.stopping is not None:  # adaptive sampling's rule, so that a resume stops pixels the same way
        threshold, floor, tail, guard = film.stopping
        meta["stopping"] = [float(threshold), int(floor), float(tail)]
        extra["guard"] = np.asarray(guard, dtype=np.float64)
    meta = json.dumps(meta)

    def write(fh):
        np.savez(fh, **{name: getattr(film, name) for name in SUM_ARRAYS}, **extra, meta=np.array(meta))

    _atomic_write(Path(path), write)


def _read_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, limit: int, where: str) -> bytes:
    """A member's bytes, refusing one whose declared or actual size exceeds `limit`."""
    if info.file_size > limit:
        raise StateError(f"{where}: the member {info.filename!r} declares {info.file_size:,} bytes, more than the {limit:,} it can need")
    try:
        with archive.open(info) as fh:
            data = fh.read(limit + 1)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError, NotImplementedError, RuntimeError, ValueError) as exc:
        raise StateError(f"{where}: the member {info.filename!r} cannot be read ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - zlib and lzma errors of corrupt data have many types
        raise StateError(f"{where}: the member {info.filename!r} is corrupt ({type(exc).__name__}: {exc})") from None
    if len(data) > limit:
        raise StateError(f"{where}: the member {info.filename!r} expands past the {limit:,} bytes it can need")
    return data


def _parse_npy(data: bytes, name: str, where: str, shape: tuple, kind: str) -> np.ndarray:
    """The array in `data` (an .npy file), which must have exactly `shape` and the kind of dtype."""
    fh = io.BytesIO(data)
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            got_shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh, max_header_size=_HEADER_BYTES)
        elif version == (2, 0):
            got_shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh, max_header_size=_HEADER_BYTES)
        else:
            raise ValueError(f"unsupported .npy version {version}")
    except (ValueError, OSError, EOFError, SyntaxError, TypeError) as exc:
        raise StateError(f"{where}: {name} is not a readable array ({exc})") from None
    wanted = {"f": "float64", "i": "int64", "u": "uint8", "U": "a string"}[kind]
    if (dtype.hasobject or dtype.kind != kind or (kind in "fi" and dtype.itemsize != 8) or (kind == "u" and dtype.itemsize != 1)
            or dtype.itemsize > 4 * _META_BYTES):
        raise StateError(f"{where}: {name} has the type {dtype}, not {wanted}")
    if tuple(got_shape) != tuple(shape):
        raise StateError(f"{where}: {name} has the shape {tuple(got_shape)}, not {tuple(shape)}")
    count = math.prod(shape)
    body = data[fh.tell():]
    if len(body) != count * dtype.itemsize:
        raise StateError(f"{where}: {name} holds {len(body):,} bytes of data, not the {count * dtype.itemsize:,} its shape needs")
    array = np.frombuffer(body, dtype=dtype, count=count)
    return array.reshape(shape, order="F" if fortran else "C")


def escape_version(value) -> str:
    """A version field as it may be shown: an integer, or what it is instead (never its text)."""
    return str(value) if type(value) is int else f"that is not a number ({type(value).__name__})"  # noqa: E721


def _meta(raw: np.ndarray, where: str) -> dict:
    try:
        meta = json.loads(str(raw[()]))
    except (ValueError, TypeError, RecursionError) as exc:
        raise StateError(f"{where}: its metadata is not JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise StateError(f"{where}: its metadata is a {type(meta).__name__}, not a mapping")
    if meta.get("version") != STATE_VERSION:
        # Version 1 had no integrator: its samples were the books' estimator's, at a time when
        # that was the only one.
        raise StateError(f"{where}: a render state of version {escape_version(meta.get('version'))}; this rt reads version "
                         f"{STATE_VERSION} (render it again)")
    fields = {"version": int, "scene": str, "width": int, "height": int, "max_depth": int, "seed": int, "integrator": str,
              "sampler": str, "samples": int}
    stopping = meta.pop("stopping", None)
    if stopping is not None:
        meta["stopping"] = _stopping(stopping, where)
    if set(meta) - {"stopping"} != set(fields):
        missing, extra = sorted(set(fields) - set(meta)), sorted(set(meta) - set(fields))
        raise StateError(f"{where}: its metadata has the wrong fields (missing {missing}, unknown {extra})")
    for name, kind in fields.items():
        if type(meta[name]) is not kind:  # noqa: E721 - bool is not an int here
            raise StateError(f"{where}: its metadata's {name} is {meta[name]!r}, not {'an integer' if kind is int else 'a string'}")
    return meta


class _BoundedReads:
    """A state file as zipfile reads it, each read at most `most` bytes.

    zipfile reads the central directory, and a stored member, in one read of the size the archive
    declares; a file that declares gigabytes must cost no more memory than a real state of this
    render's image could. The file itself may be larger than that (a state of a larger image):
    only the few bytes that say what it is are read then, so the refusal can say so.
    """

    def __init__(self, fh, most: int, where: str):
        self._fh = fh
        self._most = most
        self._where = where
        self.size = os.fstat(fh.fileno()).st_size

    def read(self, n: int = -1) -> bytes:
        left = max(0, self.size - self._fh.tell())
        n = left if n is None or n < 0 else min(n, left)
        if n > self._most:
            raise StateError(f"{self._where}: not a saved render state (it asks to read {n:,} bytes at once, more than "
                             f"the {self._most:,} a state of this render's image can need)")
        return self._fh.read(n)

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._fh.seek(offset, whence)

    def tell(self) -> int:
        return self._fh.tell()

    def seekable(self) -> bool:
        return True

    def close(self) -> None:
        pass  # the caller closes the file


def _stopping(value, where: str) -> tuple:
    """Adaptive sampling's rule as a state saves it: [threshold, floor, tail], finite and in range."""
    ok = (isinstance(value, list) and len(value) == 3 and all(type(v) in (int, float) for v in value)
          and all(math.isfinite(v) for v in value))
    if ok:
        threshold, floor, tail = value
        ok = threshold >= 0 and type(floor) is int and 0 <= floor <= MAX_STATE_SAMPLES and floor % BATCHES == 0 and 0 <= tail <= 1
    if not ok:
        raise StateError(f"{where}: its metadata's adaptive stopping rule is not [threshold, floor, tail] in range")
    return (float(threshold), int(floor), float(tail))


def describe_mismatch(saved: RenderKey, key: RenderKey) -> str:
    """What differs between the render a state holds and this one, in words (never the scene's text)."""
    of = []
    if saved.scene != key.scene:
        of.append("another scene (or of this one before a change to it)")
    if (saved.width, saved.height) != (key.width, key.height):
        of.append(f"a {saved.width}x{saved.height} image (this render is {key.width}x{key.height})")
    parts = ["it is of " + " and of ".join(of)] if of else []
    for name, label in (("max_depth", "max depth"), ("seed", "seed"), ("integrator", "integrator"), ("sampler", "sampler")):
        if getattr(saved, name) != getattr(key, name):
            parts.append(f"{label} {getattr(saved, name)} (now {getattr(key, name)})")
    return "this state does not match this render: " + "; ".join(parts)


def load_state(path: Path, key: RenderKey, max_samples: int = MAX_STATE_SAMPLES) -> Film:
    """The film saved at `path`; StateError (a ValueError) if it is not a state this render can continue.

    The state's own key is read first (a few kilobytes, whatever the file's size), so a state of
    another scene or image size is refused by saying which, not by its size."""
    from scenefmt.files import FileProblem, describe_os_error, open_regular_file

    where = str(path)
    try:
        fh = open_regular_file(path)
    except FileProblem as exc:
        raise StateError(f"{where}: {exc}") from None
    try:
        with fh:
            return _read_state(fh, where, key, max_samples)
    except OSError as exc:
        raise StateError(f"{where}: cannot read the file: {describe_os_error(exc)}") from None


# Each array of a state: its shape after (height, width), and its kind of dtype (as _parse_npy takes it).
_ARRAY_LAYOUT = {"total": ((3,), "f"), "total_sq": ((3,), "f"), "batch": ((BATCHES, 3), "f"), "peak": ((3,), "f"),
                 "counts": ((), "i"), "done": ((), "u")}
_ITEM_BYTES = {"f": 8, "i": 8, "u": 1}


def _read_state(fh, where: str, key: RenderKey, max_samples: int) -> Film:
    pixels = key.width * key.height
    sizes = {name: pixels * math.prod(tail) * _ITEM_BYTES[kind] + _HEADER_BYTES for name, (tail, kind) in _ARRAY_LAYOUT.items()}
    # Stored members can be no larger than their data; compressed ones are smaller still.
    limit = sum(sizes.values()) + sizes["counts"] + _META_BYTES * 8 + 64 * 1024  # (+ the guard's, as large as counts)
    source = _BoundedReads(fh, max(limit, 1 << 17), where)  # zipfile looks for its directory in the last 64 KiB
    try:
        archive = zipfile.ZipFile(source)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, EOFError, ValueError) as exc:
        if isinstance(exc, StateError):
            raise
        raise StateError(f"{where}: not a saved render state, or one cut short (not a zip archive: {exc})") from None
    with archive:
        members = {info.filename: info for info in archive.infolist()}
        expected = {f"{name}.npy" for name in SUM_ARRAYS} | {"meta.npy"}
        if "guard.npy" in members:  # adaptive sampling's per-pixel guard, with its rule in the metadata
            expected.add("guard.npy")
        if set(members) != expected or len(archive.infolist()) != len(expected):
            raise StateError(f"{where}: not a saved render state (it holds {sorted(members)[:8]}, not {sorted(expected)})")
        meta_raw = _parse_npy(_read_member(archive, members["meta.npy"], _META_BYTES * 4 + _HEADER_BYTES, where), "meta", where, (), "U")
        meta = _meta(meta_raw, where)
        saved = RenderKey(meta["scene"], meta["width"], meta["height"], meta["max_depth"], meta["seed"], meta["integrator"],
                          meta["sampler"])
        if saved != key:
            raise StateError(f"{where}: {describe_mismatch(saved, key)}")
        if source.size > limit:
            raise StateError(f"{where}: the file is larger than the {limit:,} bytes a state of a {key.width}x{key.height} "
                             f"image can need ({source.size:,} bytes)")
        if ("stopping" in meta) != ("guard.npy" in members):
            raise StateError(f"{where}: its adaptive stopping rule and its per-pixel guard come only together")
        if "stopping" in meta:
            data = _read_member(archive, members["guard.npy"], sizes["counts"], where)
            guard = np.array(_parse_npy(data, "guard", where, (key.height, key.width), "f"), order="C")
            if not (np.isfinite(guard).all() and (guard >= 0).all()):
                raise StateError(f"{where}: its per-pixel guard holds values that are not finite or are negative")
            meta["stopping"] = meta["stopping"] + (guard,)
        samples = meta["samples"]
        if not 1 <= samples <= max_samples:
            raise StateError(f"{where}: it holds {samples} samples per pixel; a state holds 1 to {max_samples:,}")
        arrays = {}
        for name in SUM_ARRAYS:
            tail, kind = _ARRAY_LAYOUT[name]
            data = _read_member(archive, members[f"{name}.npy"], sizes[name], where)
            # Copies: the arrays read lie over the file's bytes, read-only, and the kernels add into them.
            arrays[name] = np.array(_parse_npy(data, name, where, (key.height, key.width) + tail, kind), order="C")
    _check_sums(arrays, samples, where)
    return Film(samples=samples, **arrays, stopping=meta.get("stopping"))


def _check_sums(arrays: dict, samples: int, where: str) -> None:
    """Refuse sums no render of `samples` samples per pixel can have made: the kernels trust them."""
    for name in ("total", "total_sq", "batch", "peak"):
        if not np.isfinite(arrays[name]).all():
            raise StateError(f"{where}: {name} holds values that are not finite (NaN or infinite)")
    # A sample is at most the brightest radiance a scene may hold, times a margin for textures that
    # reflect a little more than their colour (turbulence): sums beyond are not this renderer's.
    most = samples * MAX_RADIANCE * 1e3
    for name, top in (("total", most), ("total_sq", most * MAX_RADIANCE * 1e3), ("batch", most), ("peak", MAX_RADIANCE * 1e3)):
        array = arrays[name]
        if (array < 0).any():
            raise StateError(f"{where}: {name} holds negative sums (radiance is never negative)")
        if (array > top).any():
            raise StateError(f"{where}: {name} holds sums above {top:g}, more than {samples} samples can add up to")
    counts, done = arrays["counts"], arrays["done"]
    if (done > 1).any():
        raise StateError(f"{where}: done holds values other than 0 and 1")
    if (counts < 0).any() or (counts > samples).any():
        raise StateError(f"{where}: counts holds sample counts outside 0 to {samples}")
    if (counts[done == 0] != samples).any():
        raise StateError(f"{where}: a pixel that is not done holds another count than the state's {samples} samples")
