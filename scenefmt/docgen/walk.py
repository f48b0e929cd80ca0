"""Taking annotations apart, and walking the models they reach and the unions that join them."""

from __future__ import annotations

import types
import typing
from typing import Any, Iterable, Union

from pydantic import BaseModel, Discriminator
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from ..scene import Scene


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


def unwrap_annotated(tp: Any) -> tuple[Any, list[Any], Any]:
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


def is_union(tp: Any) -> bool:
    return typing.get_origin(tp) in (Union, types.UnionType)


def is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def constraint(meta: list[Any], name: str) -> Any:
    """The last value of constraint `name` (gt, ge, max_length, pattern, ...) among the metadata."""
    value = None
    for m in meta:
        v = getattr(m, name, None)
        if v is not None and v is not PydanticUndefined:
            value = v
    return value


def union_models(tp: Any) -> list[type[BaseModel]]:
    """The models of a (possibly Annotated, possibly one-member) union, in order."""
    base, _, _ = unwrap_annotated(tp)
    if is_model(base):
        return [base]
    out = []
    for arg in typing.get_args(base):
        b, _, _ = unwrap_annotated(arg)
        if is_model(b):
            out.append(b)
    return out


def walk_models(root: type[BaseModel] = Scene) -> list[type[BaseModel]]:
    """Every model reachable from `root` through field annotations, in first-seen order."""
    seen: list[type[BaseModel]] = []

    def visit_type(tp: Any) -> None:
        if is_model(tp):
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


def direct_models(tp: Any) -> list[type[BaseModel]]:
    """Models an annotation refers to directly (not through the fields of another model)."""
    base, _, _ = unwrap_annotated(tp)
    if is_model(base):
        return [base]
    out: list[type[BaseModel]] = []
    for arg in typing.get_args(base):
        if isinstance(arg, type) or typing.get_args(arg) or typing.get_origin(arg) is not None:
            out += [m for m in direct_models(arg) if m not in out]
    return out


def _unions(tp: Any, outer: Any = None) -> Iterable[tuple[list[type[BaseModel]], Any]]:
    """Each union (or one-member discriminated union) inside an annotation: its models and discriminator."""
    base, _, disc = unwrap_annotated(tp)
    disc = disc if disc is not None else outer
    if is_union(base) or (is_model(base) and disc is not None):
        yield union_models(base), disc
    if not is_model(base):
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
