"""Saved render states (`--resume`) read as hostile input.

Before: arrays that disagreed in shape reached the kernels (a segmentation fault), a compressed
state was decompressed whole before any check, truncated or non-zip files, a wrong `meta` type
or a 1-D array gave tracebacks, and negative or huge sample counts or NaN sums were accepted.
Each case here must be refused with a `ValueError` that says why, without a large allocation.
"""

from __future__ import annotations

import io
import json
import os
import tracemalloc

import numpy as np
import pytest

from renderer import state
from renderer.config import BATCHES
from renderer.film import Film
from renderer.state import STATE_VERSION, RenderKey, load_state, save_state

KEY = RenderKey("ab" * 32, 4, 3, 5, 7)


def meta_of(key: RenderKey = KEY, samples: int = 2, **changes) -> str:
    return json.dumps({"version": STATE_VERSION, **key.__dict__, "samples": samples, **changes})


def state_bytes(total=None, total_sq=None, meta=None, compressed=False, extra=None) -> bytes:
    shape = (KEY.height, KEY.width, 3)
    arrays = {
        "total": np.full(shape, 0.5) if total is None else total,
        "total_sq": np.full(shape, 0.25) if total_sq is None else total_sq,
        "batch": np.zeros((KEY.height, KEY.width, BATCHES, 3)),
        "peak": np.zeros(shape),
        "counts": np.full(shape[:2], 2, np.int64),
        "done": np.zeros(shape[:2], np.uint8),
        "meta": np.array(meta_of() if meta is None else meta),
    }
    arrays.update(extra or {})
    buffer = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buffer, **arrays)
    return buffer.getvalue()


def refusal(tmp_path, data: bytes, key: RenderKey = KEY) -> str:
    """The message with which `load_state` refuses a state file holding `data`."""
    path = tmp_path / "s.npz"
    path.write_bytes(data)
    with pytest.raises(ValueError) as excinfo:
        load_state(path, key)
    return str(excinfo.value)


def test_a_saved_state_loads_back(tmp_path):
    film = Film(np.full((3, 4, 3), 0.5), np.full((3, 4, 3), 0.25), 2)
    save_state(tmp_path / "s.npz", film, KEY)
    back = load_state(tmp_path / "s.npz", KEY)
    assert back.samples == 2 and np.array_equal(back.total, film.total) and np.array_equal(back.total_sq, film.total_sq)
    # The kernels add into the film: its arrays are writable, C-ordered float64.
    for array in (back.total, back.total_sq):
        assert array.flags.writeable and array.flags.c_contiguous and array.dtype == np.float64
    (tmp_path / "t.npz").write_bytes(state_bytes())  # the helper's own file is valid: the control for the cases below
    assert load_state(tmp_path / "t.npz", KEY).samples == 2


def test_arrays_that_disagree_in_shape_never_reach_the_kernels(tmp_path):
    assert "total_sq has the shape (4, 4, 3), not (3, 4, 3)" in refusal(tmp_path, state_bytes(total_sq=np.zeros((4, 4, 3))))
    assert "total has the shape (36,), not (3, 4, 3)" in refusal(tmp_path, state_bytes(total=np.zeros(36)))
    assert "total has the type float32" in refusal(tmp_path, state_bytes(total=np.zeros((3, 4, 3), np.float32)))
    assert "total has the type int64" in refusal(tmp_path, state_bytes(total=np.zeros((3, 4, 3), np.int64)))


def test_a_compressed_state_that_expands_to_gigabytes_is_refused_before_decompression(tmp_path):
    key = RenderKey(KEY.scene, 100, 100, KEY.max_depth, KEY.seed)  # a film whose state may be this large a file
    bomb = state_bytes(total=np.zeros((3000, 3000, 3)), meta=meta_of(key), compressed=True)  # 216 MB of zeros
    assert len(bomb) < 300_000
    tracemalloc.start()
    try:
        message = refusal(tmp_path, bomb, key)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "declares 216,000,128 bytes" in message, message
    assert peak < 20_000_000


def needs_zip_version(data: bytes, version: int) -> bytes:
    """`data` with its first central directory entry asking for zip `version` (x10) to extract."""
    at = data.index(b"PK\x01\x02") + 6
    return data[:at] + version.to_bytes(2, "little") + data[at + 2:]


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: state_bytes()[:200], "not a zip archive"),
        (lambda: state_bytes()[:-30], "not a zip archive"),
        (lambda: b"hello, not a zip", "not a zip archive"),
        (lambda: state_bytes(meta=np.array(5)), "meta has the type int64, not a string"),
        (lambda: state_bytes(meta="[1, 2]"), "its metadata is a list, not a mapping"),
        (lambda: state_bytes(meta="{"), "its metadata is not JSON"),
        (lambda: state_bytes(meta=meta_of(width=True)), "its metadata's width is True, not an integer"),
        (lambda: state_bytes(meta=meta_of(samples=-3)), "it holds -3 samples per pixel; a state holds 1 to 1,000,000"),
        (lambda: state_bytes(meta=meta_of(samples=10**18)), "samples per pixel; a state holds 1 to 1,000,000"),
        (lambda: state_bytes(meta=meta_of(samples=0)), "it holds 0 samples"),
        (lambda: state_bytes(total=np.full((3, 4, 3), np.nan)), "total holds values that are not finite"),
        (lambda: state_bytes(total_sq=np.full((3, 4, 3), np.inf)), "total_sq holds values that are not finite"),
        (lambda: state_bytes(total_sq=np.full((3, 4, 3), -1.0)), "total_sq holds negative sums"),
        (lambda: state_bytes(total=np.full((3, 4, 3), 1e300)), "total holds sums above"),
        (lambda: state_bytes(extra={"more": np.zeros(3)}), "not a saved render state"),
        # Found by the fuzzer: a central directory asking for a zip version Python cannot read.
        (lambda: needs_zip_version(state_bytes(), 118), "not a zip archive"),
    ],
)
def test_corrupt_states_are_refused_with_a_reason(tmp_path, make, words):
    message = refusal(tmp_path, make())
    assert words in message, message


def test_a_state_path_that_is_not_a_regular_file_is_refused(tmp_path):
    os.mkfifo(tmp_path / "fifo.npz")
    for path in (tmp_path / "fifo.npz", "/dev/zero", tmp_path, tmp_path / "a\x00b.npz"):
        with pytest.raises(state.StateError) as excinfo:
            load_state(path, KEY)
        assert "regular file" in str(excinfo.value) or "NUL" in str(excinfo.value)
