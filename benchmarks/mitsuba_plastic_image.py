"""Image means of a plastic sphere under a uniform white sky, rendered by rt and by Mitsuba 3
(scalar_rgb, the `bench` extra): `python benchmarks/mitsuba_plastic_image.py [--runs 6]`.

One sphere fills most of a 32 x 32 image seen from 3 radii away (the same camera in both, box
pixel filter); each renderer runs `--runs` times with different seeds, and the table gives each
image mean (RGB), their relative difference and its z-score (difference over the standard error
of the two means, from the spread of the runs). Expected, and printed beside it: the smooth coat
0.11% darker here (Mitsuba's fit of the internal reflectance, see docs/materials.md), the rough
coat brighter by what Mitsuba's averaging rule takes from its internal reflectance; the last
column puts that rule back into rt's rough images (the base's part, found as the image less the
same image with a black base, scaled by (1 - R_rt) / (1 - R_mitsuba)).
"""

from __future__ import annotations

import argparse

import numpy as np

WIDTH, SPP, DEPTH = 32, 512, 8
ALBEDO = [0.7, 0.4, 0.2]
IOR = 1.5


def mitsuba_scene(mi, bsdf):
    return mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": DEPTH},
        "sensor": {"type": "perspective", "fov": 30, "fov_axis": "y",
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 3], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": WIDTH, "height": WIDTH, "rfilter": {"type": "box"},
                            "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": SPP}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1, 1, 1]}},
        "ball": {"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "bsdf": bsdf},
    })


def rt_scene(material):
    return {"version": 1, "camera": {"look_from": [0, 0, 3], "look_at": [0, 0, 0], "vfov": 30},
            "image": {"width": WIDTH, "height": WIDTH, "samples_per_pixel": SPP, "max_depth": DEPTH, "seed": 1},
            "background": [1.0, 1.0, 1.0], "materials": {"m": material},
            "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "material": "m"}]}


def cases():
    """(name, Mitsuba's BSDF, rt's material, alpha or 0)."""
    base = {"diffuse_reflectance": {"type": "rgb", "value": ALBEDO}, "int_ior": IOR, "ext_ior": 1.0}
    yield "smooth", {"type": "plastic", **base}, {"type": "plastic", "albedo": ALBEDO, "ior": IOR}, 0.0
    yield ("smooth, nonlinear", {"type": "plastic", "nonlinear": True, **base},
           {"type": "plastic", "albedo": ALBEDO, "ior": IOR, "nonlinear": True}, 0.0)
    for alpha in (0.1, 0.3):
        yield (f"rough, alpha {alpha}", {"type": "roughplastic", "distribution": "ggx", "alpha": alpha, **base},
               {"type": "plastic", "albedo": ALBEDO, "ior": IOR, "alpha": alpha, "shadowing": "separable"}, alpha)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=6)
    runs = parser.parse_args().runs
    import mitsuba as mi

    import rt
    from renderer.materials import coat, coat_tables

    mi.set_variant("scalar_rgb")

    def mean(image):
        return np.asarray(image, dtype=float).reshape(-1, 3).mean(axis=0)

    def compare(a, b):
        d = b.mean(0) - a.mean(0)
        se = np.sqrt(a.var(0, ddof=1) / runs + b.var(0, ddof=1) / runs)
        return d / a.mean(0), d / se

    print(f"{'case':20} {'Mitsuba mean':26} {'rt mean':26} {'rt / Mitsuba - 1':26} {'z':20} with Mitsuba's R_in")
    for name, bsdf, material, alpha in cases():
        theirs = np.array([mean(mi.render(mitsuba_scene(mi, bsdf), seed=k)) for k in range(runs)])
        ours = np.array([mean(rt.render(rt_scene(material), seed=100 + k).array) for k in range(runs)])
        rel, z = compare(theirs, ours)
        extra = ""
        if alpha > 0.0:
            factor = (1 - coat.coat_internal_reflectance(IOR, alpha)) / (
                1 - coat_tables.internal_reflectance(IOR, alpha, mitsuba_average=True))
            black = np.array([mean(rt.render(rt_scene({**material, "albedo": [0, 0, 0]}), seed=100 + k).array)
                              for k in range(runs)])
            rel2, z2 = compare(theirs, black + (ours - black) * factor)
            extra = f"{np.array2string(rel2, precision=4)} z {np.array2string(z2, precision=1)}"
        print(f"{name:20} {np.array2string(theirs.mean(0), precision=4):26} {np.array2string(ours.mean(0), precision=4):26} "
              f"{np.array2string(rel, precision=4):26} {np.array2string(z, precision=1):20} {extra}", flush=True)


if __name__ == "__main__":
    main()
