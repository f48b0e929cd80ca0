"""Which effects a scene calls for, and the scene element that switches each one on.

Computed from the node graph alone (no numpy, no Numba), so `rt validate` can print it and
the renderer can choose a kernel that simulates nothing the scene does not use.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator, Union

from . import affine
from .diagnostics import format_path
from .graph import GroupNode, InstanceNode, SceneGraph, ShapeNode, TextureNode
from .scene import SkyBackground

EFFECT_NAMES = (
    "motion blur",
    "defocus",
    "media",
    "textures",
    "instances",
    "emitters",
    "dielectrics",
)


@dataclass(frozen=True)
class Effect:
    name: str
    on: bool
    reason: str = ""

    def __str__(self) -> str:
        return f"{self.name}: {'on' if self.on else 'off'}" + (f" ({self.reason})" if self.reason else "")


@dataclass
class SceneSummary:
    """Counts by kind and the effects in use."""

    shape_counts: dict[str, int] = field(default_factory=dict)
    instanced_shape_counts: dict[str, int] = field(default_factory=dict)
    definition_counts: dict[str, int] = field(default_factory=dict)
    texture_kinds: list[str] = field(default_factory=list)
    background: str = "solid"
    effects: list[Effect] = field(default_factory=list)

    def effect(self, name: str) -> Effect:
        return next(e for e in self.effects if e.name == name)

    def to_json(self) -> dict:
        return {
            "shapes": self.shape_counts,
            "shapes_in_groups": self.instanced_shape_counts,
            "definitions": self.definition_counts,
            "texture_kinds": self.texture_kinds,
            "background": self.background,
            "effects": {e.name: {"on": e.on, "reason": e.reason} for e in self.effects},
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


def _texture_tree(tex: TextureNode) -> Iterator[TextureNode]:
    yield tex
    for child in tex.inputs.values():
        yield from _texture_tree(child)


def _first(items, text) -> str:
    return text(items[0]) + (f" and {len(items) - 1} more" if len(items) > 1 else "")


def summarize(graph: SceneGraph) -> SceneSummary:
    summary = SceneSummary()
    moving: list[ShapeNode] = []
    with_media: list[ShapeNode] = []
    placed: list[Union[ShapeNode, InstanceNode]] = []
    emitters: list = []
    dielectrics: list = []
    textures_by_kind: dict[str, list[TextureNode]] = {}
    for member, inside in _members(graph.root, set()):
        counts = summary.instanced_shape_counts if inside else summary.shape_counts
        counts[member.kind] = counts.get(member.kind, 0) + 1
        if isinstance(member, InstanceNode) or not affine.is_identity(member.transform):
            placed.append(member)
        if isinstance(member, ShapeNode):
            if member.kind == "moving_sphere" and member.model.center0 != member.model.center1:
                moving.append(member)
            if member.interior is not None:
                with_media.append(member)
            if member.material is not None and member.material.kind == "diffuse_light":
                emitters.append(member)
            if member.material is not None and member.material.kind == "dielectric":
                dielectrics.append(member)
            textures = list(member.material.textures.values()) if member.material is not None else []
            if member.interior is not None:
                textures.append(member.interior.albedo)
            for root in textures:
                for tex in _texture_tree(root):
                    if tex.kind != "solid":
                        textures_by_kind.setdefault(tex.kind, []).append(member)
    shutter = graph.shutter
    cam = graph.camera
    effects = []
    if moving and shutter.close > shutter.open:
        effects.append(Effect("motion blur", True, _first(moving, lambda m: f"{format_path(m.path)} moves, shutter {shutter.open:g}..{shutter.close:g}")))
    elif moving:
        effects.append(Effect("motion blur", False, f"{format_path(moving[0].path)} moves, but the shutter interval is empty"))
    else:
        effects.append(Effect("motion blur", False))
    if cam.lens_radius > 0:
        how = f"aperture {cam.aperture:g}" if cam.aperture else f"defocus_angle {cam.defocus_angle:g}"
        effects.append(Effect("defocus", True, f"camera {how}, focus distance {cam.focus:g}"))
    else:
        effects.append(Effect("defocus", False))
    effects.append(
        Effect("media", True, _first(with_media, lambda m: f"{format_path(m.path)} holds {m.interior.name or 'a medium'}"))
        if with_media else Effect("media", False)
    )
    summary.texture_kinds = sorted(textures_by_kind)
    effects.append(
        Effect("textures", True, ", ".join(f"{k} on {format_path(v[0].path)}" for k, v in sorted(textures_by_kind.items())))
        if textures_by_kind else Effect("textures", False)
    )
    effects.append(
        Effect("instances", True, _first(placed, lambda m: f"{format_path(m.path)} is " + ("an instance" if isinstance(m, InstanceNode) else "transformed")))
        if placed else Effect("instances", False)
    )
    effects.append(
        Effect("emitters", True, _first(emitters, lambda m: f"{format_path(m.path)} emits"))
        if emitters else Effect("emitters", False)
    )
    effects.append(
        Effect("dielectrics", True, _first(dielectrics, lambda m: f"{format_path(m.path)} is glass-like"))
        if dielectrics else Effect("dielectrics", False)
    )
    summary.effects = effects
    summary.background = "sky" if isinstance(graph.background, SkyBackground) else "solid"
    summary.definition_counts = {
        "textures": len({id(t) for t in graph.textures if t.name is not None}),
        "materials": len({id(m) for m in graph.materials if m.name is not None}),
        "media": len({id(m) for m in graph.media if m.name is not None}),
        "groups": len(graph.groups),
    }
    return summary
