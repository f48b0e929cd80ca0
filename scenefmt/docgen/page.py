"""The Markdown page: the introduction, the contents, and one block (description, table, example) per model."""

from __future__ import annotations

import inspect
import re

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from ..base import Name
from ..scene import Scene
from ..writing import field_default
from .accepted_values import Describer
from .introduction import INTRODUCTION
from .sections import build_sections, heading_title
from .walk import constraint, unwrap_annotated, required_type_models
from .yaml_values import plain, yaml_flow

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
            shown = f"`{yaml_flow(plain(default))}`"
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
    name_max = constraint(unwrap_annotated(Name)[1], "max_length")
    from ..schema_export import BEYOND_THE_SCHEMA

    beyond = "\n".join(f"- {reason}" for reason in BEYOND_THE_SCHEMA.values())
    intro = INTRODUCTION.replace("{name_max}", str(name_max)).replace("{beyond}", beyond)
    out: list[str] = [intro.rstrip("\n"), "", "## Contents", ""]
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

