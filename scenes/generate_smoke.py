"""Write the density grid of scenes/smoke_plume.yaml: a plume of smoke rising from a vent, as an .npz.

    python scenes/generate_smoke.py           # rewrite scenes/smoke_plume.npz
    python scenes/generate_smoke.py --check   # exit 1 if the committed grid differs from what would be written
                                              # (beyond 1e-5: libm's last bits vary between machines)

Nothing is simulated or downloaded: the plume is a formula on a 40 x 64 x 40 grid (x, y up, z;
float32 under the key `density`), the same on every machine (numpy in float64, a fixed seed for
PCG64, rounded to float32 once):

- a column whose centre line rises from the vent at the bottom and drifts to one side and back
  as it climbs (two slow sine waves), its radius growing from 0.08 to 0.32 of the box's width;
- across the column a Gaussian profile, so the smoke thins toward its edge, and along it a
  density that fades in over the first tenth and out over the top fifth;
- curling wisps: the profile is modulated by a sum of 24 random plane waves (fixed seed), whose
  crests cut the column into billows and leave gaps; values below 0.02 are cut to 0, so most of
  the box is empty, which the renderer's majorant grid crosses at no cost.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SHAPE = (40, 64, 40)
SEED = 36
WAVES = 24
CUT = 0.02


def plume() -> np.ndarray:
    """(40, 64, 40) float32 densities in [0, 1], cell [i, j, k] at x = (i + 0.5) / 40, y = (j + 0.5) / 64, z ..."""
    nx, ny, nz = SHAPE
    x, y, z = np.meshgrid((np.arange(nx) + 0.5) / nx, (np.arange(ny) + 0.5) / ny, (np.arange(nz) + 0.5) / nz, indexing="ij")
    cx = 0.5 + 0.12 * np.sin(2.4 * y + 0.3) * y
    cz = 0.5 + 0.08 * np.sin(3.7 * y + 1.1) * y
    radius = 0.08 + 0.24 * y
    r2 = ((x - cx) ** 2 + (z - cz) ** 2) / radius ** 2
    profile = np.exp(-2.0 * r2)
    rng = np.random.default_rng(SEED)
    directions = rng.normal(size=(WAVES, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    frequencies = rng.uniform(6.0, 18.0, WAVES)
    phases = rng.uniform(0.0, 2.0 * np.pi, WAVES)
    weights = 1.0 / frequencies
    waves = np.zeros(SHAPE)
    for d, f, p, w in zip(directions, frequencies, phases, weights):
        waves += w * np.sin(f * (d[0] * x + d[1] * 1.6 * y + d[2] * z) + p)
    waves /= weights.sum() * 0.5
    billows = np.clip(0.6 + 0.9 * waves, 0.0, None)
    fade = np.clip(y / 0.1, 0.0, 1.0) * np.clip((1.0 - y) / 0.2, 0.0, 1.0)
    density = profile * billows * fade
    density /= density.max()
    # The faint halo is cut to nothing: outside the column the grid is empty, as a simulation's is.
    density[density < CUT] = 0.0
    return density.astype(np.float32)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if scenes/smoke_plume.npz differs from what would be written")
    parser.add_argument("--out", type=Path, default=HERE / "smoke_plume.npz")
    args = parser.parse_args(argv)
    grid = plume()
    if args.check:
        try:
            with np.load(args.out, allow_pickle=False) as archive:
                committed = archive["density"]
        except (OSError, KeyError, ValueError):
            committed = None
        same = committed is not None and committed.shape == grid.shape and np.allclose(committed, grid, rtol=1e-5, atol=1e-6)
        print(f"{args.out.name}: {'up to date' if same else 'differs from what generate_smoke.py writes'}")
        return 0 if same else 1
    np.savez_compressed(args.out, density=grid)
    print(f"wrote {args.out} ({'x'.join(map(str, SHAPE))}, {args.out.stat().st_size:,} bytes, "
          f"{np.mean(grid == 0):.0%} of the cells empty)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
