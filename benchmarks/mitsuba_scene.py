"""One of our scene graphs as a Mitsuba 3 scene, for the benchmarks that render both side by side.

    from mitsuba_scene import set_variant, scene_dict, render_passes
    variant = set_variant()              # llvm_ad_rgb when DRJIT_LIBLLVM_PATH is set, else scalar_rgb
    scene = mi.load_dict(scene_dict(graph))
    passes = render_passes(scene, spp=4, seconds=10)  # or passes=...

What it converts: quads, boxes and spheres (each with its transform), the camera (no defocus), a
black background or an environment map (`envmap`), the materials that Mitsuba has an equal of
(lambertian, diffuse_light, dielectric, metal without fuzz, conductor, rough_dielectric,
thin_dielectric, plastic), and the lights that are no shape (point,
spot, directional: `emitter`). Anything else raises ValueError naming it, so a comparison never
silently renders something else (textures, normal and bump maps and a point light's radius
included). A colour temperature or a power is converted as the model resolves it for the renderer
(`radiance_slot`, `intensity_rgb`, `irradiance_rgb`): the comparison is of the kernels.

Where the two renderers differ by convention, and what this module does about it:

- Our surfaces scatter on both sides; Mitsuba's reflecting BSDFs only on the front. Each such
  BSDF is wrapped in Mitsuba's `twosided`. Dielectrics are two-sided in both.
- A one-sided light (`sides: front`) is Mitsuba's area light as it is: both emit along the
  shape's normal (a quad's u x v, which becomes the normal of Mitsuba's rectangle; a sphere's and
  a box's outside). The books' two-sided light has no equal: a two-sided quad light is turned to
  face +y or -y as `light_faces` says (down, into the Cornell box, by default), and the light its
  back would send must not matter to the image (put the lamp flush with the ceiling, as
  `FLUSH_LAMP` does for the shipped Cornell box).
- Point, spot and directional lights are Mitsuba's `point`, `spot` and `directional` with the
  same numbers: intensity in W/sr, irradiance in W/m^2, the direction the light travels, and the
  spot's cut-off and beam angles in degrees, whose profile (full within the beam, falling
  linearly in angle to 0 at the cut-off) is Mitsuba's by construction.
- Depth: the same number in both. Mitsuba's `max_depth` 1 renders only the emitters the camera
  sees and 2 direct light; our `max_depth` counts the segments of a path the same way (1: the
  camera ray's own hit). Measured at depths 1 to 3 on the Cornell box (DEPTH_OFFSET 0; 1 gave
  Mitsuba one bounce more).
- Tangents: a sphere's dp/du runs around +y in both (Mitsuba's sphere is turned to match), so
  anisotropic widths (alpha along u, alpha_v along v) mean the same.
- Pixels: both draw camera rays uniformly over the pixel (Mitsuba's box filter of radius 0.5).
- GGX: Mitsuba's rough BSDFs take the width alpha and use the separable Smith term G1 G1 with
  visible-normal sampling; our materials say `alpha:` and `shadowing: separable` to match (our
  `roughness` r is alpha = r^2).
"""

from __future__ import annotations

import os
import time

import numpy as np

# The shipped Cornell box with its lamp flush with the ceiling: the light its back sends up then
# meets the lamp itself within 0.001 and goes nowhere, so our two-sided lamp and Mitsuba's
# one-sided one light the box alike.
DEPTH_OFFSET = 0  # Mitsuba's max_depth minus ours for the same paths
FLUSH_LAMP = ("shapes[2].q=[343,554.999,332]",)


def set_variant() -> str:
    """Choose Mitsuba's variant: the vectorised LLVM one when its library is named, else scalar."""
    import mitsuba as mi

    variant = "llvm_ad_rgb" if os.environ.get("DRJIT_LIBLLVM_PATH") else "scalar_rgb"
    mi.set_variant(variant)
    return variant


def _affine4(m) -> np.ndarray:
    return np.array([list(row) for row in m] + [[0.0, 0.0, 0.0, 1.0]], float)


def _rgb(value) -> dict:
    return {"type": "rgb", "value": [float(x) for x in value]}


def _constant(value, what: str):
    """A plain colour or number from a model field; textures are not converted."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, (tuple, list)) and len(value) == 3 and all(isinstance(x, (int, float)) for x in value):
        return [float(x) for x in value]
    raise ValueError(f"the Mitsuba conversion takes only constant {what}, not {value!r}")


def _alpha(model) -> tuple[float, float]:
    """(alpha_u, alpha_v), the GGX widths, as the model's `widths` gives them (a roughness squared)."""
    def width(given):
        value, squared = given
        value = _constant(value, "roughness")
        return value * value if squared else value
    u, v = model.widths()
    return width(u), width(v)


def _check_separable(model) -> None:
    shadowing = getattr(model, "shadowing", "separable")
    if shadowing != "separable":
        raise ValueError(f"Mitsuba's GGX uses the separable Smith term: give the {model.type} `shadowing: separable`")


def _microfacet(au: float, av: float) -> dict:
    return {"distribution": "ggx", "sample_visible": True, "alpha_u": au, "alpha_v": av}


def _conductor_index(model) -> tuple[list, list]:
    """(eta, k) RGB of a conductor model: given, or its named metal's (the values our rows hold)."""
    eta, k = model.index()
    return [float(x) for x in eta], [float(x) for x in k]


def bsdf(model) -> tuple[str, dict]:
    """('bsdf' or 'emitter', Mitsuba's dict) for one of our material models."""
    kind = model.type
    if getattr(model, "normal_map", None) is not None or getattr(model, "bump_map", None) is not None:
        raise ValueError(f"the Mitsuba conversion does not convert the normal or bump map of a {kind} material")
    if kind == "diffuse_light":
        # The radiance the renderer reads: `emit`, in the colour of a `temperature` where one is given.
        return "emitter", {"type": "area", "radiance": _rgb(_constant(model.radiance_slot(), "emission"))}
    if kind == "lambertian":
        inner = {"type": "diffuse", "reflectance": _rgb(_constant(model.albedo, "albedo"))}
    elif kind == "conductor":
        _check_separable(model)
        eta, k = _conductor_index(model)
        au, av = _alpha(model)
        inner = {"type": "roughconductor" if au > 0 else "conductor", "eta": _rgb(eta), "k": _rgb(k),
                 "specular_reflectance": _rgb(_constant(getattr(model, "tint", (1.0, 1.0, 1.0)), "tint"))}
        if au > 0:
            inner.update(_microfacet(au, av))
    elif kind == "rough_dielectric":
        _check_separable(model)
        au, av = _alpha(model)
        tint = _rgb(_constant(getattr(model, "tint", (1.0, 1.0, 1.0)), "tint"))
        # Our tint multiplies both what is reflected and what is transmitted.
        out = {"type": "roughdielectric" if au > 0 else "dielectric", "int_ior": float(model.ior), "ext_ior": 1.0,
               "specular_reflectance": tint, "specular_transmittance": tint}
        if au > 0:
            out.update(_microfacet(au, av))
        return "bsdf", out  # both sides of a dielectric are alike in Mitsuba: no `twosided`
    elif kind == "dielectric":
        # Smooth glass with the exact Fresnel terms, as Mitsuba's `dielectric`: two-sided already.
        return "bsdf", {"type": "dielectric", "int_ior": float(model.ior), "ext_ior": 1.0}
    elif kind == "metal":
        # The books' metal is a mirror of reflectance `albedo` blurred by `fuzz`: unblurred, it is
        # Mitsuba's conductor without a named material (reflectance 1) times that albedo. The fuzz
        # has no equal (compare a variant with `fuzz: 0` in both).
        if _constant(model.fuzz, "fuzz") != 0.0:
            raise ValueError("Mitsuba has no equal of the books' fuzzed metal: the conversion takes a metal only with fuzz 0")
        inner = {"type": "conductor", "material": "none", "specular_reflectance": _rgb(_constant(model.albedo, "albedo"))}
    elif kind == "thin_dielectric":
        # A sheet: the tint multiplies only what goes through. Two-sided in Mitsuba already.
        return "bsdf", {"type": "thindielectric", "int_ior": float(model.ior), "ext_ior": 1.0,
                        "specular_transmittance": _rgb(_constant(model.tint, "tint"))}
    elif kind == "plastic":
        au, av = _alpha(model)
        if au != av:
            raise ValueError("Mitsuba's roughplastic is isotropic")
        inner = {"type": "roughplastic" if au > 0 else "plastic", "int_ior": float(model.ior), "ext_ior": 1.0,
                 "diffuse_reflectance": _rgb(_constant(model.albedo, "albedo")),
                 "nonlinear": bool(getattr(model, "nonlinear", False))}
        if au > 0:
            _check_separable(model)
            inner.update({"distribution": "ggx", "sample_visible": True, "alpha": au})
    else:
        raise ValueError(f"the Mitsuba conversion has no equal of a {kind} material")
    return "bsdf", {"type": "twosided", "bsdf": inner}


def one_sided(material) -> bool:
    """Whether a material model emits from its front face only, as every Mitsuba area light does."""
    return getattr(material, "sides", "both") == "front"


def shape(model, transform, slot: str, light_faces: float | None) -> dict:
    """Mitsuba's shape dict for one of our shapes (without its material). A two-sided quad light
    is turned to face the sign of y `light_faces`; None keeps every quad as it is (its normal
    u x v), as a one-sided light must be."""
    import mitsuba as mi

    to_world = _affine4(transform)
    m = np.eye(4)
    if model.type == "quad":
        q, u, v = (np.array(x, float) for x in (model.q, model.u, model.v))
        if slot == "emitter" and light_faces is not None and np.cross(u, v)[1] * light_faces < 0:
            u, v = v, u  # one-sided in Mitsuba: face it the way the lamp is to shine
        n = np.cross(u, v)
        # Mitsuba's rectangle is [-1, 1]^2 in x, y with normal +z: map it onto q + a u + b v.
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u / 2, v / 2, n / np.linalg.norm(n), q + u / 2 + v / 2
        kind = "rectangle"
    elif model.type == "box":
        lo, hi = np.array(model.min, float), np.array(model.max, float)
        m[:3, :3] = np.diag((hi - lo) / 2)
        m[:3, 3] = (hi + lo) / 2
        kind = "cube"
    elif model.type == "sphere":
        # Our sphere's u runs around +y, Mitsuba's around its local +z: turn that axis to +y, so that
        # both lay an anisotropic lobe along the same dp/du.
        m[:3, :3] = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]) * float(model.radius)
        m[:3, 3] = np.array(model.center, float)
        kind = "sphere"
    else:
        raise ValueError(f"the Mitsuba conversion does not convert a {model.type}")
    return {"type": kind, "to_world": mi.ScalarTransform4f((to_world @ m).tolist())}


def emitter(model) -> dict:
    """Mitsuba's emitter dict for one of our lights that are no shape (scene `lights:`), with the
    numbers the renderer reads from the model: its intensity or irradiance per channel (a power
    or a temperature already turned into them by the model), a spot's axis and beam width in
    effect."""
    import mitsuba as mi

    kind = model.type
    if kind == "point":
        if model.radius:
            raise ValueError("Mitsuba's point light has no radius: the conversion takes only a point light of radius 0")
        return {"type": "point", "position": [float(x) for x in model.position], "intensity": _rgb(model.intensity_rgb())}
    if kind == "spot":
        position = np.array(model.position, float)
        axis = np.array(model.axis(), float)
        # Mitsuba's spot shines along its local +z: look from the position along the axis, with any up
        # that is not the axis (the profile is round, so which one does not matter).
        up = [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0]
        return {"type": "spot", "intensity": _rgb(model.intensity_rgb()), "cutoff_angle": float(model.cutoff_angle),
                "beam_width": float(model.beam),
                "to_world": mi.ScalarTransform4f().look_at(origin=position.tolist(), target=(position + axis).tolist(), up=up)}
    if kind == "directional":
        return {"type": "directional", "direction": [-float(x) for x in model.toward_light()],
                "irradiance": _rgb(model.irradiance_rgb())}
    raise ValueError(f"the Mitsuba conversion has no equal of a {kind} light")


# Mitsuba's environment map filters bilinearly, ours takes the nearest texel. Each texel is
# repeated ENV_UPSAMPLE x ENV_UPSAMPLE times, so Mitsuba blends only within 1/(2 ENV_UPSAMPLE) of a
# texel's edge, and a blend across an edge keeps its integral (measured: at 16, 6% of directions
# differ from our lookup at all, each between the two neighbours it lies between).
ENV_UPSAMPLE = 16


def environment(graph) -> dict:
    """Mitsuba's `envmap` emitter for an image background: the texels the renderer reads, times
    the strength, turned about +y by the background's `rotate`. Our map's longitude phi runs from
    -z toward -x, Mitsuba's is half a turn from ours, hence the extra 180 degrees."""
    import mitsuba as mi

    from renderer.textures import load_image_texels

    bg = graph.background
    texels = load_image_texels(graph.environment_path, "srgb") * float(bg.strength)
    big = np.repeat(np.repeat(np.asarray(texels, np.float32), ENV_UPSAMPLE, axis=0), ENV_UPSAMPLE, axis=1)
    return {"type": "envmap", "bitmap": mi.Bitmap(np.ascontiguousarray(big)),
            "to_world": mi.ScalarTransform4f().rotate([0.0, 1.0, 0.0], float(bg.rotate) + 180.0)}


def scene_dict(graph, light_faces: float = -1.0, spp: int = 4) -> dict:
    """Mitsuba's scene dict for `graph`: its shapes, materials, lights, camera and path depth.
    `light_faces` is the sign of y along which two-sided quad lights shine (-1: down); one-sided
    ones shine along their own normal."""
    import mitsuba as mi

    background = getattr(graph, "background", None)
    colour = getattr(background, "color", background)
    objects = {}
    if getattr(background, "type", None) == "image":
        objects["environment"] = environment(graph)
    elif colour is not None and not (isinstance(colour, (tuple, list)) and not any(colour)):
        raise ValueError(f"the Mitsuba conversion takes only a black background or an image one, not {background!r}")
    for k, member in enumerate(graph.root.members):
        material = member.material.model
        slot, value = bsdf(material)
        entry = shape(member.model, member.transform, slot, None if one_sided(material) else light_faces)
        entry[slot] = value
        objects[f"s{k}"] = entry
    for k, light in enumerate(getattr(graph, "lights", None) or ()):
        objects[f"l{k}"] = emitter(getattr(light, "model", light))
    cam, image = graph.camera, graph.image
    if cam.defocus_angle or cam.aperture:
        raise ValueError("the Mitsuba conversion has no defocus")
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": image.max_depth + DEPTH_OFFSET},
        "sensor": {
            "type": "perspective", "fov": cam.vfov, "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=list(cam.look_from), target=list(cam.look_at), up=list(cam.up)),
            "film": {"type": "hdrfilm", "width": image.width, "height": image.pixel_height, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        **objects,
    }


class Passes:
    """Running per-pixel sums of Mitsuba's pass images (each the mean of `spp` samples): the image,
    and the variance of each pixel's mean from the spread of its passes."""

    def __init__(self, spp: int):
        self.spp, self.count, self.total, self.total_sq, self.seconds, self.cpu_seconds = spp, 0, None, None, 0.0, 0.0

    def add(self, image: np.ndarray) -> None:
        image = np.asarray(image, np.float64)[..., :3]
        if self.total is None:
            self.total, self.total_sq = np.zeros_like(image), np.zeros_like(image)
        self.total += image
        self.total_sq += image * image
        self.count += 1

    @property
    def samples(self) -> int:
        return self.count * self.spp

    def mean(self) -> np.ndarray:
        return self.total / max(self.count, 1)

    def mean_variance(self) -> np.ndarray:
        """Variance of each pixel's mean: its passes' unbiased variance over their number (needs 2 passes)."""
        n = self.count
        return np.maximum(self.total_sq - self.total * (self.total / n), 0.0) / (n - 1) / n


def render_passes(scene, spp: int, passes: int | None = None, seconds: float | None = None, seed: int = 1) -> Passes:
    """Render `scene` in passes of `spp` samples (one compiled kernel), each with its own seed,
    until `passes` are done or `seconds` of wall time are spent. The first, compiling, call is
    made before the clock starts and not counted."""
    import mitsuba as mi

    mi.render(scene, spp=spp, seed=0)
    out = Passes(spp)
    t0, c0 = time.perf_counter(), time.process_time()
    while True:
        if passes is not None and out.count >= passes:
            break
        if seconds is not None and time.perf_counter() - t0 >= seconds:
            break
        out.add(np.array(mi.render(scene, spp=spp, seed=seed + out.count)))
    out.seconds, out.cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
    return out
