"""The display transforms' figures for docs/display.md: each one's 8-bit code for grey radiance
from 1/256 of mid grey to 64 times it, and how long each takes on a 600x600 image.

    python benchmarks/display_curves.py

Prints a Markdown table of codes (exact: the transforms are deterministic) and the median of
seven timings of each transform on one 600x600 image of random radiance (machine-dependent).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from renderer.display import DISPLAYS, to_display8  # noqa: E402

MID_GREY = 0.18
STOPS = (-8, -4, -2, -1, 0, 1, 2, 3, 4, 6)


def code_table() -> str:
    grey = np.array([MID_GREY * 2.0**s for s in STOPS])
    image = np.repeat(grey[None, :, None], 3, axis=2)
    rows = ["| radiance | " + " | ".join(f"`{name}`" for name in DISPLAYS) + " |",
            "|---|" + "---|" * len(DISPLAYS)]
    codes = {name: to_display8(image, name)[0, :, 0] for name in DISPLAYS}
    for i, (stop, value) in enumerate(zip(STOPS, grey)):
        label = f"0.18 x 2^{stop}" if stop else "mid grey"
        rows.append(f"| {value:.4g} ({label}) | " + " | ".join(str(codes[name][i]) for name in DISPLAYS) + " |")
    return "\n".join(rows)


def timings(repeats: int = 7) -> str:
    image = np.random.default_rng(0).exponential(0.5, (600, 600, 3))
    lines = []
    for name in DISPLAYS:
        seconds = []
        for _ in range(repeats):
            start = time.perf_counter()
            to_display8(image, name)
            seconds.append(time.perf_counter() - start)
        lines.append(f"- `{name}`: {1000 * float(np.median(seconds)):.1f} ms")
    return "\n".join(lines)


if __name__ == "__main__":
    print(code_table())
    print()
    print("600x600, median of 7:")
    print(timings())
