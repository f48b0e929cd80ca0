"""Warm-process figures (issue 22's targets), printed:

1. `rt.render` of the Cornell box at 64 pixels wide (64x64) in a warm process: the median of
   several calls after a first one that loads the kernels. Target: at most 0.3 s.
2. `rt watch` of the Cornell box: the time from saving a changed file to the first updated image
   on the page's event stream, and to the first full-size one, with the kernels warm, measured by
   a client of the page (the event's arrival and the image's download). Target: at most 1 s.

    python benchmarks/warm.py [--spp N] [--repeats N]
"""

from __future__ import annotations

import argparse
import http.client
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import rt  # noqa: E402
from rt.watch import Watch, WatchOptions  # noqa: E402
from tests.test_watch import Events, save  # noqa: E402

CORNELL = ROOT / "scenes" / "cornell_box.yaml"


def warm_api(spp: int, repeats: int) -> list[float]:
    rt.render(CORNELL, spp=spp, width=64)  # loads the kernels
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        img = rt.render(CORNELL, spp=spp, width=64)
        times.append(time.perf_counter() - t0)
    assert img.array.shape == (64, 64, 3)
    return times


def watch_latency(repeats: int) -> tuple[list[float], list[float]]:
    folder = Path(tempfile.mkdtemp(prefix="rt-warm-"))
    scene = folder / "cornell_box.yaml"
    shutil.copy(CORNELL, scene)
    text = scene.read_text()
    watch = Watch(WatchOptions(scene), port=0, say=lambda m: None).start()
    first, full = [], []
    try:
        events = Events(watch.port)
        events.until(lambda n, d: n == "image" and d["stage"] == "render")  # kernels warm, a render under way
        for i in range(repeats):
            changed = text.replace("[0.65, 0.05, 0.05]", f"[0.65, 0.05, {0.05 + 0.1 * (i % 5 + 1):.2f}]")
            t0 = time.perf_counter()
            save(scene, changed)
            data, _ = events.until(lambda n, d: n == "image" and d["version"] and d["save_to_image"] is not None)
            conn = http.client.HTTPConnection("127.0.0.1", watch.port)
            conn.request("GET", f"/image.png?v={data['version']}")
            assert conn.getresponse().read()[:4] == b"\x89PNG"
            first.append(time.perf_counter() - t0)
            events.until(lambda n, d: n == "image" and d["stage"] == "render")
            full.append(time.perf_counter() - t0)
            time.sleep(0.5)
        events.close()
    finally:
        watch.close()
        shutil.rmtree(folder, ignore_errors=True)
    return first, full


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--spp", type=int, default=16, help="samples per pixel of the 64-pixel API render")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    api = warm_api(args.spp, args.repeats)
    print(f"warm rt.render, Cornell box 64x64 at {args.spp} spp: median {statistics.median(api):.3f} s "
          f"(min {min(api):.3f}, max {max(api):.3f}, {len(api)} calls; target 0.3 s)")
    first, full = watch_latency(args.repeats)
    print(f"rt watch, Cornell box 600x600: save -> first updated image (the 150x150 first pass) median "
          f"{statistics.median(first):.3f} s (max {max(first):.3f}); -> first full-size image median "
          f"{statistics.median(full):.3f} s (max {max(full):.3f}), {len(first)} saves; target 1 s")


if __name__ == "__main__":
    main()
