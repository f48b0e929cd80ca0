"""Fingerprints of rendered images: proof that a refactor changed no image, bit for bit.

    python benchmarks/fingerprints.py > before.json      # on the old code
    python benchmarks/fingerprints.py --check before.json  # on the new: every line must match

Every shipped scene and the scenes in benchmarks/fingerprint_scenes/ (an environment map beside
lamps of every shape, some under instance transforms; a lit medium) is rendered small, with
both integrators and with both the general and the specialised kernel, and the SHA-256 of its
film's sums (and sums of squares) printed. Bits depend on the processor and the Numba version,
so fingerprints are compared on one machine, before and after, never kept in the repository.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from renderer.compile import compile_scene, with_width  # noqa: E402
from renderer.flat import Frame  # noqa: E402
from renderer.render import render_flat  # noqa: E402
from renderer.variants import GENERAL, features_of  # noqa: E402
from scenefmt.validation import load  # noqa: E402

WIDTH, SAMPLES, DEPTH = 32, 4, 12


def scene_files() -> list[Path]:
    shipped = sorted((ROOT / "scenes").glob("*.yaml")) + sorted((ROOT / "scenes").glob("*.json"))
    return shipped + sorted((ROOT / "benchmarks" / "fingerprint_scenes").glob("*.yaml"))


def digest(film) -> str:
    h = hashlib.sha256()
    h.update(film.total.tobytes())
    h.update(film.total_sq.tobytes())
    return h.hexdigest()[:24]


def fingerprints(stems: list[str]) -> dict[str, str]:
    out = {}
    for path in scene_files():
        if stems and path.stem not in stems:
            continue
        graph = with_width(load(path, allow_paths=[ROOT / "scenes"]).graph, WIDTH)
        flat = compile_scene(graph)
        needed = features_of(graph)
        for integrator in ("path", "mis"):
            frame = Frame.of(graph)._replace(integrator=integrator)
            for name, features in (("general", GENERAL), ("specialised", needed)):
                result = render_flat(flat, frame, samples=SAMPLES, max_depth=DEPTH, seed=7, needed=needed, features=features)
                key = f"{path.stem}/{integrator}/{name}"
                out[key] = digest(result.film)
                print(f"{key}: {out[key]}", file=sys.stderr, flush=True)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", type=Path, help="fingerprints written before: report every difference")
    parser.add_argument("stems", nargs="*", help="only these scenes (file names without suffix)")
    args = parser.parse_args()
    now = fingerprints(args.stems)
    if args.check is None:
        print(json.dumps(now, indent=1, sort_keys=True))
        return 0
    before = json.loads(args.check.read_text())
    changed = [k for k in now if before.get(k) != now[k]]
    for k in changed:
        print(f"CHANGED {k}: {before.get(k)} -> {now[k]}")
    print(f"{len(now) - len(changed)} of {len(now)} images unchanged, bit for bit")
    return 1 if changed else 0


if __name__ == "__main__":
    raise SystemExit(main())
