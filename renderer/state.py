"""Saving a render's film to continue it later with more samples (`--save-state`, `--resume`).

Random numbers are keyed by sample index, so a render continued from a saved state gives the
very same image as one render with the total number of samples. A state records a
fingerprint of the scene and the settings that shape the image; resuming with anything else
is refused rather than mixing two different images.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .film import Film, _atomic_write

STATE_VERSION = 1


@dataclass(frozen=True)
class RenderKey:
    """What must match for two renders' samples to be added together."""

    scene: str  # sha256 of the scene in canonical JSON
    width: int
    height: int
    max_depth: int
    seed: int


def scene_fingerprint(scene_json: str) -> str:
    return hashlib.sha256(scene_json.encode("utf-8")).hexdigest()


def save_state(path: Path, film: Film, key: RenderKey) -> None:
    meta = json.dumps({"version": STATE_VERSION, **key.__dict__, "samples": film.samples})

    def write(fh):
        np.savez(fh, total=film.total, total_sq=film.total_sq, meta=np.array(meta))

    _atomic_write(Path(path), write)


def load_state(path: Path, key: RenderKey) -> Film:
    """The film saved at `path`; ValueError if it belongs to another scene or other settings."""
    with np.load(Path(path), allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        total, total_sq = data["total"], data["total_sq"]
    if meta.get("version") != STATE_VERSION:
        raise ValueError(f"{path}: a render state of an unknown version ({meta.get('version')})")
    saved = RenderKey(meta["scene"], meta["width"], meta["height"], meta["max_depth"], meta["seed"])
    if saved != key:
        diffs = [f"{name} {getattr(saved, name)} (now {getattr(key, name)})" for name in key.__dict__
                 if getattr(saved, name) != getattr(key, name)]
        shown = ", ".join("the scene file changed" if d.startswith("scene ") else d for d in diffs)
        raise ValueError(f"{path}: the saved render does not match this one: {shown}")
    if total.shape != (key.height, key.width, 3):
        raise ValueError(f"{path}: the saved image is {total.shape[1]}x{total.shape[0]}, not {key.width}x{key.height}")
    return Film(total.astype(np.float64), total_sq.astype(np.float64), int(meta["samples"]))
