"""Which optional paths the kernels compile in: one constant per entry of the table of effects
(`scenefmt.effect_flags.EFFECT_FLAGS`), named by its key upper-cased: MOTION, DEFOCUS, MEDIA,
INSTANCES, CHECKER, IMAGE, NOISE, EMITTERS, DIELECTRICS, SKY, LIGHTS, ENVIRONMENT, MESHES.

Numba freezes module globals into the machine code as constants, and its dead-branch pass
drops `if FLAG and ...:` blocks whose FLAG is False before they are even type-checked. So a
path behind a False flag costs neither time at render nor time at compile.

This module, as shipped, turns every path on: `renderer.tracing` is the general kernel that
renders any scene. `renderer.variants` loads further copies of this package with this module
replaced by `values(...)` of that scene's flags (a flag is only ever off where the flat scene
cannot reach that path, so the image is the same bit for bit).
"""

from scenefmt.effect_flags import EFFECT_FLAGS, flags_tag

NAMES = tuple(flag.constant for flag in EFFECT_FLAGS)


def values(on) -> dict:
    """The module globals of a kernel whose flags `on` (keys) are on: each constant, NAMES and
    TAG (the kernel's name, which also names its cache folder: renderer/target.py)."""
    on = set(on)
    flags = {flag.constant: flag.key in on for flag in EFFECT_FLAGS}
    return {**flags, "NAMES": NAMES, "TAG": flags_tag(on)}


# As shipped: every path on, the general kernel.
globals().update(values(flag.key for flag in EFFECT_FLAGS))
