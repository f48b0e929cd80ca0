"""The sections of the reference, the models each holds, and the headings and anchors they get."""

from __future__ import annotations

import re
import typing
from dataclasses import dataclass, field

from pydantic import BaseModel

from ..materials import Material
from ..media import Medium
from ..lights import Light
from ..scene import Background, Scene
from ..shapes import Group, Shape
from ..textures import Texture
from ..transforms import TransformStep
from .walk import direct_models, unwrap_annotated, union_models, walk_models


@dataclass(eq=False)
class Section:
    """One `##` section of the reference."""

    title: str
    models: list[type[BaseModel]]
    intro: str = ""
    noun: str = ""  # what one of its models is called, e.g. "texture"; "" for Scene, Camera, ...
    plural: str = ""
    single: bool = False  # one model whose table sits directly under the section heading
    list_kinds: bool = False  # name each kind where a field takes any of them, rather than the noun
    sub: dict[type[BaseModel], list[type[BaseModel]]] = field(default_factory=dict)

    @property
    def anchor(self) -> str:
        return slug(self.title)


def type_value(model: type[BaseModel]) -> str | None:
    """The `type:` literal that selects a model, if it has one."""
    info = model.model_fields.get("type")
    if info is None:
        return None
    args = typing.get_args(info.annotation)
    return str(args[0]) if args else None


def step_key(model: type[BaseModel]) -> str | None:
    """The key of a transform step model (its only field)."""
    fields = list(model.model_fields)
    return fields[0] if len(fields) == 1 and model in union_models(TransformStep) else None


def heading_title(model: type[BaseModel], section: Section | None) -> str:
    """The heading text of a model: "Camera", "`sphere` shape", "`translate` step", or its class name."""
    if section is not None and section.single and section.models == [model]:
        return section.title
    key = type_value(model)
    if key is not None and section is not None and section.noun:
        return f"`{key}` {section.noun}"
    key = step_key(model)
    if key is not None:
        return f"`{key}` step"
    return model.__name__


def slug(title: str) -> str:
    """The anchor GitHub (and Python-Markdown's toc) give a heading."""
    text = title.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def build_sections() -> list[Section]:
    """The sections of the reference, in order; the models of each come from the format's unions."""
    scene_fields = Scene.model_fields
    sections = [
        Section("Scene", [Scene], single=True),
        Section("Camera", [unwrap_annotated(scene_fields["camera"].annotation)[0]], single=True),
        Section("Image", [unwrap_annotated(scene_fields["image"].annotation)[0]], single=True),
        Section("Shutter", [unwrap_annotated(scene_fields["shutter"].annotation)[0]], single=True),
        Section(
            "Background",
            union_models(Background),
            intro="`background:` gives the radiance of rays that leave the scene without hitting anything. "
            "Besides the kinds below, a bare colour `[r, g, b]` is shorthand for `{type: solid, color: [r, g, b]}`: "
            "`background: [0.7, 0.8, 1.0]`.",
            noun="background",
            plural="backgrounds",
            list_kinds=True,
        ),
        Section(
            "Textures",
            union_models(Texture),
            intro="Defined by name under `textures:`. A texture slot (a material's `albedo` or `emit`, a checker's "
            "`even` and `odd`, a medium's `albedo`) takes a colour `[r, g, b]`, the name of a texture, or an "
            "inline texture.",
            noun="texture",
            plural="textures",
        ),
        Section(
            "Materials",
            union_models(Material),
            intro="Defined by name under `materials:`. A shape's `material:` takes a material's name or an inline "
            "material.",
            noun="material",
            plural="materials",
        ),
        Section(
            "Media",
            union_models(Medium),
            intro="Participating media (smoke, fog) are defined by name under `media:` and fill a closed shape "
            "(`sphere`, `moving_sphere`, `box`) that names one as its `interior:`.",
            noun="medium",
            plural="media",
        ),
        Section(
            "Shapes",
            union_models(Shape),
            intro="The shapes of the scene are listed under `shapes:` (and under a group's `shapes:`). Every shape "
            "takes a `transform`. Surfaces (`quad`, `triangle`, `disk`) need a `material`; closed shapes (`sphere`, "
            "`moving_sphere`, `box`) take a `material`, an `interior` medium, or both.",
            noun="shape",
            plural="shapes",
        ),
        Section(
            "Lights",
            union_models(Light),
            intro="Lights that are no shape are listed under `lights:`, in world space (no transform or group applies "
            "to them). A point or spot light's `intensity` is in W/sr and its `power` in watts, a directional light's "
            "`irradiance` in W/m^2; each is a number or a colour `[r, g, b]`, and with a `temperature` (kelvin) a "
            "number, the luminance of a black body's colour. Point, spot and directional lights are deltas: no ray "
            "meets them by chance, so they light a scene only with `integrator: mis` (the default), which samples "
            "them and gives their samples full weight. An emitting shape (a `diffuse_light` material) is a light "
            "too. docs/lights.md gives the formulas and conventions.",
            noun="light",
            plural="lights",
        ),
        Section(
            "Groups",
            [Group],
            intro="Defined by name under `groups:` (or written inline as an instance's `group:`).",
            noun="group",
            plural="groups",
            single=True,
        ),
        Section(
            "Transform steps",
            union_models(TransformStep),
            intro="A `transform:` is an ordered list of steps, applied first to last. Each step is a mapping with "
            "one key that names its kind, so `[{rotate: {axis: y, degrees: 15}}, {translate: [265, 0, 295]}]` "
            "reads as it acts: rotate, then move.",
            noun="step",
            plural="steps",
        ),
    ]
    # A model used only inside another section's model (a rotate step's Rotation) follows its user.
    placed = {m for s in sections for m in s.models}
    for model in walk_models(Scene):
        if model in placed:
            continue
        for s in sections:
            users = [m for m in s.models if any(model in direct_models(f.annotation) for f in m.model_fields.values())]
            if users:
                s.sub.setdefault(users[0], []).append(model)
                placed.add(model)
                break
    missing = [m.__name__ for m in walk_models(Scene) if m not in placed]
    if missing:
        raise RuntimeError(f"scenefmt.docgen has no section for {', '.join(missing)}; add one in build_sections()")
    return sections

