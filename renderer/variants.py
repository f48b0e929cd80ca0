"""Kernels specialised to a scene's feature set: unused paths are not compiled at all.

The renderer package as shipped is the general kernel: every flag in `kernel_flags.py` is on.
For a scene that needs fewer paths, `kernel_set` imports the renderer package a second time
under another name (`renderer_<flags>`), with `kernel_flags` replaced by a module holding that
scene's flags (`kernel_flags.values`). Numba compiles module globals in as constants and prunes
the dead branches, so the copy holds no code for an effect the scene lacks. Every module with
compiled code therefore imports its siblings relatively, so a copy's modules see the copy's
flags, and its own copy of the target module (target.py), which caches the copy's machine code
in a folder of its flags' own: Numba keys cached code by source file and signature, not by
globals, so copies sharing a folder would load each other's machine code.

A `KernelSet` is what a render runs: `render_pass` (the progressive render's passes,
tracing/integrator.py) and `render_tile` (the tiles a cluster's workers render, tracing/tile.py)
of one feature set, each launched through the target.

The flags come from the scene's effects (`scenefmt.effects.summarize`), the same analysis
`rt validate` prints: an effect is off only where the scene cannot reach its path, so a
specialised kernel renders the same image as the general kernel, bit for bit.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import tempfile
import threading
import types
from dataclasses import fields, make_dataclass
from pathlib import Path
from typing import Optional

from scenefmt.effect_flags import EFFECT_FLAGS, flags_tag

from . import jit_cache, kernel_flags, target

_RENDERER_DIR = Path(__file__).resolve().parent
_copies: dict[str, str] = {}  # tag -> package name of the renderer's copy with those flags
_loaded: dict[tuple[str, str], types.ModuleType] = {}  # (tag, module of tracing/) -> the module
_lock = threading.Lock()


class _FeatureMethods:
    @property
    def is_general(self) -> bool:
        return all(getattr(self, f.name) for f in fields(self))

    @property
    def tag(self) -> str:
        """A short stable name: 'all', 'none', or the flags that are on, joined by '+'."""
        return flags_tag(f.name for f in fields(self) if getattr(self, f.name))

    def covers(self, other: "KernelFeatures") -> bool:
        """Whether every path `other` has is compiled in here too."""
        return all(getattr(self, f.name) or not getattr(other, f.name) for f in fields(self))


# The optional kernel paths a scene reaches: a bool field (default on) per entry of the table of
# effects (scenefmt/effect_flags.py), named by its key: motion, defocus, media, ...
KernelFeatures = make_dataclass(
    "KernelFeatures", [(flag.key, bool, True) for flag in EFFECT_FLAGS], bases=(_FeatureMethods,), frozen=True,
    namespace={"__module__": __name__, "__doc__": "The optional kernel paths a scene reaches, by the keys of "
               "scenefmt.effect_flags.EFFECT_FLAGS (every one on by default: the general kernel)."},
)

GENERAL = KernelFeatures()
# The general kernels, smallest first: the core one (every effect of tier 0 in the table of
# effects), the core with the lights that are no shape and the light tree (tier 1), and the full
# one. A render with no kernel compiled for its scene starts with the smallest that covers it, so
# a scene without the microfacet materials and maps compiles what it compiled before they existed
# (51 s against 85 s for the full kernel, cold, on 2 cores), and a scene lit by a spot or the sun
# does not compile the microfacets either.
CORE = KernelFeatures(**{flag.key: flag.tier == 0 for flag in EFFECT_FLAGS})
CORE_LIGHTS = KernelFeatures(**{flag.key: flag.tier <= 1 for flag in EFFECT_FLAGS})
GENERAL_KERNELS = (CORE, CORE_LIGHTS, GENERAL)


def features_of(graph) -> KernelFeatures:
    """The kernel paths a scene graph reaches: its effects, as `rt validate` reports them."""
    from scenefmt.effects import summarize

    return KernelFeatures(**summarize(graph).kernel_paths)


# How a render chooses its kernel (`render_flat(kernel=...)`, `rt render --kernel`).
KERNEL_CHOICES = ("auto", "general", "specialised")
# What "auto" weighs: a specialised kernel renders a few per cent faster than the general one
# (docs/performance.md: 5% at the median of the book scenes, 14% at most), and compiling it
# costs 8 to 14 s on a quiet 2-core machine, twice that on a busy one. So a render starts at
# once with whatever is compiled, and compiles the specialised kernel only when the time it
# saves on the rest of the render repays the compile.
SPECIALISED_GAIN = 0.05
SPECIALISED_COMPILE_SECONDS = 15.0


def first_kernel(needed: KernelFeatures, choice: str = "auto") -> KernelFeatures:
    """The kernel a render of a scene needing `needed` starts with.

    "auto": the specialised kernel if it is compiled already, else a general one (one compile
    serves every scene it covers): the smallest of GENERAL_KERNELS that covers the scene and is
    compiled, or the smallest that covers it; "general" (the full general kernel) and
    "specialised" force one or the other.
    """
    if choice not in KERNEL_CHOICES:
        raise ValueError(f"unknown kernel choice {choice!r}: expected one of {', '.join(KERNEL_CHOICES)}")
    if choice == "specialised" or (choice == "auto" and is_compiled(needed)):
        return needed
    if choice == "general":
        return GENERAL
    covering = [kernel for kernel in GENERAL_KERNELS if kernel.covers(needed)]
    return next((kernel for kernel in covering if is_compiled(kernel)), covering[0])


def compile_wait(features: KernelFeatures) -> str:
    """How long the first compile of `features`' kernel makes a user wait, as the messages say it:
    a kernel with any effect of tier 2 (the microfacet materials and maps) is the larger one.
    Measured on a fresh install, 2 idle cores (benchmarks/compile_cost.py --each-cold, issue 33):
    the core kernel 67 s (cornell_box), the core with the lights 66-71 s (cornell_spot, sun_sky,
    many_lights), the full one 114-121 s (the same three before they had a kernel of their own)."""
    if any(getattr(features, flag.key) for flag in EFFECT_FLAGS if flag.tier > 1):
        return "about two minutes on 2 cores"
    return "about a minute on 2 cores"


def worth_specialising(remaining_seconds: float) -> bool:
    """Whether compiling the specialised kernel now repays itself in the rest of a render."""
    return remaining_seconds * SPECIALISED_GAIN > SPECIALISED_COMPILE_SECONDS


def seconds_left(sample_seconds: float, samples: int, cap: int, *, noise: Optional[float] = None,
                 noise_target: Optional[float] = None, time_left: Optional[float] = None) -> Optional[float]:
    """The rendering time a render has left, forecast from what it measured so far: None while
    it cannot tell yet (a noise target, and no noise estimate).

    `sample_seconds` is the time of one sample per pixel, `samples` those done and `cap` the most
    it may render. With a noise target the render ends when the estimated noise `noise` falls
    to it, and noise falls as one over the square root of the samples: so it needs about
    samples * (noise / noise_target)^2 in all, often far below the cap (a `--noise` render's
    cap is a million samples). With a time budget, `time_left` of it remains. The forecast is
    the least of these.
    """
    left = sample_seconds * max(0, cap - samples)
    if noise_target is not None:
        if noise is None or samples < 2 or not 0 < noise < float("inf"):
            return None
        from .forecast import samples_for_noise

        left = min(left, sample_seconds * max(0.0, samples_for_noise(samples, noise, noise_target) - samples))
    if time_left is not None:
        left = min(left, max(0.0, time_left))
    return left


def _variant_cache_dir(tag: str) -> str:
    """The cache folder of the specialised kernel named `tag` (jit_cache.folder_for)."""
    return jit_cache.folder_for(tag)


# What a ready marker is about: the progressive render's kernel (tracing/integrator.py), the
# tile kernel of a cluster's workers (tracing/tile.py) or the render passes' kernel
# (tracing/aux_passes.py, general only). Each is compiled on first use.
KERNEL_KINDS = ("kernel", "tile", "aux")


def _ready_marker(features: KernelFeatures, kind: str = "kernel") -> Path:
    """A file of ours, beside the kernel's cached machine code, that says it was compiled by this
    installation: Numba keys its cache by each source file's path and modification time, so the
    same sources installed elsewhere (or again) compile anew and must not find this marker."""
    if kind not in KERNEL_KINDS:
        raise ValueError(f"unknown kernel kind {kind!r}: expected one of {', '.join(KERNEL_KINDS)}")
    folder = jit_cache.folder_for(features.tag)
    return Path(folder or tempfile.gettempdir()) / f"rt-{kind}-ready-{features.tag}-{jit_cache.installation_key()}"


def is_compiled(features: KernelFeatures, kind: str = "kernel") -> bool:
    """Whether the kernel of `kind` (KERNEL_KINDS) for `features` has been compiled in this
    installation (and so will load from the disk cache rather than compile): a render says so
    before a long compile."""
    return _ready_marker(features, kind).is_file()


def mark_compiled(features: KernelFeatures, kind: str = "kernel") -> None:
    marker = _ready_marker(features, kind)
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
    except OSError:  # a read-only cache: the next render just says it may compile
        pass


def _kernel_module(features: KernelFeatures, name: str) -> types.ModuleType:
    """The module `kernels.<name>` of the renderer compiled for `features`: this package's own if
    every flag is on, else that of the copy with the scene's flags."""
    if features.is_general:
        return importlib.import_module(f".tracing.{name}", __package__)
    tag = features.tag
    with _lock:
        if (tag, name) in _loaded:
            return _loaded[tag, name]
        package = _copies.get(tag) or _copy_package(features)
        module = importlib.import_module(f"{package}.tracing.{name}")
        _loaded[tag, name] = module
        return module


def _copy_package(features: KernelFeatures) -> str:
    """Import the renderer package again as `renderer_<flags>`, with `features` as its kernel_flags
    (the caller holds _lock); its name."""
    tag = features.tag
    package = f"renderer_{tag.replace('+', '_')}"
    spec = importlib.util.spec_from_file_location(
        package, _RENDERER_DIR / "__init__.py", submodule_search_locations=[str(_RENDERER_DIR)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[package] = module
    spec.loader.exec_module(module)
    flags = types.ModuleType(f"{package}.kernel_flags", "Flags of one specialised kernel (generated).")
    vars(flags).update(kernel_flags.values(f.name for f in fields(KernelFeatures) if getattr(features, f.name)))
    sys.modules[flags.__name__] = flags
    _copies[tag] = package
    return package


class KernelSet:
    """The kernels of one feature set (the general kernel's, or a specialised copy's): what a
    render launches. Each module is imported, and so compiled or loaded from the cache, when it
    is first asked for."""

    def __init__(self, features: KernelFeatures):
        self.features = features

    def render_pass(self, S, width, height, seed, sample_start, sample_count, max_depth, integrator, sampling, sums,
                    row_rays, row_bad, band_start, band_stop, rec=None, splats=None):
        """tracing.integrator.render_pass of this feature set: samples added to the whole film's
        sums, for the rows band_start..band_stop of the pass's row order (it allocates the
        threads' scratch and launches the parallel kernel `render_band`); `rec`: the guide's
        training records (guide_records.py), None for a render."""
        return _kernel_module(self.features, "integrator").render_pass(S, width, height, seed, sample_start, sample_count,
                                                                       max_depth, integrator, sampling, sums, row_rays,
                                                                       row_bad, band_start, band_stop, rec, splats)

    def caustic_splats(self, S, width, height, seed, sample_start, sample_count, max_depth):
        """tracing.caustics.caustic_splats of this feature set: each sample's photons' share of each pixel."""
        return _kernel_module(self.features, "caustics").caustic_splats(S, width, height, seed, sample_start,
                                                                        sample_count, max_depth)

    def render_tile(self, S, width, x0, y0, seed, sample_start, sample_count, max_depth, integrator, sampling, sums,
                    row_rays, row_bad, rec=None):
        """tracing.tile.render_tile of this feature set: samples added to one tile's sums (`rec`
        as for render_pass)."""
        from .guide_records import no_records

        return target.launch(_kernel_module(self.features, "tile").render_tile, S, width, x0, y0, seed, sample_start,
                             sample_count, max_depth, integrator, sampling, sums, row_rays, row_bad,
                             no_records() if rec is None else rec)



_sets: dict[str, KernelSet] = {}


def kernel_set(features: KernelFeatures) -> KernelSet:
    """The kernels compiled for `features` (the general ones if every flag is on)."""
    found = _sets.get(features.tag)
    if found is None:
        found = _sets.setdefault(features.tag, KernelSet(features))
    return found


