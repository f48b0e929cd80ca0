"""How far rt's `aces` display transform (Hill's fit) is from the reference ACES 1.0 transforms as
OpenColorIO applies them: the figures in docs/display.md.

    pip install opencolorio        # a measuring tool only: rt itself does not use it
    python benchmarks/display_vs_ocio.py

The reference is OpenColorIO's built-in configuration cg-config-v2.2.0 (ACES 1.3), view "ACES 1.0 -
SDR Video" of display "sRGB - Display", from "Linear Rec.709 (sRGB)": the Academy's RRT and sRGB
output transform. Both sides are rounded to 8-bit codes the same way (display.to_code8).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from renderer.display import aces, srgb, to_code8  # noqa: E402

CONFIG = "ocio://cg-config-v2.2.0_aces-v1.3_ocio-v2.4"


def reference():
    """The reference transform as a function of linear images, (..., 3) -> uint8."""
    import PyOpenColorIO as ocio

    config = ocio.Config.CreateFromFile(CONFIG)
    view = ocio.DisplayViewTransform(src="Linear Rec.709 (sRGB)", display="sRGB - Display", view="ACES 1.0 - SDR Video")
    cpu = config.getProcessor(view).getDefaultCPUProcessor()

    def apply(linear: np.ndarray) -> np.ndarray:
        flat = np.ascontiguousarray(linear.reshape(-1, 3), dtype=np.float32)
        cpu.applyRGB(flat)
        return to_code8(flat).reshape(linear.shape)

    return apply


def main() -> int:
    try:
        ref = reference()
    except ImportError:
        print("this measurement needs OpenColorIO's Python bindings: pip install opencolorio (rt does not use them)")
        return 1
    grey = np.geomspace(2.0**-10, 2.0**8, 1000)
    g = np.repeat(grey[:, None], 3, axis=1)[None]
    d = np.abs(aces(g).astype(int) - ref(g).astype(int))[0, :, 0]
    print(f"grey from 2^-10 to 2^8 (1000 values): largest difference {d.max()} codes, mean {d.mean():.2f}")
    colours = np.random.default_rng(0).exponential(0.4, (1, 200_000, 3))
    worst = np.abs(aces(colours).astype(int) - ref(colours).astype(int)).max(axis=2)
    print(f"random colours (each channel exponential, mean 0.4; 200,000): per pixel largest channel difference "
          f"mean {worst.mean():.2f}, 99th percentile {np.percentile(worst, 99):.0f}, largest {worst.max()} codes; "
          f"{100 * np.mean(worst <= 3):.0f}% within 3 codes")
    plain = np.abs(srgb(colours).astype(int) - ref(colours).astype(int)).max(axis=2)
    print(f"for scale, srgb (no tone curve) against the same reference: mean {plain.mean():.2f} codes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
