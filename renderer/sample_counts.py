"""The sample-count image of a render (`--samples-map`): where adaptive sampling spent its samples."""

from __future__ import annotations

import numpy as np


def sample_count_image(counts: np.ndarray, raw: bool) -> np.ndarray:
    """An (h, w, 3) image of each pixel's sample count (`counts`, (h, w)): the counts themselves in
    every channel (`raw`, for a float file: EXR or PFM), or for display grey, linear in the count,
    white at the largest (squared, so that the books' gamma-2 PNG shows it linearly)."""
    counts = np.asarray(counts, dtype=np.float64)
    if raw:
        return np.repeat(counts[:, :, None], 3, axis=2)
    top = float(counts.max(initial=0.0))
    grey = counts / top if top > 0 else np.zeros_like(counts)
    return np.repeat((grey * grey)[:, :, None], 3, axis=2)


# What a samples map's PNG records (film.PNG_CONTENT_KEY): always encoded with gamma2, whatever the
# image's display transform, so that its grey stays linear in the count.
SAMPLES_MAP_CONTENT = "samples map: each pixel's sample count, grey linear in the count, white the largest"
