"""The *Accepted values* column: a field's type and constraints in words, linking models to their headings."""

from __future__ import annotations

import typing
from typing import Any, Literal

from pydantic import BaseModel

from .. import scene as _scene_module
from ..base import Color, Name, Vec3
from ..shapes import Faces, Vertices
from ..materials import MaterialSlot
from ..media import MediumSlot
from ..shapes import GroupSlot
from ..textures import TextureSlot
from ..transforms import Transform
from .sections import Section, heading_title, slug
from .walk import constraint, unwrap_annotated, is_model, is_union
from .yaml_values import yaml_flow

# How the named type aliases read to a human; the keys are the aliases themselves.
# Links point at the sections of this document.
ALIAS_WORDING: list[tuple[Any, str]] = [
    (TextureSlot, "`[r, g, b]`, texture name or [texture](#textures)"),
    (MaterialSlot, "material name or [material](#materials)"),
    (MediumSlot, "medium name or [medium](#media)"),
    (GroupSlot, "group name or [group](#groups)"),
    (Transform, "list of [transform steps](#transform-steps)"),
    (Vec3, "`[x, y, z]`"),
    (Vertices, "list of `[x, y, z]`"),
    (Faces, "list of lists of 3 or more vertex indices (from 0)"),
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


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b)
    except Exception:  # pragma: no cover - exotic metadata without a usable __eq__
        return a is b


def match_alias(base: Any, meta: list[Any]) -> str | None:
    """The human wording of a named alias when `base` + `meta` is (a use of) that alias."""
    for alias, wording in ALIAS_WORDING:
        abase, ameta, _ = unwrap_annotated(alias)
        if _same(base, abase) and all(any(_same(m, x) for x in meta) for m in ameta):
            return wording
    return None


def _num(x: Any) -> str:
    """A bound, written compactly: 0 not 0.0, and 2^63-1 rather than its 19 digits."""
    if isinstance(x, float) and x.is_integer() and abs(x) < 2**53:
        x = int(x)
    if isinstance(x, int) and x > 2**20 and (x + 1) & x == 0:
        return f"2^{(x + 1).bit_length() - 1}-1"
    return str(x)


def _range(word: str, meta: list[Any]) -> str:
    gt, ge, lt, le = (constraint(meta, k) for k in ("gt", "ge", "lt", "le"))
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
    return constraint(meta, "min_length"), constraint(meta, "max_length")


def _literal(value: Any) -> str:
    return f"`{yaml_flow(value)}`"


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
        base, meta, _ = unwrap_annotated(tp)
        meta = list(outer_meta or []) + meta
        wording = match_alias(base, meta)
        if wording is not None:
            return wording
        if is_union(base):
            args = [a for a in typing.get_args(base) if a is not type(None)]
            if len(args) == 1:
                return self.describe(args[0], meta, plural)
            models = [unwrap_annotated(a)[0] for a in args if is_model(unwrap_annotated(a)[0])]
            others: list[str] = []
            for a in args:
                if typing.get_origin(a) is Literal:  # x, y, z or [x, y, z]: the values read as alternatives
                    others += [_literal(v) for v in typing.get_args(a)]
                elif not is_model(unwrap_annotated(a)[0]):
                    others.append(self.describe(a, None, plural))
            if models:
                others += self.models_wording(models, plural)
            return _join_or(others)
        if is_model(base):
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
            pattern = constraint(meta, "pattern")
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

