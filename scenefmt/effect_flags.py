"""The effects a scene may call for, each of which switches on one optional path of the kernels.

Declared once, here: `scenefmt.effects` reports each effect by its name (`rt validate`, `--explain`)
and says whether a scene calls for it; `renderer.kernel_flags` makes each key, upper-cased, the
constant a kernel tests (`if MEDIA and kind == MEDIUM:`); `renderer.variants.KernelFeatures` has
a field per key, the feature set a kernel is compiled for. Pure Python, importing nothing, so
that `rt validate` never loads numpy or Numba.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EffectFlag:
    key: str  # KernelFeatures' field and scenefmt.effects' key; upper-cased, the kernels' constant
    name: str  # what users read
    path: str  # what the kernels compile in when it is on
    # 0: in the core general kernel, which a render with nothing compiled starts with unless its
    # scene needs more; 1: the lights that are no shape and the light tree, added to the core in
    # the middle general kernel; 2: only in the full general kernel (the microfacet materials and
    # maps). So a scene never compiles the code of a tier above what it uses, not even on a fresh
    # install.
    tier: int = 0

    @property
    def constant(self) -> str:
        """The name of the kernels' constant: renderer.kernel_flags.MEDIA for 'media'."""
        return self.key.upper()


EFFECT_FLAGS = (
    EffectFlag("motion", "motion blur", "time sampling, moving sphere centres, and transforms and a camera interpolated at each ray's time"),
    EffectFlag("defocus", "defocus", "sampling the lens disk"),
    EffectFlag("media", "media", "media in the trees (their boundaries, constant densities) and scattering inside them"),
    EffectFlag("instances", "instances", "the top-level tree and per-instance transforms"),
    EffectFlag("checker", "checker textures", "checker textures"),
    EffectFlag("image", "image textures", "image textures"),
    EffectFlag("noise", "noise textures", "Perlin noise textures"),
    EffectFlag("emitters", "emitters", "diffuse lights"),
    EffectFlag("dielectrics", "dielectrics", "refraction"),
    EffectFlag("sky", "sky background", "the sky-gradient background"),
    EffectFlag("lights", "light sampling",
               "shadow rays to points on emitters, weighted with the path's own hits"),
    EffectFlag("environment", "environment map",
               "an image background: its lookup, and with `integrator: mis` its sampling as a light"),
    EffectFlag("meshes", "triangle meshes", "the ray's sheared frame and the watertight triangle test"),
    EffectFlag("conductors", "conductors", "GGX microfacet reflection with a measured metal's Fresnel", 2),
    EffectFlag("rough_dielectrics", "rough and thin glass", "refraction through GGX microfacets, and thin sheets", 2),
    EffectFlag("plastics", "plastics", "a dielectric coat over a diffuse base", 2),
    EffectFlag("principled", "principled materials", "glTF's metallic-roughness mix of lobes", 2),
    EffectFlag("surface_maps", "normal and bump maps", "tangent frames and shading normals bent by a map", 2),
    EffectFlag("parameter_textures", "textured parameters", "roughness and other numbers read from a texture", 2),
    EffectFlag("punctual", "point, spot, directional and sun lights",
               "sampling lights that are no shape: points, spots, parallel light and the sun's disc", 1),
    EffectFlag("light_tree", "many lights", "choosing among many lights by a tree of their bounds, orientations and power", 1),
    EffectFlag("guiding", "path guiding",
               "a learned distribution of where light arrives from, mixed with the BSDF at every diffuse bounce", 2),
    EffectFlag("caustics", "light-traced caustics",
               "photons from the lights through specular spheres onto matte surfaces, joined to the camera", 2),
    EffectFlag("varying_media", "media of varying density",
               "grid and noise densities: delta tracking through a majorant grid, ratio tracking for shadow rays", 2),
    EffectFlag("phase_hg", "Henyey-Greenstein phase",
               "sampling and evaluating an anisotropic (Henyey-Greenstein) phase function in media", 2),
)
EFFECT_KEYS = tuple(flag.key for flag in EFFECT_FLAGS)
CORE_KEYS = tuple(flag.key for flag in EFFECT_FLAGS if flag.tier == 0)
LIGHTS_KEYS = tuple(flag.key for flag in EFFECT_FLAGS if flag.tier <= 1)


def flags_tag(on) -> str:
    """A short stable name of a set of flags that are on (keys): 'all', 'core' (every flag of tier
    0), 'core+lights' (every flag of tiers 0 and 1), 'none', or those that are on, in the table's
    order, joined by '+'. It names a specialised kernel and its cache folder."""
    on = set(on)
    if on >= set(EFFECT_KEYS):
        return "all"
    if on == set(CORE_KEYS):
        return "core"
    if on == set(LIGHTS_KEYS):
        return "core+lights"
    return "+".join(key for key in EFFECT_KEYS if key in on) or "none"
