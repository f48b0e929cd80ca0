"""A grid medium in a box under a white sky, rendered by rt and by Mitsuba 3 (its `heterogeneous`
medium over a `gridvolume`, the `bench` extra), and what a grid medium costs:

    python benchmarks/mitsuba_grid_medium.py [--spp 64] [--runs 16] [--width 32]

The grid is scenes/smoke_plume.npz (40 x 64 x 40, 80% of it empty), stretched over the box
[-1, 1] x [-1.6, 1.6] x [-1, 1], trilinear in both (Mitsuba's grid texture holds its values at
cell centres and clamps at the edges, as ours does), density scale 10, albedo 0.8, isotropic
(`--g` for Henyey-Greenstein in both). The box has no surface in either (Mitsuba's `null` BSDF);
the sky is a constant radiance of 1 (Mitsuba's `constant` emitter, our solid background); the same
camera, depth (--depth, 64 by default: paths longer than that carry nothing measurable here),
box pixel filter and pixels. Each renderer runs `--runs` times with different seeds; printed: the
image means (RGB) over the pixels that see the box, their difference and its z-score (from the
spread of the runs), and the largest |z| over blocks of 4 x 4 pixels against the limit for that
many tests (Bonferroni at 0.001).

Then the costs, on rt alone, at the same samples (`costs`): scenes/smoke_plume.yaml without its
plume, with it, and with its majorant grid made one cell holding the largest density (a single
global majorant, as a renderer without a majorant grid would use), each the best of
`--cost-runs` timed renders after a warm-up (kernels compiled), with each image's relative noise
so that time at equal error can be read.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

LO, HI = (-1.0, -1.6, -1.0), (1.0, 1.6, 1.0)
DENSITY, ALBEDO = 10.0, 0.8
EYE, TARGET, FOV = (0.0, 0.0, 6.0), (0.0, 0.0, 0.0), 45.0
ROUNDING = 1e-6


def grid() -> np.ndarray:
    with np.load(ROOT / "scenes" / "smoke_plume.npz", allow_pickle=False) as archive:
        return np.asarray(archive["density"], np.float64)


def rt_scene(width: int, height: int, spp: int, depth: int, g: float) -> dict:
    phase = {"type": "henyey_greenstein", "g": g} if g else {"type": "isotropic"}
    return {
        "version": 1,
        "camera": {"look_from": list(EYE), "look_at": list(TARGET), "vfov": FOV},
        "image": {"width": width, "height": height, "samples_per_pixel": spp, "max_depth": depth},
        "background": [1.0, 1.0, 1.0],
        "media": {"smoke": {"type": "grid", "file": str(ROOT / "scenes" / "smoke_plume.npz"), "key": "density",
                            "bounds": [list(LO), list(HI)], "interpolation": "trilinear", "density": DENSITY,
                            "albedo": [ALBEDO] * 3, "phase": phase}},
        "shapes": [{"type": "box", "min": list(LO), "max": list(HI), "interior": "smoke"}],
    }


def mitsuba_scene(mi, width: int, height: int, spp: int, depth: int, g: float):
    values = grid()
    lo, hi = np.array(LO), np.array(HI)
    # Mitsuba's grid is indexed [z][y][x] (x fastest); ours [x][y][z].
    volume = mi.VolumeGrid(np.ascontiguousarray(np.transpose(values, (2, 1, 0))[..., None], np.float32))
    to_grid = mi.ScalarTransform4f().translate(lo.tolist()) @ mi.ScalarTransform4f().scale((hi - lo).tolist())
    phase = {"type": "hg", "g": g} if g else {"type": "isotropic"}
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": depth},
        "sensor": {"type": "perspective", "fov": FOV, "fov_axis": "y",
                   "to_world": mi.ScalarTransform4f().look_at(origin=list(EYE), target=list(TARGET), up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
        "box": {"type": "cube", "bsdf": {"type": "null"},
                "to_world": mi.ScalarTransform4f().translate(centre.tolist()) @ mi.ScalarTransform4f().scale(half.tolist()),
                "interior": {"type": "heterogeneous", "scale": DENSITY,
                             "albedo": {"type": "rgb", "value": [ALBEDO] * 3},
                             "sigma_t": {"type": "gridvolume", "grid": volume, "filter_type": "trilinear",
                                         "to_world": to_grid},
                             "phase": phase}},
    })


def box_pixels(width: int, height: int) -> np.ndarray:
    """Which pixels see the box (a mask): those whose ray through the pixel's centre meets it."""
    lo, hi = np.array(LO), np.array(HI)
    eye = np.array(EYE)
    j, i = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    half = np.tan(np.radians(FOV) / 2)
    aspect = width / height
    x = (2 * (i + 0.5) / width - 1) * half * aspect
    y = (1 - 2 * (j + 0.5) / height) * half
    d = np.stack([x, y, -np.ones_like(x)], axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - eye) / d, (hi - eye) / d
    near = np.minimum(t0, t1).max(axis=-1)
    far = np.maximum(t0, t1).min(axis=-1)
    return near < far


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, default=64)
    # Each block's standard error comes from the spread of the runs: with few runs it is itself so
    # uncertain that |z| (a t statistic) passes the normal limit by chance (at 4 runs, 5 of 288 blocks).
    parser.add_argument("--runs", type=int, default=16)
    parser.add_argument("--width", type=int, default=32)
    parser.add_argument("--depth", type=int, default=64)
    parser.add_argument("--g", type=float, default=0.0)
    parser.add_argument("--skip-mitsuba", action="store_true")
    parser.add_argument("--cost-width", type=int, default=96)
    parser.add_argument("--cost-spp", type=int, default=32)
    parser.add_argument("--cost-runs", type=int, default=3)
    args = parser.parse_args()
    width, height = args.width, int(round(args.width * 1.5))

    import rt
    from tests.renderer.stats import z_limit

    mask = box_pixels(width, height)
    ours = [rt.render(rt_scene(width, height, args.spp, args.depth, args.g), seed=100 + r, kernel="general",
                      adaptive=False, allow_paths=[ROOT / "scenes"]).array.astype(np.float64) for r in range(args.runs)]
    if not args.skip_mitsuba:
        import mitsuba as mi

        from mitsuba_scene import set_variant

        variant = set_variant()
        scene = mitsuba_scene(mi, width, height, args.spp, args.depth, args.g)
        t0 = time.perf_counter()
        theirs = [np.array(mi.render(scene, spp=args.spp, seed=200 + r), np.float64)[..., :3] for r in range(args.runs)]
        mitsuba_seconds = (time.perf_counter() - t0) / args.runs
        print(f"{width}x{height}, {args.spp} spp x {args.runs} runs each, depth {args.depth}, g {args.g}; Mitsuba {mi.__version__} "
              f"{variant} ({mitsuba_seconds:.1f} s a run)")
        a, b = np.array(ours), np.array(theirs)
        ma, mb = a[:, mask].mean(axis=(0, 1)), b[:, mask].mean(axis=(0, 1))
        sa = a[:, mask].mean(axis=1).std(axis=0, ddof=1) / np.sqrt(args.runs)
        sb = b[:, mask].mean(axis=1).std(axis=0, ddof=1) / np.sqrt(args.runs)
        z = (ma - mb) / np.sqrt(sa ** 2 + sb ** 2)
        print(f"  box pixels ({mask.sum()}): rt {np.round(ma, 5)}  Mitsuba {np.round(mb, 5)}  "
              f"difference {np.round((ma - mb) / mb * 100, 3)}%  z {np.round(z, 2)}")
        block = 4
        hb, wb = height // block, width // block

        def blocks(stack):
            return stack[:, :hb * block, :wb * block].reshape(len(stack), hb, block, wb, block, 3).mean(axis=(2, 4))
        ba, bb = blocks(a), blocks(b)
        # The runs' spread, and float32's rounding as a floor: a block of sky is 1 in every run of
        # one renderer and 1 - 6e-8 in the other's, which is no difference of the estimators.
        se = np.sqrt(ba.var(axis=0, ddof=1) / args.runs + bb.var(axis=0, ddof=1) / args.runs + ROUNDING ** 2)
        zb = (ba.mean(axis=0) - bb.mean(axis=0)) / se
        print(f"  blocks of {block}x{block}: largest |z| {np.abs(zb).max():.2f} of {zb.size} "
              f"(limit {z_limit(zb.size):.2f} at 0.001 family-wise)")

    costs(args)


def costs(args) -> None:
    """What the grid medium costs, on rt alone, at the same samples: scenes/smoke_plume.yaml at
    --cost-width, without its plume, with it, and with its majorant grid made one cell holding the
    largest density (a single global majorant, as a renderer without a majorant grid would use);
    each the best of --runs timed renders after a warm-up, with the image's relative noise."""
    import rt
    from renderer.compile import compile_scene, with_width
    from renderer.grid_media import F_BLOCKS, F_MAJORANT, F_MAJORANTS, FIELD_F, ROW
    from renderer.media import MEDIUM_FIELD
    from renderer.render import render
    from renderer.shapes import MEDIUM, PRIM_KIND

    def timed(graph, flat_change=None):
        flat = compile_scene(graph)
        if flat_change:
            flat_change(flat)
        render(graph, flat=flat, samples=1, seed=1, kernel="general")  # warm-up: the kernel compiled and loaded
        best, noise = np.inf, 0.0
        for r in range(args.cost_runs):
            result = render(graph, flat=flat, samples=args.cost_spp, seed=10 + r, kernel="general")
            if result.stats.seconds < best:
                best = result.stats.seconds
                film = result.film
                mean = film.mean()
                var = np.maximum(film.total_sq / film.samples - mean ** 2, 0.0) / (film.samples - 1)
                noise = float(np.sqrt(var.mean()) / mean.mean())
        return best, noise

    def one_majorant(flat):
        rows = np.nonzero(flat.prims_i[:len(flat.prims_f), PRIM_KIND] == MEDIUM)[0]
        h = int(flat.prims_f[rows[0], MEDIUM_FIELD]) - 1
        header = flat.bnd_f[h:h + FIELD_F.width // ROW].ravel().copy()
        first = int(header[F_MAJORANTS])
        header[F_BLOCKS:F_BLOCKS + 3] = 1
        flat.bnd_f[h:h + FIELD_F.width // ROW] = header.reshape(-1, ROW)
        flat.bnd_f[first, 0] = header[F_MAJORANT]

    path = ROOT / "scenes" / "smoke_plume.yaml"
    loaded = rt.load(path)
    graph = with_width(loaded.graph, args.cost_width)
    bare = loaded.scene.model_copy(update={"shapes": loaded.scene.shapes[:-1], "media": {}})
    bare_graph = with_width(rt.load(bare, allow_paths=[ROOT / "scenes"]).graph, args.cost_width)
    without, noise_without = timed(bare_graph)
    with_grid, noise_grid = timed(graph)
    single, noise_single = timed(graph, one_majorant)
    size = f"{graph.image.width}x{graph.image.pixel_height}"
    print(f"smoke_plume.yaml at {size}, {args.cost_spp} spp, best of {args.cost_runs} (general kernel): "
          f"without the plume {without:.2f} s (noise {noise_without:.2%}); with it {with_grid:.2f} s "
          f"(noise {noise_grid:.2%}), {with_grid / without:.2f} times; one global majorant {single:.2f} s "
          f"(noise {noise_single:.2%}): the majorant grid takes {with_grid / single:.2f} of that time")


if __name__ == "__main__":
    main()
