"""What each expensive effect of a scene costs: `rt render --explain` renders the scene and, for
each effect it has, the scene without it, each for the same short time at a small width, and says
how the effect changes the time per sample, the noise per sample, the time to a given noise, and
the image's mean brightness (the bias of leaving it out).

The variants are made from the scene graph, as `renderer.compile.with_width` makes a narrower
one: path depth (the scene's max_depth against SHORT_DEPTH), media (their boundaries' shapes keep
their material, the medium inside is gone), the environment map (a black background), defocus
(a pinhole camera), motion blur (a shutter closed at its opening time) and the glossy materials
(conductors, rough and thin glass, plastics, principled: each a matte surface of its colour, at
most MATTE_ALBEDO). They render with the kernel the render starts with, which covers every
variant (a variant only takes paths away), so nothing is compiled for them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable, Optional

# The short path of the depth comparison: direct light and three bounces.
SHORT_DEPTH = 4
# The width the costs are measured at, and the time each render of them takes: the whole report
# takes about (effects + 1) x SECONDS_EACH, SECONDS_LEAST to SECONDS_MOST each.
COST_WIDTH = 64
REPORT_SECONDS = 15.0
SECONDS_LEAST, SECONDS_MOST = 1.5, 4.0


@dataclass(frozen=True)
class Variant:
    """The scene without one effect: its name as users read it, what was changed, and the graph
    (or, for depth, the same graph at another max_depth)."""

    effect: str
    change: str
    graph: object
    max_depth: Optional[int] = None


@dataclass(frozen=True)
class Measure:
    """One short render: seconds per sample per pixel, the image's noise per sample (the sum over
    pixels of each pixel's sample variance, channels averaged), its mean value and the standard
    error of that mean."""

    sample_seconds: float
    variance: float
    mean: float
    mean_error: float
    samples: int


@dataclass(frozen=True)
class Cost:
    """What an effect costs: the ratios of the scene with it to the scene without it."""

    effect: str
    change: str
    time: float  # time per sample
    noise: float  # noise per sample
    bias: float  # (mean without - mean with) / mean with
    bias_error: float  # the standard error of `bias`
    dark: bool = False  # the image is black without it: it is the scene's only light

    @property
    def time_to_noise(self) -> float:
        """How many times longer the scene takes to the same noise with the effect than without."""
        return self.time * self.noise * self.noise

    def sentence(self) -> str:
        """'defocus (aperture 0): time per sample x1.8, noise x1.3 (so x3.0 the time to the same
        noise), bias -4% if removed'."""
        if self.dark:
            return (f"{self.effect} ({self.change}): time per sample x{self.time:.2f}; it is the scene's only light "
                    "(the image is black without it)")
        if not math.isfinite(self.noise):
            return (f"{self.effect} ({self.change}): time per sample x{self.time:.2f}, and all of the noise "
                    "(the image is the same in every sample without it)")
        bias = 100 * self.bias
        if abs(self.bias) > 3 * self.bias_error and abs(bias) >= 0.05:
            what = f"bias {bias:+.1f}% if removed (+/- {100 * self.bias_error:.2g}%)"
        else:
            what = f"no bias seen if removed (within +/- {300 * self.bias_error:.2g}%)"
        return (f"{self.effect} ({self.change}): time per sample x{self.time:.2f}, noise x{self.noise:.2f} "
                f"(so x{self.time_to_noise:.2f} the time to the same noise), {what}")


def _with_members(graph, member, **changes):
    """The graph with every member of every group (the root, named groups, those instances place)
    replaced by `member(m)` (a list of members, maybe empty), each group copied once however often it
    is placed; `changes` replace other fields of the graph."""
    from scenefmt.graph import GroupNode, InstanceNode

    copies: dict[int, GroupNode] = {}

    def group(g: GroupNode) -> GroupNode:
        if id(g) in copies:
            return copies[id(g)]
        new = copies[id(g)] = dataclasses.replace(g, members=[])
        for m in g.members:
            if isinstance(m, InstanceNode):
                new.members.append(dataclasses.replace(m, group=group(m.group)))
            else:
                new.members.extend(member(m))
        return new

    root = group(graph.root)
    return dataclasses.replace(graph, root=root, groups=[copies.get(id(g), g) for g in graph.groups], **changes)


def _without_media(graph):
    """The graph with every medium taken out: a boundary with a material keeps it, one without goes."""
    from scenefmt.graph import ShapeNode

    def member(m):
        if isinstance(m, ShapeNode) and m.interior is not None:
            return [dataclasses.replace(m, interior=None)] if m.material is not None else []
        return [m]

    return _with_members(graph, member, media=[])


# A glossy material made matte keeps its colour, at most this albedo (a white tint would make a
# white lambertian surface, whose paths barely end).
MATTE_ALBEDO = 0.8


def _matte_of(material):
    """A lambertian MaterialNode of a glossy material's colour (its albedo, base colour or tint);
    other materials as they are."""
    from scenefmt.effects import MATERIAL_KIND_EFFECTS
    from scenefmt.graph import MaterialNode, TextureNode
    from scenefmt.materials import Lambertian
    from scenefmt.textures import SolidTexture

    if material is None or material.kind not in MATERIAL_KIND_EFFECTS:
        return material
    colour = next((material.textures[key] for key in ("albedo", "base_color", "tint") if key in material.textures), None)
    if colour is None or colour.kind == "solid":
        rgb = colour.model.color if colour is not None else (MATTE_ALBEDO,) * 3
        colour = TextureNode(SolidTexture(color=tuple(min(float(c), MATTE_ALBEDO) for c in rgb)), None, material.path)
    return MaterialNode(Lambertian(), material.name, material.path, {"albedo": colour})


def _without_glossy(graph):
    """The graph with every glossy material (conductors, rough and thin glass, plastics, principled
    materials) made a matte surface of its colour."""
    from scenefmt.graph import ShapeNode, SphereRunNode

    mattes: dict[int, object] = {}

    def matte(material):
        if material is None:
            return None
        if id(material) not in mattes:
            mattes[id(material)] = _matte_of(material)
        return mattes[id(material)]

    def member(m):
        if isinstance(m, ShapeNode):
            return [dataclasses.replace(m, material=matte(m.material))]
        if isinstance(m, SphereRunNode):
            return [dataclasses.replace(m, materials=[matte(x) for x in m.materials])]
        return [m]

    return _with_members(graph, member, materials=[matte(m) for m in graph.materials])


def variants(graph, max_depth: int) -> list[Variant]:
    """The scene without each expensive effect it has (see the module's docstring)."""
    from scenefmt.effects import summarize
    from scenefmt.scene import SolidBackground

    on = {e.key for e in summarize(graph).effects if e.on}
    out = []
    if max_depth > SHORT_DEPTH:
        out.append(Variant("path depth", f"max_depth {SHORT_DEPTH} instead of {max_depth}", graph, SHORT_DEPTH))
    if "media" in on:
        out.append(Variant("media", "the scene without its media", _without_media(graph)))
    if "environment" in on:
        out.append(Variant("environment map", "a black background instead",
                           dataclasses.replace(graph, background=SolidBackground(), environment=None)))
    if "defocus" in on:
        camera = graph.camera.model_copy(update={"defocus_angle": 0.0, "aperture": None})
        out.append(Variant("defocus", "a pinhole camera: aperture 0", dataclasses.replace(graph, camera=camera)))
    if "motion" in on:
        shutter = graph.shutter.model_copy(update={"close": graph.shutter.open})
        out.append(Variant("motion blur", "the shutter closed at its opening time", dataclasses.replace(graph, shutter=shutter)))
    if on & {"conductors", "rough_dielectrics", "plastics", "principled"}:
        out.append(Variant("glossy materials", "each a matte surface of its colour", _without_glossy(graph)))
    return out


def measure(graph, kernel, *, seconds: float, max_depth: Optional[int] = None, seed: Optional[int] = None,
            threads: Optional[int] = None) -> Measure:
    """Render `graph` (already at the width wanted) with the kernel `kernel` (KernelFeatures) for
    `seconds` of rendering; what it measured."""
    import numpy as np

    from renderer.compile import compile_scene
    from renderer.film import Film
    from renderer.flat import Frame
    from renderer.local_passes import LocalPasses
    from renderer import target as kernel_target
    from renderer.session import render_progressively
    from renderer.variants import GENERAL, features_of

    frame = Frame.of(graph)
    flat = compile_scene(graph)
    needed = features_of(graph)
    if not kernel.covers(needed):  # a variant that needs a path the scene's kernel lacks: the general one has it
        kernel = GENERAL
    before = kernel_target.thread_count()
    try:
        if threads is not None:
            kernel_target.set_thread_count(threads)
        executor = LocalPasses.for_frame(flat, frame, seed=seed, max_depth=max_depth)
        result = render_progressively(executor, Film.empty(frame.width, frame.height), target=1_000_000, needed=needed,
                                      features=kernel, kernel="general", time_budget=seconds)
    finally:
        kernel_target.set_thread_count(before)
    film = result.film
    n = max(film.samples, 2)
    mean = film.total / n
    sample_var = np.maximum(film.total_sq / n - mean * mean, 0.0) * n / (n - 1)  # each pixel's sample variance
    pixel_var = sample_var.mean(axis=2)
    pixels = pixel_var.size
    return Measure(result.stats.seconds / n, float(pixel_var.sum()), float(mean.mean()),
                   math.sqrt(float(pixel_var.sum()) / n) / pixels, film.samples)


def costs(graph, kernel, *, max_depth: Optional[int] = None, seed: Optional[int] = None, threads: Optional[int] = None,
          width: int = COST_WIDTH, total_seconds: float = REPORT_SECONDS, seconds_each: Optional[float] = None,
          say: Optional[Callable[[str], None]] = None) -> list[Cost]:
    """What each expensive effect of `graph` costs (Cost), from renders of `total_seconds` in all
    (or `seconds_each` each) at `width` (never wider than the scene's own image)."""
    from renderer.compile import with_width

    depth = max_depth if max_depth is not None else graph.image.max_depth
    small = with_width(graph, min(width, graph.image.width))
    found = variants(small, depth)
    if not found:
        return []
    each = seconds_each or max(SECONDS_LEAST, min(SECONDS_MOST, total_seconds / (len(found) + 1)))
    if say is not None:
        names = ", ".join(v.effect for v in found)
        say(f"explain: measuring what each effect costs ({names}): {len(found) + 1} renders of {each:.1f} s at "
            f"{small.image.width} px, about {each * (len(found) + 1):.0f} s")
    base = measure(small, kernel, seconds=each, max_depth=depth, seed=seed, threads=threads)
    out = []
    for variant in found:
        other = measure(variant.graph, kernel, seconds=each, max_depth=variant.max_depth or depth, seed=seed, threads=threads)
        out.append(compare(variant, base, other))
    return out


def compare(variant: Variant, base: Measure, without: Measure) -> Cost:
    """The cost of `variant`'s effect: the scene with it (`base`) against the scene without it."""
    def ratio(a: float, b: float) -> float:
        return a / b if b > 0 else (1.0 if a == 0 else math.inf)

    time = ratio(base.sample_seconds, without.sample_seconds)
    noise = math.sqrt(ratio(base.variance, without.variance))
    if base.mean > 0:
        bias = (without.mean - base.mean) / base.mean
        bias_error = math.hypot(base.mean_error, without.mean_error) / base.mean
    else:
        bias, bias_error = 0.0, 0.0
    return Cost(variant.effect, variant.change, time, noise, bias, bias_error, dark=base.mean > 0 and without.mean == 0)
