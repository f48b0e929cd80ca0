"""Render every scene in scenes/ for docs/gallery.md (run by hand; the PNGs are committed).

    python docs/gallery.py [NAME ...]

With names (stems of scenes/ files), only those scenes are rendered; the other rows of
docs/gallery.md are kept as they are (a scene with no row yet gets one when it is named). Each
scene is rendered at a small width with enough samples for the book's image to be recognisable;
the table records the settings and the time each took on this machine.
"""

from __future__ import annotations

import platform
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "gallery"
WIDTH = 256
# Samples per pixel: more where the light is small or the scene is mostly indirect.
SPP = {"cornell_box": 512, "cornell_knot": 512, "cornell_smoke": 256, "final_scene": 512, "simple_light": 256,
       "cornell_conductor": 512, "cornell_plastic": 512, "cornell_principled": 512, "cornell_rough_glass": 1024, "cornell_spot": 256,
       "motion_knot": 512, "smoke_plume": 256, "still_life": 512}
DEFAULT_SPP = 128


def kept_rows(names: set) -> dict:
    """The rows of the current docs/gallery.md, by scene stem, except those of `names`."""
    page = ROOT / "docs" / "gallery.md"
    rows = {}
    if page.exists():
        for line in page.read_text().splitlines():
            if line.startswith("| `"):
                stem = line.split("`")[1].rsplit(".", 1)[0]
                if stem not in names:
                    rows[stem] = line
    return rows


def main(argv=None) -> int:
    names = set(sys.argv[1:] if argv is None else argv)
    sys.path.insert(0, str(ROOT))
    from renderer.film import write_png
    from renderer.compile import with_width
    from renderer.render import render
    from scenefmt.validation import load

    OUT.mkdir(exist_ok=True)
    rows = []
    kept = kept_rows(names) if names else {}
    scenes = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))
    for path in scenes:
        if names and path.stem not in names:
            if path.stem in kept:
                rows.append(kept[path.stem])
            continue
        loaded = load(path)
        graph = with_width(loaded.graph, WIDTH)
        spp = SPP.get(path.stem, DEFAULT_SPP)
        result = render(graph, samples=spp)
        write_png(OUT / f"{path.stem}.png", result.film.mean())
        stats = result.stats
        rows.append(
            f"| `{path.name}` | ![{path.stem}](gallery/{path.stem}.png) | {graph.image.width}x{graph.image.pixel_height}, "
            f"{spp} spp, depth {graph.image.max_depth} | {stats.seconds:.1f} s, {stats.rays_per_second / 1e6:.1f} Mrays/s |"
        )
        print(rows[-1].split("|")[1], f"{stats.seconds:.1f}s", flush=True)
    text = [
        "# Gallery",
        "",
        "<!-- Written by `python docs/gallery.py`; the images are committed. -->",
        "",
        "Every scene in `scenes/`, rendered with `rt`'s path tracer at a small size. The samples per pixel",
        "are enough for the book's image to be recognisable, not for a clean picture: `rt render",
        "scenes/NAME.yaml` renders at the scene's own (the books') settings.",
        "",
        f"Rendered on {platform.machine()} with 2 threads; times are rendering only (kernels already compiled).",
        "",
        "| scene | image | settings | time |",
        "|---|---|---|---|",
        *rows,
        "",
    ]
    (ROOT / "docs" / "gallery.md").write_text("\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
