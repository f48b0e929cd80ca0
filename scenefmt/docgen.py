"""Generate `docs/format.md`, the reference of every type and field of the scene format, from the models.

Everything below the hand-written introduction comes from the models: each model's docstring
(one descriptive paragraph, then a ```yaml example), and each field's annotation, constraints,
default and `description`. `python -m scenefmt.docgen` rewrites the committed file;
`python -m scenefmt.docgen --check` exits 1 when it is out of date.

Pure Python: it needs pydantic and the scene models only (no numpy, no numba).
"""

from __future__ import annotations

import difflib
import inspect
import json
import math
import re
import sys
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Literal, Union

from pydantic import BaseModel, Discriminator
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from . import scene as _scene_module
from .base import Color, Name, Vec3
from .materials import Material, MaterialSlot
from .media import Medium, MediumSlot
from .scene import Background, Scene
from .writing import field_default
from .shapes import Group, GroupSlot, Shape
from .textures import Texture, TextureSlot
from .transforms import Transform, TransformStep

DOC_PATH = Path(__file__).resolve().parent.parent / "docs" / "format.md"
REGENERATE = "python -m scenefmt.docgen"

INTRODUCTION = """\
# Scene file format reference

<!-- Generated from the models in scenefmt/ by `python -m scenefmt.docgen`; do not edit by hand. -->

A scene file describes everything `rt` needs to render one image: the camera, the image size
and sampling, the shutter interval, the background, and the shapes with their materials,
textures and participating media. It is written in YAML or JSON; both syntaxes load to the
same models, so anything below can be written either way (the examples are YAML).

```yaml
# yaml-language-server: $schema=../schemas/scene.schema.json
version: 1
camera: {look_from: [0, 0, 9], look_at: [0, 0, 0], vfov: 80}
materials:
  red: {type: lambertian, albedo: [1.0, 0.2, 0.2]}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: red}
```

- **Version.** Every file should start with `version: 1`, the version of the format this
  release reads. Keys not listed below are errors, so a misspelt key never goes unnoticed.
- **Named definitions.** Textures, materials, media and groups of shapes are defined once,
  by name, under `textures:`, `materials:`, `media:` and `groups:`, and referred to by that
  name wherever they are used. Wherever a name is accepted, an inline definition is accepted
  too (`material: {type: metal, fuzz: 0.1}` instead of `material: brass`). A name starts with
  a letter or `_`, continues with letters, digits, `_`, `.` or `-`, and is at most
  {name_max} characters long.
- **Colours** are linear RGB triples `[r, g, b]` with components >= 0; reflectances
  (albedos) normally stay within 0..1, while emitters may exceed 1 (`emit: [15, 15, 15]`).
- **Angles** are in degrees.
- **Transforms.** A shape's (or an instance's) `transform:` is an ordered list of steps,
  applied first to last: `[{rotate: {axis: y, degrees: 15}}, {translate: [265, 0, 295]}]`
  rotates, then moves.
- **Editor support.** A first line `# yaml-language-server: $schema=...` pointing at the
  JSON Schema (`schemas/scene.schema.json`; the path is relative to the scene file) gives
  completion, hover help and live checking in editors that use the YAML language server;
  `rt schema` prints the schema.
- **Checking.** `rt validate scene.yaml` checks a file without rendering it and reports every
  problem with its line and column.

In the tables below, *Default* is the value a key takes when it is left out; **required** keys
have none. A `type` key selects the kind of a definition and must be given (except on a group).
"""

# How the named type aliases read to a human; the keys are the aliases themselves.
# Links point at the sections of this document.
ALIAS_WORDING: list[tuple[Any, str]] = [
    (TextureSlot, "`[r, g, b]`, texture name or [texture](#textures)"),
    (MaterialSlot, "material name or [material](#materials)"),
    (MediumSlot, "medium name or [medium](#media)"),
    (GroupSlot, "group name or [group](#groups)"),
    (Transform, "list of [transform steps](#transform-steps)"),
    (Vec3, "`[x, y, z]`"),
    (Color, "`[r, g, b]` >= 0"),
    (Name, "name"),
]


def _ratio_pattern() -> str | None:
    ratio = getattr(_scene_module, "_RATIO", None)
    return getattr(ratio, "pattern", None)


# Human wording of the string patterns the format uses; any other pattern is shown as a regex.
PATTERN_WORDING: dict[str | None, str] = {
    _ratio_pattern(): '`"W:H"` (e.g. `"16:9"`)',
}


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


# ---------------------------------------------------------------------------------------------
# Types: flattening Annotated, telling aliases apart, and describing them for humans.


def _expand(meta: Iterable[Any]) -> tuple[list[Any], Any]:
    """Metadata with `FieldInfo`s replaced by their own metadata, and the discriminator if one is set.

    The discriminator is a field name (`"type"`) or a pydantic `Discriminator`; None when there is none.
    """
    out: list[Any] = []
    discriminator = None
    for m in meta:
        if isinstance(m, FieldInfo):
            out.extend(m.metadata)
            if m.discriminator is not None:
                discriminator = m.discriminator
        else:
            if isinstance(m, Discriminator):
                discriminator = m
            out.append(m)
    return out, discriminator


def flatten(tp: Any) -> tuple[Any, list[Any], Any]:
    """`(base type, metadata, discriminator)` of a possibly `Annotated` type."""
    meta: list[Any] = []
    discriminator = None
    while typing.get_origin(tp) is typing.Annotated:
        args = typing.get_args(tp)
        expanded, disc = _expand(args[1:])
        meta = expanded + meta
        discriminator = discriminator if discriminator is not None else disc
        tp = args[0]
    return tp, meta, discriminator


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b)
    except Exception:  # pragma: no cover - exotic metadata without a usable __eq__
        return a is b


def match_alias(base: Any, meta: list[Any]) -> str | None:
    """The human wording of a named alias when `base` + `meta` is (a use of) that alias."""
    for alias, wording in ALIAS_WORDING:
        abase, ameta, _ = flatten(alias)
        if _same(base, abase) and all(any(_same(m, x) for x in meta) for m in ameta):
            return wording
    return None


def _is_union(tp: Any) -> bool:
    return typing.get_origin(tp) in (Union, types.UnionType)


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _constraint(meta: list[Any], name: str) -> Any:
    """The last value of constraint `name` (gt, ge, max_length, pattern, ...) among the metadata."""
    value = None
    for m in meta:
        v = getattr(m, name, None)
        if v is not None and v is not PydanticUndefined:
            value = v
    return value


def _num(x: Any) -> str:
    """A bound, written compactly: 0 not 0.0, and 2^63-1 rather than its 19 digits."""
    if isinstance(x, float) and x.is_integer() and abs(x) < 2**53:
        x = int(x)
    if isinstance(x, int) and x > 2**20 and (x + 1) & x == 0:
        return f"2^{(x + 1).bit_length() - 1}-1"
    return str(x)


def _range(word: str, meta: list[Any]) -> str:
    gt, ge, lt, le = (_constraint(meta, k) for k in ("gt", "ge", "lt", "le"))
    if ge is not None and le is not None and gt is None and lt is None:
        return f"{word} {_num(ge)}..{_num(le)}"
    parts = []
    if gt is not None:
        parts.append(f"> {_num(gt)}")
    if ge is not None:
        parts.append(f">= {_num(ge)}")
    if lt is not None:
        parts.append(f"< {_num(lt)}")
    if le is not None:
        parts.append(f"<= {_num(le)}")
    return word + (" " + " and ".join(parts) if parts else "")


def _count(meta: list[Any]) -> tuple[Any, Any]:
    return _constraint(meta, "min_length"), _constraint(meta, "max_length")


def _literal(value: Any) -> str:
    return f"`{_yaml(value)}`"


class Describer:
    """Turns annotations into the *accepted values* wording, linking models to their headings."""

    def __init__(self, sections: list[Section]):
        self.sections = sections
        self.section_of: dict[type[BaseModel], Section] = {}
        for s in sections:
            for m in s.models:
                self.section_of[m] = s
            for subs in s.sub.values():
                for m in subs:
                    self.section_of[m] = s

    def model_link(self, model: type[BaseModel]) -> str:
        section = self.section_of.get(model)
        title = heading_title(model, section)
        if title.startswith("`"):
            label = title.split(" ")[0]
        elif section is not None and section.single and section.noun:
            label = section.noun
        else:
            label = title.lower()
        return f"[{label}](#{slug(title)})"

    def models_wording(self, models: list[type[BaseModel]], plural: bool = False) -> list[str]:
        """A union of models: the section's noun when it is all of them, else a link to each kind."""
        owners = {self.section_of.get(m) for m in models}
        if len(owners) == 1:
            (owner,) = owners
            if owner is not None and owner.noun and not owner.list_kinds and set(models) == set(owner.models):
                return [f"[{owner.plural if plural else owner.noun}](#{owner.anchor})"]
        return [self.model_link(m) for m in models]

    def describe(self, tp: Any, outer_meta: list[Any] | None = None, plural: bool = False) -> str:
        base, meta, _ = flatten(tp)
        meta = list(outer_meta or []) + meta
        wording = match_alias(base, meta)
        if wording is not None:
            return wording
        if _is_union(base):
            args = [a for a in typing.get_args(base) if a is not type(None)]
            if len(args) == 1:
                return self.describe(args[0], meta, plural)
            models = [flatten(a)[0] for a in args if _is_model(flatten(a)[0])]
            others: list[str] = []
            for a in args:
                if typing.get_origin(a) is Literal:  # x, y, z or [x, y, z]: the values read as alternatives
                    others += [_literal(v) for v in typing.get_args(a)]
                elif not _is_model(flatten(a)[0]):
                    others.append(self.describe(a, None, plural))
            if models:
                others += self.models_wording(models, plural)
            return _join_or(others)
        if _is_model(base):
            return _join_or(self.models_wording([base], plural))
        origin = typing.get_origin(base)
        args = typing.get_args(base)
        if origin is Literal:
            if len(args) == 1:
                return _literal(args[0])
            return "one of " + ", ".join(_literal(a) for a in args)
        if base is bool:
            return "`true` or `false`"
        if base is int:
            return _range("integers" if plural else "integer", meta)
        if base is float:
            return _range("numbers" if plural else "number", meta)
        if base is str:
            pattern = _constraint(meta, "pattern")
            if pattern is not None:
                return PATTERN_WORDING.get(pattern, f"text matching `{pattern}`")
            lo, hi = _count(meta)
            text = "non-empty text" if lo == 1 else "text"
            if lo is not None and lo > 1:
                text += f", at least {_num(lo)} characters"
            if hi is not None:
                text += f", at most {_num(hi)} characters"
            return text
        if origin is tuple and args and args[-1] is not Ellipsis:
            return "`[" + ", ".join(self.describe(a).strip("`") for a in args) + "]`"
        if origin is list:
            (item,) = args
            inner = self.describe(item, None, plural=True)
            lo, hi = _count(meta)
            if lo is not None and hi is not None:
                text = f"list of {_num(lo) if lo == hi else f'{_num(lo)}..{_num(hi)}'} {inner}"
            elif lo == 1:
                text = f"non-empty list of {inner}"
            else:
                text = f"list of {inner}"
                if lo is not None:
                    text += f", at least {_num(lo)}"
                if hi is not None:
                    text += f", at most {_num(hi)}"
            return text.replace("list of", "lists of", 1) if plural else text
        if origin is dict:
            key, value = args
            return f"mapping of {self.describe(key)} to {self.describe(value)}"
        raise TypeError(f"scenefmt.docgen cannot describe the annotation {tp!r}; teach Describer.describe about it")


def _join_or(parts: list[str]) -> str:
    if len(parts) <= 1:
        return "".join(parts)
    return ", ".join(parts[:-1]) + " or " + parts[-1]


# ---------------------------------------------------------------------------------------------
# Values: defaults written as YAML.


def plain(value: Any) -> Any:
    """Plain data for a default: models as their non-default fields (`type` kept), tuples as lists."""
    if isinstance(value, BaseModel):
        out: dict[str, Any] = {}
        fields = type(value).model_fields
        if "type" in fields:
            out["type"] = value.type
        for name, info in fields.items():
            if name == "type":
                continue
            current = getattr(value, name)
            if current != field_default(info):
                out[name] = plain(current)
        return out
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


_PLAIN_SCALAR = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")
# Plain words the scene loader (YAML 1.2 core schema) reads as something other than a string.
_YAML_WORDS = {"null", "true", "false"}


def _yaml(value: Any) -> str:
    """A value in YAML flow style, as a user would type it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if value.is_integer() and abs(value) < 2**53:
            return str(int(value))
        return repr(value) if math.isfinite(value) else str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        if _PLAIN_SCALAR.match(value) and value.lower() not in _YAML_WORDS:
            return value
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_yaml(k)}: {_yaml(v)}" for k, v in value.items()) + "}"
    return json.dumps(value)


# ---------------------------------------------------------------------------------------------
# Models: docstrings, field order, and the sections of the document.

_EXAMPLE = re.compile(r"```yaml\n(.*?)```", re.S)


def docstring(model: type[BaseModel]) -> str:
    return inspect.cleandoc(model.__dict__.get("__doc__") or "")


def description(model: type[BaseModel]) -> str:
    """The docstring's descriptive paragraph (everything before the example), on one line."""
    text = docstring(model).split("```", 1)[0]
    return " ".join(text.split())


def example(model: type[BaseModel]) -> str | None:
    """The ```yaml example of the model's docstring, or None when it has none."""
    m = _EXAMPLE.search(docstring(model))
    return m.group(1) if m else None


def ordered_fields(model: type[BaseModel]) -> list[str]:
    """`type` first, then the model's own fields, then inherited ones (nearest base first)."""
    names = list(model.model_fields)
    inherited: list[str] = []
    for base in model.__mro__[1:]:
        if isinstance(base, type) and issubclass(base, BaseModel) and base is not BaseModel:
            for name in base.__dict__.get("__annotations__", {}):
                if name in model.model_fields and name not in inherited:
                    inherited.append(name)
    own = [n for n in names if n not in inherited and n != "type"]
    return (["type"] if "type" in names else []) + own + inherited


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
    return fields[0] if len(fields) == 1 and model in _union_models(TransformStep) else None


def _union_models(tp: Any) -> list[type[BaseModel]]:
    """The models of a (possibly Annotated, possibly one-member) union, in order."""
    base, _, _ = flatten(tp)
    if _is_model(base):
        return [base]
    out = []
    for arg in typing.get_args(base):
        b, _, _ = flatten(arg)
        if _is_model(b):
            out.append(b)
    return out


def walk_models(root: type[BaseModel] = Scene) -> list[type[BaseModel]]:
    """Every model reachable from `root` through field annotations, in first-seen order."""
    seen: list[type[BaseModel]] = []

    def visit_type(tp: Any) -> None:
        if _is_model(tp):
            visit_model(tp)
            return
        for arg in typing.get_args(tp):
            if isinstance(arg, type) or typing.get_args(arg) or typing.get_origin(arg) is not None:
                visit_type(arg)

    def visit_model(model: type[BaseModel]) -> None:
        if model in seen:
            return
        seen.append(model)
        for info in model.model_fields.values():
            visit_type(info.annotation)

    visit_model(root)
    return seen


def _direct_models(tp: Any) -> list[type[BaseModel]]:
    """Models an annotation refers to directly (not through the fields of another model)."""
    base, _, _ = flatten(tp)
    if _is_model(base):
        return [base]
    out: list[type[BaseModel]] = []
    for arg in typing.get_args(base):
        if isinstance(arg, type) or typing.get_args(arg) or typing.get_origin(arg) is not None:
            out += [m for m in _direct_models(arg) if m not in out]
    return out


def _unions(tp: Any, outer: Any = None) -> Iterable[tuple[list[type[BaseModel]], Any]]:
    """Each union (or one-member discriminated union) inside an annotation: its models and discriminator."""
    base, _, disc = flatten(tp)
    disc = disc if disc is not None else outer
    if _is_union(base) or (_is_model(base) and disc is not None):
        yield _union_models(base), disc
    if not _is_model(base):
        for arg in typing.get_args(base):
            if isinstance(arg, type) or typing.get_args(arg) or typing.get_origin(arg) is not None:
                yield from _unions(arg)


def required_type_models(root: type[BaseModel] = Scene) -> set[type[BaseModel]]:
    """Models whose `type` key must be written: members of a union told apart by `type`.

    That is a union with `discriminator="type"`, or a union with a callable discriminator over
    several models that each have a `type` key (the background's). A group, reached by name or
    as the one model of a name-or-group slot, keeps its default `type`.
    """
    out: set[type[BaseModel]] = set()
    for model in walk_models(root):
        for info in model.model_fields.values():
            _, field_disc = _expand(info.metadata)
            field_disc = field_disc if field_disc is not None else info.discriminator
            for models, disc in _unions(info.annotation, field_disc):
                typed = [m for m in models if "type" in m.model_fields]
                if disc == "type" or (disc is not None and len(typed) >= 2):
                    out.update(typed)
    return out


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
        Section("Camera", [flatten(scene_fields["camera"].annotation)[0]], single=True),
        Section("Image", [flatten(scene_fields["image"].annotation)[0]], single=True),
        Section("Shutter", [flatten(scene_fields["shutter"].annotation)[0]], single=True),
        Section(
            "Background",
            _union_models(Background),
            intro="`background:` gives the radiance of rays that leave the scene without hitting anything. "
            "Besides the kinds below, a bare colour `[r, g, b]` is shorthand for `{type: solid, color: [r, g, b]}`: "
            "`background: [0.7, 0.8, 1.0]`.",
            noun="background",
            plural="backgrounds",
            list_kinds=True,
        ),
        Section(
            "Textures",
            _union_models(Texture),
            intro="Defined by name under `textures:`. A texture slot (a material's `albedo` or `emit`, a checker's "
            "`even` and `odd`, a medium's `albedo`) takes a colour `[r, g, b]`, the name of a texture, or an "
            "inline texture.",
            noun="texture",
            plural="textures",
        ),
        Section(
            "Materials",
            _union_models(Material),
            intro="Defined by name under `materials:`. A shape's `material:` takes a material's name or an inline "
            "material.",
            noun="material",
            plural="materials",
        ),
        Section(
            "Media",
            _union_models(Medium),
            intro="Participating media (smoke, fog) are defined by name under `media:` and fill a closed shape "
            "(`sphere`, `moving_sphere`, `box`) that names one as its `interior:`.",
            noun="medium",
            plural="media",
        ),
        Section(
            "Shapes",
            _union_models(Shape),
            intro="The shapes of the scene are listed under `shapes:` (and under a group's `shapes:`). Every shape "
            "takes a `transform`. Surfaces (`quad`, `triangle`, `disk`) need a `material`; closed shapes (`sphere`, "
            "`moving_sphere`, `box`) take a `material`, an `interior` medium, or both.",
            noun="shape",
            plural="shapes",
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
            _union_models(TransformStep),
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
            users = [m for m in s.models if any(model in _direct_models(f.annotation) for f in m.model_fields.values())]
            if users:
                s.sub.setdefault(users[0], []).append(model)
                placed.add(model)
                break
    missing = [m.__name__ for m in walk_models(Scene) if m not in placed]
    if missing:
        raise RuntimeError(f"scenefmt.docgen has no section for {', '.join(missing)}; add one in build_sections()")
    return sections


# ---------------------------------------------------------------------------------------------
# Markdown.


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def field_table(model: type[BaseModel], describer: Describer, required_type: bool) -> list[str]:
    rows = ["| Key | Accepted values | Default | Description |", "|---|---|---|---|"]
    for name in ordered_fields(model):
        info = model.model_fields[name]
        accepted = describer.describe(info.annotation, list(info.metadata))
        default = field_default(info)
        if default is PydanticUndefined or (name == "type" and required_type):
            shown = "**required**"
        else:
            shown = f"`{_yaml(plain(default))}`"
        rows.append(
            f"| `{name}` | {_cell(accepted)} | {_cell(shown)} | {_cell(info.description or '')} |"
        )
    return rows


def model_block(
    model: type[BaseModel], level: int, title: str, describer: Describer, required: set, intro: str = ""
) -> list[str]:
    lines = [f"{'#' * level} {title}", ""]
    if intro:
        lines += [intro, ""]
    text = description(model)
    if text:
        lines += [text, ""]
    lines += field_table(model, describer, model in required)
    lines.append("")
    ex = example(model)
    if ex is not None:
        lines += ["```yaml", ex.rstrip("\n"), "```", ""]
    return lines


def render_reference() -> str:
    """The whole Markdown reference."""
    sections = build_sections()
    describer = Describer(sections)
    required = required_type_models(Scene)
    name_max = _constraint(flatten(Name)[1], "max_length")
    out: list[str] = [INTRODUCTION.replace("{name_max}", str(name_max)).rstrip("\n"), "", "## Contents", ""]
    for s in sections:
        out.append(f"- [{s.title}](#{s.anchor})")
        if not s.single:
            out[-1] += ": " + ", ".join(describer.model_link(m) for m in s.models)
    out.append("")
    for s in sections:
        if s.single:
            (model,) = s.models
            out += model_block(model, 2, s.title, describer, required, intro=s.intro)
        else:
            out += [f"## {s.title}", ""]
            if s.intro:
                out += [s.intro, ""]
        for model in s.models:
            if not s.single:
                out += model_block(model, 3, heading_title(model, s), describer, required)
            for sub in s.sub.get(model, []):
                out += model_block(sub, 3 if s.single else 4, heading_title(sub, s), describer, required)
    return "\n".join(out).rstrip("\n") + "\n"


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    text = render_reference()
    if "--check" in args:
        current = DOC_PATH.read_text(encoding="utf-8") if DOC_PATH.is_file() else ""
        if current != text:
            diff = list(
                difflib.unified_diff(
                    current.splitlines(), text.splitlines(), "docs/format.md (committed)", "generated", lineterm="", n=1
                )
            )
            print("\n".join(diff[:40]) + ("\n..." if len(diff) > 40 else ""), file=sys.stderr)
            print(f"{DOC_PATH} is out of date; run: {REGENERATE}", file=sys.stderr)
            return 1
        print(f"{DOC_PATH} is up to date")
        return 0
    DOC_PATH.parent.mkdir(parents=True, exist_ok=True)
    DOC_PATH.write_text(text, encoding="utf-8")
    print(f"wrote {DOC_PATH}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
