"""Write the project's environment map: a clear sky with a sun, equirectangular, as a PFM file.

    python scenes/generate_sky.py           # rewrite scenes/sky.pfm
    python scenes/generate_sky.py --check   # exit 1 if the committed file differs from what would be written
                                            # (beyond 1e-5 relative: libm's last bits vary between machines)

Nothing is measured or downloaded: the sky is a formula, the same on every machine (numpy in
float64, rounded to float32 once). The mapping is the format's (scenefmt.scene.ImageBackground):
the top row is straight up, u = 1/2 looks toward -z, u = 3/4 toward +x.

- the sky above the horizon blends a deep blue at the zenith into a pale haze at the horizon,
  brighter toward the sun (a broad glow about it), at radiances near 1;
- the sun is a disk 2.5 degrees in radius (a few texels of the 256 x 128 map, where one texel
  is 1.4 degrees across) of radiance 900, warm white, 35 degrees above the horizon at u = 0.6;
  it sends about twice the light the whole sky sends onto a level surface (3.3 against 1.6);
- below the horizon, a dim brown ground that darkens toward the nadir.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
try:
    import scenefmt  # noqa: F401
except ImportError:  # run from a checkout without the package installed
    sys.path.insert(0, str(HERE.parent))

from renderer.film import write_pfm  # noqa: E402
from scenefmt.hdr_files import HdrProblem, read_hdr  # noqa: E402

WIDTH, HEIGHT = 256, 128
SUN_ELEVATION = math.radians(35.0)
SUN_U = 0.6
SUN_RADIUS = math.radians(2.5)
SUN_RADIANCE = np.array([1.0, 0.93, 0.82]) * 900.0
ZENITH = np.array([0.12, 0.25, 0.62])
HORIZON = np.array([0.75, 0.82, 0.92])
GROUND = np.array([0.16, 0.12, 0.09])


def direction(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The format's equirectangular mapping: theta = pi v from +y, phi = 2 pi u."""
    theta, phi = np.pi * v, 2.0 * np.pi * u
    return np.stack([-np.sin(theta) * np.sin(phi), np.cos(theta), np.sin(theta) * np.cos(phi)], axis=-1)


def sky() -> np.ndarray:
    """(HEIGHT, WIDTH, 3) float32 linear radiance, row 0 at the top."""
    v, u = np.meshgrid((np.arange(HEIGHT) + 0.5) / HEIGHT, (np.arange(WIDTH) + 0.5) / WIDTH, indexing="ij")
    d = direction(u, v)
    sun = direction(np.array(SUN_U), np.array(0.5 - SUN_ELEVATION / np.pi))
    cos_sun = np.clip(d @ sun, -1.0, 1.0)
    up = d[..., 1]
    # Above the horizon: zenith to haze by height, and a glow about the sun.
    t = np.clip(up, 0.0, 1.0) ** 0.5
    above = (1.0 - t)[..., None] * HORIZON + t[..., None] * ZENITH
    glow = 1.0 + 2.5 * np.exp((cos_sun - 1.0) / 0.05) + 0.6 * np.exp((cos_sun - 1.0) / 0.5)
    above = above * glow[..., None]
    # Below: the ground, darkest straight down.
    below = GROUND * (0.6 + 0.4 * (1.0 + np.clip(up, -1.0, 0.0)))[..., None]
    image = np.where((up >= 0.0)[..., None], above, below)
    disk = np.arccos(cos_sun) <= SUN_RADIUS
    image[disk] = SUN_RADIANCE
    return image.astype(np.float32)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if scenes/sky.pfm differs from what would be written")
    parser.add_argument("--out", type=Path, default=HERE / "sky.pfm")
    args = parser.parse_args(argv)
    image = sky()
    if args.check:
        try:  # read as a scene reads it
            committed = read_hdr(args.out, WIDTH * HEIGHT)
        except HdrProblem:
            committed = None
        same = committed is not None and committed.shape == image.shape and np.allclose(committed, image, rtol=1e-5, atol=0.0)
        print(f"{args.out.name}: {'up to date' if same else 'differs from what generate_sky.py writes'}")
        return 0 if same else 1
    write_pfm(args.out, image)  # little-endian float32, rows bottom to top
    print(f"wrote {args.out} ({WIDTH} x {HEIGHT}, {args.out.stat().st_size:,} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
