"""Our sun and sky against Mitsuba 3's `sunsky` emitter (an independent implementation of the
same Hosek-Wilkie sky, and of Hosek and Wilkie's solar model), for tests/renderer/test_sky_model.py.

    python benchmarks/mitsuba_sky.py           # print the table the test keeps (MITSUBA_SKY, MITSUBA_SUN)
    python benchmarks/mitsuba_sky.py --check   # compare ours against Mitsuba now, and print the ratios

Mitsuba's frame has +z up; ours +y: a direction (x, y, z) of ours is (x, z, y) in Mitsuba's (a
mirror, which the sky, symmetric about the sun's vertical plane, does not see). Mitsuba's RGB
radiance is a spectral mean, W/(m^2 sr nm): ours (the model's, sky.py) is the spectrum integrated
against the CIE observer, so Mitsuba's times the integral of y-bar (106.86 nm) is ours. Needs
`pip install mitsuba` (the `bench` extra); its scalar RGB variant is enough.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

# (elevation degrees, turbidity, albedo) of the sky cases, and the directions (ours: +y up, the sun
# toward -z turned up by its elevation) each is looked up in.
SKY_CASES = [(5.0, 2.0, 0.0), (20.0, 3.0, 0.3), (45.0, 3.0, 0.3), (70.0, 6.0, 0.5), (35.0, 9.5, 1.0)]
DIRECTIONS = [(0.0, 1.0, 0.0), (0.3, 0.5, -0.8), (-0.5, 0.2, 0.6), (0.05, 0.02, -1.0), (0.9, 0.1, 0.1), (0.0, 0.4, 1.0)]
SUN_CASES = [(90.0, 2.0), (60.0, 3.0), (45.0, 2.0), (30.0, 3.0), (10.0, 3.0), (60.0, 6.0)]
SUN_DIAMETER = 0.5332


def sun_toward(elevation: float) -> np.ndarray:
    el = math.radians(elevation)
    return np.array([0.0, math.sin(el), -math.cos(el)])


def mitsuba_emitter(elevation: float, turbidity: float, albedo: float, sky: bool):
    import mitsuba as mi

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    s = sun_toward(elevation)
    return mi.load_dict({"type": "sunsky", "sun_direction": [float(s[0]), float(s[2]), float(s[1])], "turbidity": turbidity,
                         "albedo": albedo, "sun_scale": 0.0 if sky else 1.0, "sky_scale": 1.0 if sky else 0.0,
                         "sun_aperture": SUN_DIAMETER})


def mitsuba_radiance(emitter, d) -> np.ndarray:
    import mitsuba as mi

    d = np.asarray(d, np.float64) / np.linalg.norm(d)
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(float(-d[0]), float(-d[2]), float(-d[1]))
    return np.array(emitter.eval(si), np.float64)


def mitsuba_sky_table() -> list:
    rows = []
    for elevation, turbidity, albedo in SKY_CASES:
        emitter = mitsuba_emitter(elevation, turbidity, albedo, sky=True)
        rows.append([[float(v) for v in mitsuba_radiance(emitter, d)] for d in DIRECTIONS])
    return rows


def mitsuba_sun_table(points: int = 256) -> list:
    """Mitsuba's sun: its radiance averaged over the disc (it darkens toward the limb), at
    `points` directions spread evenly over the disc by area (a Fibonacci spiral)."""
    rows = []
    radius = math.radians(0.5 * SUN_DIAMETER) * 0.999
    for elevation, turbidity in SUN_CASES:
        emitter = mitsuba_emitter(elevation, turbidity, 0.3, sky=False)
        s = sun_toward(elevation)
        e1 = np.array([1.0, 0.0, 0.0])
        e2 = np.cross(s, e1)
        total = np.zeros(3)
        for k in range(points):
            r = radius * math.sqrt((k + 0.5) / points)
            phi = 2.399963229728653 * k
            total += mitsuba_radiance(emitter, s * math.cos(r) + math.sin(r) * (math.cos(phi) * e1 + math.sin(phi) * e2))
        rows.append([float(v) for v in total / points])
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare ours against Mitsuba and print the ratios")
    args = parser.parse_args(argv)
    sky_rows, sun_rows = mitsuba_sky_table(), mitsuba_sun_table()
    if not args.check:
        print("MITSUBA_SKY = [")
        for row in sky_rows:
            print("    [" + ", ".join("(" + ", ".join(f"{v:.7g}" for v in rgb) + ")" for rgb in row) + "],")
        print("]")
        print("MITSUBA_SUN = [" + ", ".join("(" + ", ".join(f"{v:.7g}" for v in rgb) + ")" for rgb in sun_rows) + "]")
        return 0
    from renderer import sky

    for (elevation, turbidity, albedo), row in zip(SKY_CASES, sky_rows):
        s = sun_toward(elevation)
        d = np.array(DIRECTIONS) / np.linalg.norm(DIRECTIONS, axis=1)[:, None]
        ours = sky.radiance(d[:, 1], d @ s, math.radians(elevation), turbidity, albedo)
        print(f"sky elevation {elevation:g} turbidity {turbidity:g} albedo {albedo:g}: ours / Mitsuba's",
              np.array2string(ours / np.array(row), precision=6))
    for (elevation, turbidity), rgb in zip(SUN_CASES, sun_rows):
        ours = sky.disc_radiance(math.radians(elevation), turbidity)
        print(f"sun elevation {elevation:g} turbidity {turbidity:g}: ours / Mitsuba's", np.array2string(ours / np.array(rgb), precision=4))
    return 0


if __name__ == "__main__":
    sys.exit(main())
