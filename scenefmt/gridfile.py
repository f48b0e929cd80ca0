"""Reading a medium's density grid: a 3-D array from a `.npy` file, or one array of a `.npz` file.

The file is untrusted. Nothing is unpickled (object arrays are refused before their data are
read); the array's header (shape and type) is read first and the size bounded before any data
(scenefmt.media.MAX_GRID_CELLS, MAX_GRID_SIDE), so a small compressed file cannot unpack into
gigabytes; the values must be finite and none negative. `GridProblem` says in one sentence what
is wrong; a key or a name from the file is shown only through `quote_text`.
"""

from __future__ import annotations

import zipfile

import numpy as np
from numpy.lib import format as npy_format

from .diagnostics import quote_text
from .files import FileProblem, open_regular_file
from .media import MAX_GRID_CELLS, MAX_GRID_SIDE


class GridProblem(Exception):
    """A grid file cannot be used; the message is the reason, in words."""


def _check_header(shape, dtype) -> None:
    if dtype.hasobject or dtype.kind not in "fiu" or dtype.fields is not None:
        raise GridProblem(f"the array holds {dtype.kind!r}-kind values, not numbers (floats or integers)")
    if len(shape) != 3:
        raise GridProblem(f"the array has {len(shape)} dimensions, not 3")
    if min(shape) < 1:
        raise GridProblem(f"the array is empty (shape {tuple(shape)})")
    if max(shape) > MAX_GRID_SIDE or int(np.prod(shape, dtype=np.int64)) > MAX_GRID_CELLS:
        raise GridProblem(f"the array's shape {tuple(shape)} is larger than allowed ({MAX_GRID_CELLS:,} cells, "
                          f"{MAX_GRID_SIDE} along a side)")


def _read_array(fh) -> np.ndarray:
    """The array of an open .npy stream, its header checked before its data are read."""
    try:
        version = npy_format.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = npy_format.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, fortran, dtype = npy_format.read_array_header_2_0(fh)
        else:
            raise GridProblem(f"unknown .npy format version {version}")
    except GridProblem:
        raise
    except (ValueError, OSError, EOFError) as exc:
        raise GridProblem("not a readable .npy array") from exc
    _check_header(shape, dtype)
    count = int(np.prod(shape, dtype=np.int64))
    raw = fh.read(count * dtype.itemsize)
    if len(raw) != count * dtype.itemsize:
        raise GridProblem("the file ends before the array's values do")
    flat = np.frombuffer(raw, dtype=dtype, count=count)
    return flat.reshape(shape, order="F" if fortran else "C")


def read_grid(path, key: str | None) -> np.ndarray:
    """The checked density grid of `path` (`.npy`, or the array `key` of an `.npz`), as a
    C-ordered float64 array of shape (nx, ny, nz). Raises GridProblem or FileProblem."""
    with open_regular_file(path) as fh:
        if str(path).lower().endswith(".npz"):
            try:
                with zipfile.ZipFile(fh) as archive:
                    names = archive.namelist()
                    member = f"{key}.npy"
                    if member not in names:
                        shown = ", ".join(quote_text(n[:-4]) for n in names[:8] if n.endswith(".npy"))
                        raise GridProblem(f"the .npz file holds no array {quote_text(key or '')}"
                                          + (f" (it holds {shown})" if shown else " (it holds none)"))
                    with archive.open(member) as inner:
                        values = _read_array(inner)
            except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, OSError, EOFError) as exc:
                raise GridProblem("not a readable .npz archive") from exc
        else:
            values = _read_array(fh)
    values = np.ascontiguousarray(values, dtype=np.float64)
    if not np.isfinite(values).all():
        raise GridProblem(f"{int((~np.isfinite(values)).sum()):,} of its values are not finite (NaN or infinite)")
    if (values < 0).any():
        raise GridProblem(f"{int((values < 0).sum()):,} of its values are negative; a density is at least 0")
    values.setflags(write=False)
    return values


__all__ = ["FileProblem", "GridProblem", "read_grid"]
