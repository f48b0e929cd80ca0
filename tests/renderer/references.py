"""Reference renders of every book scene for the regression test, and the statistics that compare them.

A reference keeps, for each 4x4 block of a 48-pixel-wide render with 4096 samples per pixel,
the mean and the variance of single samples (float64, so rounding never looks like a change).

Run `python tests/renderer/references.py` to (re)write tests/renderer/references/*.npz after a
change that is meant to alter images, or `python tests/renderer/references.py STEM...` (e.g.
`weekend_glass`) to rewrite only the scenes a change affects; commit the files with a note on
why they changed.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
REF_DIR = Path(__file__).resolve().parent / "references"
WIDTH = 48
REF_SPP = 4096
REF_SEED = 1
BLOCK = 4  # pixels per side of the blocks whose means are compared


def scene_files() -> list[Path]:
    return sorted(SCENES.glob("*.yaml")) + sorted(SCENES.glob("*.json"))


def render_small(path: Path, spp: int, seed: int):
    from renderer.compile import with_width
    from renderer.render import render
    from scenefmt.validation import load

    graph = with_width(load(path).graph, WIDTH)
    return render(graph, samples=spp, seed=seed)


def block_stats(total: np.ndarray, total_sq: np.ndarray, spp: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Per-block mean and variance of single samples, and the number of samples per block."""
    h, w, _ = total.shape
    hb, wb = h // BLOCK, w // BLOCK
    s = total[: hb * BLOCK, : wb * BLOCK].reshape(hb, BLOCK, wb, BLOCK, 3).sum(axis=(1, 3))
    s2 = total_sq[: hb * BLOCK, : wb * BLOCK].reshape(hb, BLOCK, wb, BLOCK, 3).sum(axis=(1, 3))
    n = BLOCK * BLOCK * spp
    mean = s / n
    var = np.maximum(s2 / n - mean * mean, 0.0)
    return mean, var, n


def main(stems: list[str]) -> int:
    REF_DIR.mkdir(exist_ok=True)
    paths = scene_files()
    if stems:
        unknown = sorted(set(stems) - {p.stem for p in paths})
        if unknown:
            print(f"no scene named {', '.join(unknown)} in {SCENES}", file=sys.stderr)
            return 1
        paths = [p for p in paths if p.stem in stems]
    else:
        for old in REF_DIR.glob("*.npz"):
            old.unlink()
    for path in paths:
        result = render_small(path, REF_SPP, REF_SEED)
        film = result.film
        mean, var, n = block_stats(film.total, film.total_sq, film.samples)
        out = REF_DIR / f"{path.stem}.npz"
        np.savez_compressed(out, mean=mean, var=var, n=n, shape=np.array(film.total.shape))
        print(f"{out.relative_to(ROOT)}: {film.width}x{film.height}, {REF_SPP} spp, {result.stats.seconds:.1f}s")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main(sys.argv[1:]))
