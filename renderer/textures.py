"""Texture data prepared in Python: image texels (linearised) and Perlin lattice tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function inverted (IEC 61966-2-1), for values in [0, 1]."""
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


def load_image_texels(path: Path, colorspace: str = "srgb") -> np.ndarray:
    """An (h, w, 3) float32 array of linear RGB, row 0 at the top of the image.

    Memory: the decoded image, its 8-bit RGB form (3 bytes a pixel) and the float32 texels
    (12 bytes a pixel), made by looking each 8-bit value up in a 256-entry table; no float64
    copy of the image is ever made (scenefmt.bounds.TEXTURE_BYTES_PER_PIXEL counts this).
    The file is opened as a regular file only, and its size is checked from its header before
    anything is decoded.
    """
    from PIL import Image, UnidentifiedImageError

    from scenefmt.files import FileProblem, open_regular_file
    from scenefmt.graph import MAX_TEXTURE_PIXELS  # the bound `rt validate` checks

    try:
        with open_regular_file(path) as fh, Image.open(fh) as img:
            if img.width * img.height > MAX_TEXTURE_PIXELS:
                raise ValueError(f"{path}: {img.width} x {img.height} is larger than the {MAX_TEXTURE_PIXELS:,} pixels allowed")
            rgb8 = np.asarray(img.convert("RGB"), dtype=np.uint8)
    except FileProblem as exc:
        raise ValueError(f"{path}: {exc}") from None
    except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise ValueError(f"{path}: cannot read it as an image ({exc})") from None
    table = np.arange(256, dtype=np.float64) / 255.0
    if colorspace == "srgb":
        table = srgb_to_linear(table)
    return np.ascontiguousarray(table.astype(np.float32)[rgb8])


def perlin_tables(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Three 256-entry permutations and 256 random unit vectors (Perlin's lattice, after Kensler)."""
    rng = np.random.default_rng(seed)
    perm = np.empty((3, 256), np.int32)
    for axis in range(3):
        p = np.arange(256, dtype=np.int32)
        # Fisher-Yates, as the books build their tables.
        for i in range(255, 0, -1):
            j = int(rng.integers(0, i + 1))
            p[i], p[j] = p[j], p[i]
        perm[axis] = p
    vec = np.empty((256, 3))
    k = 0
    while k < 256:
        v = rng.uniform(-1.0, 1.0, 3)
        n = float(v @ v)
        if 1e-12 < n <= 1.0:  # uniform directions by rejection from the cube
            vec[k] = v / np.sqrt(n)
            k += 1
    return perm, vec
