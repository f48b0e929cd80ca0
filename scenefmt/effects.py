"""Which effects a scene calls for, and the scene element that switches each one on.

Computed from the node graph alone (no numpy, no Numba), so `rt validate` can print it and
the renderer can choose a kernel that simulates nothing the scene does not use.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator, Union

from . import affine
from .diagnostics import format_path
from .effect_flags import EFFECT_FLAGS
from .graph import GroupNode, InstanceNode, SceneGraph, ShapeNode, SphereRunNode, TextureNode
from .many_lights import LIGHT_TREE_THRESHOLD, count_lights, wants_light_tree
from .materials import SCALAR_SLOTS, emits
from .scene import LIGHT_SAMPLING_INTEGRATORS, ImageBackground, SkyBackground
from .sky import SunSkyBackground

# (key, name), from the one table of effects: the key is the kernel path's flag
# (renderer/kernel_flags.py), the name is what users read.
EFFECTS = tuple((flag.key, flag.name) for flag in EFFECT_FLAGS)
EFFECT_NAMES = tuple(name for _, name in EFFECTS)


@dataclass(frozen=True)
class Effect:
    name: str
    on: bool
    reason: str = ""
    key: str = ""  # the kernel path it switches on

    def __str__(self) -> str:
        return f"{self.name}: {'on' if self.on else 'off'}" + (f" ({self.reason})" if self.reason else "")


@dataclass(frozen=True)
class LightKind:
    """One kind of light a scene has: how many, and what in the scene makes them."""

    kind: str  # area, environment, point, spot, directional, sun
    count: int
    reason: str

    def __str__(self) -> str:
        return f"{self.kind}: {self.count} ({self.reason})"


@dataclass
class SceneSummary:
    """Counts by kind and the effects in use."""

    shape_counts: dict[str, int] = field(default_factory=dict)
    instanced_shape_counts: dict[str, int] = field(default_factory=dict)
    definition_counts: dict[str, int] = field(default_factory=dict)
    texture_kinds: list[str] = field(default_factory=list)
    background: str = "solid"
    effects: list[Effect] = field(default_factory=list)
    lights: list[LightKind] = field(default_factory=list)  # the kinds present, in the light table's order

    def effect(self, name: str) -> Effect:
        """The effect called `name` (as printed) or keyed `name` (as the kernel's flag)."""
        return next(e for e in self.effects if name in (e.name, e.key))

    @property
    def kernel_paths(self) -> dict[str, bool]:
        """Which kernel paths the scene needs, by flag name."""
        return {e.key: e.on for e in self.effects}

    def to_json(self) -> dict:
        return {
            "shapes": self.shape_counts,
            "shapes_in_groups": self.instanced_shape_counts,
            "definitions": self.definition_counts,
            "texture_kinds": self.texture_kinds,
            "background": self.background,
            "effects": {e.name: {"on": e.on, "reason": e.reason} for e in self.effects},
            "lights": {light.kind: {"count": light.count, "reason": light.reason} for light in self.lights},
        }


def _members(group: GroupNode, seen: set) -> Iterator[tuple[Union[ShapeNode, InstanceNode], bool]]:
    """Every member reachable from `group`; the flag says whether it sits inside an instanced group."""
    stack = [(group, False)]
    while stack:
        g, inside = stack.pop()
        for m in g.members:
            yield m, inside
            if isinstance(m, InstanceNode) and id(m.group) not in seen:
                seen.add(id(m.group))
                stack.append((m.group, True))


# Which effect each material kind calls for, and how `rt validate` says why.
MATERIAL_KIND_EFFECTS = {"conductor": "conductors", "rough_dielectric": "rough_dielectrics",
                         "thin_dielectric": "rough_dielectrics", "plastic": "plastics", "principled": "principled"}
MATERIAL_EFFECT_REASONS = {
    "conductors": "is a conductor", "rough_dielectrics": "is rough or thin glass", "plastics": "is a plastic",
    "principled": "is a principled material", "surface_maps": "has a normal or bump map",
    "parameter_textures": "reads a parameter from a texture",
}


def material_effects(material) -> list[str]:
    """The effect keys a material node calls for by its kind, its maps and its textured parameters."""
    keys = []
    kind = MATERIAL_KIND_EFFECTS.get(material.kind)
    if kind is not None:
        keys.append(kind)
    if "normal_map" in material.textures or "bump_map" in material.textures:
        keys.append("surface_maps")
    if any(slot in SCALAR_SLOTS for slot in material.textures):
        keys.append("parameter_textures")
    return keys


def _texture_tree(tex: TextureNode) -> Iterator[TextureNode]:
    yield tex
    for child in tex.inputs.values():
        yield from _texture_tree(child)


@dataclass(frozen=True)
class _RunPart:
    """The spheres of a run that share one material: where the first is, and how many there are."""

    path: tuple
    count: int


@dataclass(frozen=True)
class _Camera:
    """The camera, where effects name what moves."""

    path: tuple = ("camera",)


def _first(items, text) -> str:
    more = sum(item.count if isinstance(item, _RunPart) else 1 for item in items) - 1
    return text(items[0]) + (f" and {more} more" if more > 0 else "")


def _needs_instance(member: Union[ShapeNode, InstanceNode], similar: dict) -> Union[str, None]:
    """Why a member keeps a transform of its own in the kernels (None if it is baked in).
    `similar` remembers which transforms are similarities: a scene's many shapes share a few."""
    if member.motion is not None:
        return "moves: its keyframes place it at each ray's time"
    if isinstance(member, InstanceNode):
        return "is an instance"
    if member.kind in ("sphere", "moving_sphere"):
        known = similar.get(member.transform)
        if known is None:
            known = similar[member.transform] = affine.similarity_scale(affine.linear(member.transform)) is not None
        if not known:
            return "is a sphere under a non-uniform scale or shear"
    return None


def sun_sky_effects(bg: SunSkyBackground, integrator: str) -> dict[str, Effect]:
    """The effects a `sun_sky` background calls for: its sky is an environment map (even without
    a sky: the map is then black, and the sun's disc is looked up beside it), and its sun a light
    that is no shape, which rays escaping toward its disc meet whatever the integrator."""
    how = "sampled as a light" if integrator in LIGHT_SAMPLING_INTEGRATORS else "found by chance (image.integrator is path)"
    found = {"environment": Effect("", True, f"background: sun_sky, its sky {how}" if bg.sky else
                                   "background: sun_sky, the sun's disc beside a black sky")}
    if bg.sun:
        found["punctual"] = Effect("", True, f"background: sun_sky, its sun {how}")
    return found


def _placed_emitters(group: GroupNode, memo: dict) -> int:
    """How many emitting shapes `group` places, each group counted once per instance that places it
    (a sphere run's spheres one by one)."""
    known = memo.get(id(group))
    if known is not None:
        return known
    total = 0
    for m in group.members:
        if isinstance(m, InstanceNode):
            total += _placed_emitters(m.group, memo)
        elif isinstance(m, SphereRunNode):
            total += sum(int(count) for material, count in zip(m.materials, m.material_count.tolist()) if emits(material.model))
        elif m.material is not None and emits(m.material.model):
            total += 1
    memo[id(group)] = total
    return total


def light_kinds(graph: SceneGraph, emitters: list) -> list[LightKind]:
    """The kinds of light `graph` has, with their counts and what makes them, in the light table's
    order: emitting shapes (`emitters`, as summarize found them: each shape once, however often
    instances place it), the environment map, the lights under `lights:`, the sun."""
    found = []
    if emitters:
        defined = sum(item.count if isinstance(item, _RunPart) else 1 for item in emitters)
        placed = _placed_emitters(graph.root, {})
        reason = _first(emitters, lambda m: f"{format_path(m.path)} emits")
        if placed != defined:
            reason += f"; {placed} in all, as instances place them"
        found.append(LightKind("area", placed, reason))
    if isinstance(graph.background, ImageBackground):
        found.append(LightKind("environment", 1, f"background: {{type: image, file: {graph.background.file}}}"))
    if isinstance(graph.background, SunSkyBackground) and graph.background.sky and graph.background.strength > 0:
        found.append(LightKind("environment", 1, "background: {type: sun_sky, sky: true}, its sky as a map"))
    for kind in ("point", "spot", "directional"):
        which = [k for k, light in enumerate(graph.lights) if light.type == kind]
        if which:
            more = f" and {len(which) - 1} more" if len(which) > 1 else ""
            found.append(LightKind(kind, len(which), f"lights[{which[0]}]{more}"))
    background = graph.background
    if getattr(background, "type", None) == "sun_sky" and getattr(background, "sun", False):
        found.append(LightKind("sun", 1, "background: {type: sun_sky, sun: true}"))
    return found


def medium_effects(with_media: list) -> dict:
    """The effects of the media the shapes `with_media` hold, beyond the constant medium: a density
    that varies (a grid or noise medium) and an anisotropic phase function."""
    found = {}
    varying = [m for m in with_media if m.interior.kind != "constant"]
    if varying:
        found["varying_media"] = Effect("", True, _first(varying, lambda m: (
            f"{format_path(m.path)} holds {m.interior.name or 'a medium'}, a {m.interior.kind} medium")))
    forward = [m for m in with_media if m.interior.model.phase_g != 0.0]
    if forward:
        found["phase_hg"] = Effect("", True, _first(forward, lambda m: (
            f"{format_path(m.path)} holds {m.interior.name or 'a medium'}, whose phase is henyey_greenstein "
            f"(g {m.interior.model.phase_g:g})")))
    return found


def summarize(graph: SceneGraph) -> SceneSummary:
    summary = SceneSummary()
    moving: list[ShapeNode] = []
    with_media: list[ShapeNode] = []
    placed: list[tuple[Union[ShapeNode, InstanceNode], str]] = []
    emitters: list = []
    dielectrics: list = []
    mirrors: list = []  # the books' metals: a delta lobe, like glass, that light sampling cannot see through
    with_meshes: list[ShapeNode] = []
    textures_by_kind: dict[str, list[ShapeNode]] = {}
    by_material_effect: dict[str, list] = {}  # effect key -> the members whose material calls for it
    similar: dict = {}  # transform -> whether it is a similarity
    kinds_of: dict = {}  # (material, medium) -> the kinds of texture they read, but solid
    def texture_kinds(material, interior) -> list[str]:
        """The kinds of texture a material and medium read, but solid."""
        key = (id(material), id(interior))
        kinds = kinds_of.get(key)
        if kinds is None:
            textures = list(material.textures.values()) if material is not None else []
            if interior is not None:
                textures.append(interior.albedo)
            kinds = kinds_of[key] = [tex.kind for root in textures for tex in _texture_tree(root) if tex.kind != "solid"]
        return kinds

    for member, inside in _members(graph.root, set()):
        counts = summary.instanced_shape_counts if inside else summary.shape_counts
        if isinstance(member, SphereRunNode):
            counts["sphere"] = counts.get("sphere", 0) + len(member)
            for material, first, count in zip(member.materials, member.material_first.tolist(), member.material_count.tolist()):
                part = _RunPart(member.path_of(first), count)
                if emits(material.model):
                    emitters.append(part)
                if material.kind == "dielectric":
                    dielectrics.append(part)
                if material.kind == "metal":
                    mirrors.append(part)
                for key in material_effects(material):
                    by_material_effect.setdefault(key, []).append(part)
                for kind in texture_kinds(material, None):
                    textures_by_kind.setdefault(kind, []).append(part)
            continue
        counts[member.kind] = counts.get(member.kind, 0) + 1
        why = _needs_instance(member, similar)
        if why is not None:
            placed.append((member, why))
        if member.motion is not None:
            moving.append(member)
        if isinstance(member, ShapeNode):
            if member.kind == "moving_sphere" and member.model.center0 != member.model.center1:
                moving.append(member)
            if member.interior is not None:
                with_media.append(member)
            if member.kind == "mesh":
                with_meshes.append(member)
            if member.material is not None and emits(member.material.model):
                emitters.append(member)
            if member.material is not None and member.material.kind == "dielectric":
                dielectrics.append(member)
            if member.material is not None and member.material.kind == "metal":
                mirrors.append(member)
            if member.material is not None:
                for key in material_effects(member.material):
                    by_material_effect.setdefault(key, []).append(member)
            for kind in texture_kinds(member.material, member.interior):
                textures_by_kind.setdefault(kind, []).append(member)
    shutter = graph.shutter
    cam = graph.camera
    if cam.moves:
        moving.insert(0, _Camera())
    found: dict[str, Effect] = {}
    if moving and shutter.close > shutter.open:
        found["motion"] = Effect("", True, _first(moving, lambda m: f"{format_path(m.path)} moves, shutter {shutter.open:g}..{shutter.close:g}"))
    elif moving:
        found["motion"] = Effect("", False, f"{format_path(moving[0].path)} moves, but the shutter interval is empty")
    if cam.lens_radius > 0:
        how = f"aperture {cam.aperture:g}" if cam.aperture else f"defocus_angle {cam.defocus_angle:g}"
        found["defocus"] = Effect("", True, f"camera {how}, focus distance {cam.focus:g}")
    if with_media:
        found["media"] = Effect("", True, _first(with_media, lambda m: f"{format_path(m.path)} holds {m.interior.name or 'a medium'}"))
        found.update(medium_effects(with_media))
    if placed:
        found["instances"] = Effect("", True, _first(placed, lambda mw: f"{format_path(mw[0].path)} {mw[1]}"))
    for kind, members in textures_by_kind.items():
        found[kind] = Effect("", True, _first(members, lambda m: f"{format_path(m.path)} uses one"))
    if emitters:
        found["emitters"] = Effect("", True, _first(emitters, lambda m: f"{format_path(m.path)} emits"))
    if dielectrics:
        found["dielectrics"] = Effect("", True, _first(dielectrics, lambda m: f"{format_path(m.path)} is glass-like"))
    if isinstance(graph.background, SkyBackground):
        found["sky"] = Effect("", True, "background: {type: sky}")
    if isinstance(graph.background, ImageBackground):
        how = "sampled as a light" if graph.image.integrator in LIGHT_SAMPLING_INTEGRATORS else "found by chance (image.integrator is path)"
        found["environment"] = Effect("", True, f"background: {{type: image, file: {graph.background.file}}}, {how}")
    if isinstance(graph.background, SunSkyBackground):
        found.update(sun_sky_effects(graph.background, graph.image.integrator))
    if emitters and graph.image.integrator in LIGHT_SAMPLING_INTEGRATORS:
        found["lights"] = Effect("", True, _first(emitters, lambda m: f"{format_path(m.path)} is sampled as a light"))
    elif emitters:
        found["lights"] = Effect("", False, "image.integrator is path: lights are found only by chance")
    if emitters or getattr(graph, "lights", None):
        count = count_lights(graph)
        if wants_light_tree(graph, count):
            found["light_tree"] = Effect("", True, f"{count.reason}; a tree chooses among them by what each may send")
        elif count.total > 1 and graph.image.integrator in LIGHT_SAMPLING_INTEGRATORS:
            found["light_tree"] = Effect("", False, f"{count.reason}; fewer than {LIGHT_TREE_THRESHOLD}: chosen by power")
    for key, members in by_material_effect.items():
        found[key] = Effect("", True, _first(members, lambda m, key=key: f"{format_path(m.path)} {MATERIAL_EFFECT_REASONS[key]}"))
    if with_meshes:
        found["meshes"] = Effect("", True, _first(with_meshes, lambda m: f"{format_path(m.path)} is a mesh"))
    punctual = [(k, light) for k, light in enumerate(graph.lights)]
    if punctual and graph.image.integrator in LIGHT_SAMPLING_INTEGRATORS:
        found["punctual"] = Effect("", True, _first(punctual, lambda kl: f"lights[{kl[0]}] is a {kl[1].type} light"))
    elif punctual and "punctual" not in found:  # a sun's disc keeps the path on: escaping rays meet it
        found["punctual"] = Effect("", False, "image.integrator is path: point, spot and directional lights are never found")
    if graph.image.integrator == "guided":
        found["guiding"] = Effect("", True, "image.integrator is guided: a short training render learns where light "
                                  "arrives from, and diffuse bounces follow it")
    if graph.image.integrator == "caustics":
        found["caustics"] = Effect("", True, "image.integrator is caustics: photons from the lights through glass and "
                                   "mirror spheres onto matte surfaces, joined to the camera")
    elif (dielectrics or mirrors) and graph.image.integrator in LIGHT_SAMPLING_INTEGRATORS and (
            emitters or graph.lights or isinstance(graph.background, (ImageBackground, SunSkyBackground))):
        specular = _first(dielectrics + mirrors, lambda m: f"{format_path(m.path)} is glass or a mirror")
        found["caustics"] = Effect("", False, f"{specular}: light that reaches matte surfaces through it is found only "
                                   "by chance; image.integrator caustics traces it from the lights (docs/integrators.md)")
    summary.effects = [
        Effect(name, found[key].on, found[key].reason, key) if key in found else Effect(name, False, "", key)
        for key, name in EFFECTS
    ]
    summary.lights = light_kinds(graph, emitters)
    summary.texture_kinds = sorted(textures_by_kind)
    summary.background = graph.background.type
    summary.definition_counts = {
        "textures": len({id(t) for t in graph.textures if t.name is not None}),
        "materials": len({id(m) for m in graph.materials if m.name is not None}),
        "media": len({id(m) for m in graph.media if m.name is not None}),
        "groups": len(graph.groups),
    }
    return summary
