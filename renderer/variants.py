"""Kernels specialised to a scene's feature set: unused paths are not compiled at all.

The renderer package as shipped is the general kernel: every flag in `kernel_flags.py` is on.
For a scene that needs fewer paths, `kernels_for` imports the renderer package a second time
under another name (`renderer_<flags>`), with `kernel_flags` replaced by a module holding that
scene's flags. Numba compiles module globals in as constants and prunes the dead branches,
so the copy holds no code for an effect the scene lacks. Every module with compiled code
therefore imports its siblings relatively, so a copy's modules see the copy's flags.

Each copy gets its own Numba disk-cache folder (a subfolder named after its flags): Numba
keys cached code by source file and signature, not by globals, so copies sharing a folder
would load each other's machine code. `kernels_for` (the progressive render's passes) and
`tile_kernel_for` (the tiles a cluster's workers render, rt/chunks.py) import their modules
from the same copy, under its folder.

The flags come from the scene's effects (`scenefmt.effects.summarize`), the same analysis
`rt validate` prints: an effect is off only where the scene cannot reach its path, so a
specialised kernel renders the same image as the general kernel, bit for bit.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
import tempfile
import threading
import types
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Optional

import numba

from . import jit_cache
from . import kernel_flags as _general_flags

_RENDERER_DIR = Path(__file__).resolve().parent
_copies: dict[str, str] = {}  # tag -> package name of the renderer's copy with those flags
_loaded: dict[tuple[str, str], types.ModuleType] = {}  # (tag, module of kernels/) -> the module
_lock = threading.Lock()


@dataclass(frozen=True)
class KernelFeatures:
    """The optional kernel paths a scene reaches; field names match `kernel_flags.py` and the
    keys of `scenefmt.effects.EFFECTS`."""

    motion: bool = True
    defocus: bool = True
    media: bool = True
    instances: bool = True
    checker: bool = True
    image: bool = True
    noise: bool = True
    emitters: bool = True
    dielectrics: bool = True
    sky: bool = True
    lights: bool = True
    environment: bool = True
    meshes: bool = True

    @property
    def is_general(self) -> bool:
        return all(getattr(self, f.name) for f in fields(self))

    @property
    def tag(self) -> str:
        """A short stable name: 'all', 'none', or the flags that are on, joined by '+'."""
        on = [f.name for f in fields(self) if getattr(self, f.name)]
        if len(on) == len(fields(self)):
            return "all"
        return "+".join(on) if on else "none"

    def covers(self, other: "KernelFeatures") -> bool:
        """Whether every path `other` has is compiled in here too."""
        return all(getattr(self, f.name) or not getattr(other, f.name) for f in fields(self))


GENERAL = KernelFeatures()
# The general kernel's flags must be exactly the shipped features module.
assert tuple(f.name.upper() for f in fields(KernelFeatures)) == _general_flags.NAMES


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

    "auto": the specialised kernel if it is compiled already, else the general one (one compile
    serves every scene); "general" and "specialised" force one or the other.
    """
    if choice not in KERNEL_CHOICES:
        raise ValueError(f"unknown kernel choice {choice!r}: expected one of {', '.join(KERNEL_CHOICES)}")
    if choice == "specialised" or (choice == "auto" and is_compiled(needed)):
        return needed
    return GENERAL


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
        needed = samples * (noise / noise_target) ** 2
        left = min(left, sample_seconds * max(0.0, needed - samples))
    if time_left is not None:
        left = min(left, max(0.0, time_left))
    return left


def _variant_cache_dir(tag: str) -> str:
    base = jit_cache.configure()
    if not base:
        # Numba's default puts the cache beside the sources, shared by every copy: keep the
        # copies apart in a private temporary folder instead.
        base = os.path.join(tempfile.gettempdir(), f"rt-numba-{os.getuid() if hasattr(os, 'getuid') else 'user'}")
    return os.path.join(base, "variants", tag)


# What a ready marker is about: the progressive render's kernel (kernels/integrator.py) or
# the tile kernel of a cluster's workers (kernels/tile.py). Each is compiled on first use.
KERNEL_KINDS = ("kernel", "tile")


def _ready_marker(features: KernelFeatures, kind: str = "kernel") -> Path:
    """A file of ours, beside the kernel's cached machine code, that says it was compiled by this
    installation: Numba keys its cache by each source file's path and modification time, so the
    same sources installed elsewhere (or again) compile anew and must not find this marker."""
    if kind not in KERNEL_KINDS:
        raise ValueError(f"unknown kernel kind {kind!r}: expected one of {', '.join(KERNEL_KINDS)}")
    folder = jit_cache.configure() if features.is_general else _variant_cache_dir(features.tag)
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
    every flag is on, else that of the copy with the scene's flags, imported under its cache folder."""
    if features.is_general:
        return importlib.import_module(f".kernels.{name}", __package__)
    tag = features.tag
    with _lock:
        if (tag, name) in _loaded:
            return _loaded[tag, name]
        package = _copies.get(tag) or _copy_package(features)
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = _variant_cache_dir(tag)
        try:
            module = importlib.import_module(f"{package}.kernels.{name}")
        finally:
            numba.config.CACHE_DIR = saved
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
    for f in fields(KernelFeatures):
        setattr(flags, f.name.upper(), getattr(features, f.name))
    flags.NAMES = _general_flags.NAMES
    sys.modules[flags.__name__] = flags
    _copies[tag] = package
    return package


def kernels_for(features: KernelFeatures) -> types.ModuleType:
    """The integrator module compiled for `features` (the general one if every flag is on)."""
    return _kernel_module(features, "integrator")


def tile_kernel_for(features: KernelFeatures):
    """`kernels.tile.render_tile` compiled for `features`: the tile kernel of a cluster's workers."""
    return _kernel_module(features, "tile").render_tile
