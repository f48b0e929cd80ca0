"""Turn pydantic validation errors into diagnostics a user can act on.

Each error is placed at the line and column of the offending value (or key), named by its
key path in the file (pydantic's union tags are dropped from the path), and worded as what
was found against what was expected, with a did-you-mean for misspelt keys and type names.
"""

from __future__ import annotations

import typing
from typing import Any, Iterator, Union

from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from .diagnostics import Diagnostic, did_you_mean
from .loading import SourceDocument
from .transforms import STEP_KINDS


def data_path(data: Any, loc: tuple) -> tuple:
    """Follow pydantic's `loc` through the raw data, keeping only real keys and indices."""
    path: list = []
    node = data
    for part in loc:
        if isinstance(node, dict) and isinstance(part, str) and part in node:
            path.append(part)
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            path.append(part)
            node = node[part]
    return tuple(path)


def value_at(data: Any, path: tuple) -> Any:
    for part in path:
        data = data[part]
    return data


# ----------------------------------------------------------------------------------------------
# Finding the model a loc points into (for did-you-mean on keys and the tags a union expects)


def _unwrap(tp: Any) -> Any:
    while typing.get_origin(tp) is typing.Annotated:
        tp = typing.get_args(tp)[0]
    return tp


def _union_members(tp: Any) -> list[tuple[str | None, Any]]:
    """(tag, type) pairs of a union, tags from `Tag(...)` metadata or a model's `type` literal."""
    out = []
    for member in typing.get_args(tp):
        tag = None
        if typing.get_origin(member) is typing.Annotated:
            for meta in typing.get_args(member)[1:]:
                if type(meta).__name__ == "Tag":
                    tag = meta.tag
        inner = _unwrap(member)
        if tag is None and isinstance(inner, type) and issubclass(inner, BaseModel) and "type" in inner.model_fields:
            tag = inner.model_fields["type"].default
        if inner is type(None):
            continue
        out.append((tag, member))
    return out


def _step(tp: Any, part: Any) -> Any:
    """The type reached from `tp` through one loc element, or None."""
    tp = _unwrap(tp)
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        field: FieldInfo | None = tp.model_fields.get(part) if isinstance(part, str) else None
        return field.annotation if field is not None else None
    if origin is Union:
        members = _union_members(tp)
        for tag, member in members:
            if tag == part:
                return member
        if len(members) == 1:
            return _step(members[0][1], part)
        return None
    if origin in (list, tuple):
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        if isinstance(part, int) and args:
            return args[min(part, len(args) - 1)] if origin is tuple else args[0]
        return None
    if origin is dict:
        return typing.get_args(tp)[1] if part != "[key]" else None
    return None


def type_at(root: type, loc: tuple) -> Any:
    """The (unwrapped) type that `loc` points into, following unions by their tags."""
    tp: Any = root
    for part in loc:
        nxt = _step(tp, part)
        if nxt is None:
            return None
        tp = nxt
    return _unwrap(tp)


def _expected_tags(root: type, loc: tuple) -> list[str]:
    tp = type_at(root, loc)
    if typing.get_origin(tp) is Union:
        return [str(t) for t, _ in _union_members(tp) if t is not None]
    return []


# ----------------------------------------------------------------------------------------------


def _short(value: Any) -> str:
    """A found value as the file spells it: `true`, `null`, `'text'`, `[1, 2]`."""
    if value is True or value is False:
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, dict):
        return "a mapping {" + ", ".join(str(k) for k in list(value)[:4]) + (", ..." if len(value) > 4 else "") + "}"
    text = repr(value).replace("True", "true").replace("False", "false").replace("None", "null")
    return text if len(text) <= 60 else text[:57] + "..."


def _diagnostics_for(err: dict, doc: SourceDocument, root: type) -> Diagnostic:
    kind = err["type"]
    loc = tuple(err["loc"])
    ctx = err.get("ctx") or {}
    path = data_path(doc.data, loc)
    found = err.get("input")

    if kind == "missing":
        field = loc[-1]
        return doc.diagnostic(path + (field,), f"missing required key '{field}'")

    if kind == "field_rule":
        # A rule about several fields, placed at the field the message is about.
        field = ctx.get("field")
        return doc.diagnostic(path + ((field,) if field else ()), err["msg"])

    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return doc.diagnostic(path, f"expected a mapping of keys to values, found {_short(found)}")

    if kind in ("too_short", "too_long"):
        bound = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        word = "at least" if kind == "too_short" else "at most"
        return doc.diagnostic(path, f"expected {word} {bound} item{'s' if bound != 1 else ''}, found {ctx.get('actual_length')}")

    if kind == "literal_error" and path == ("version",):
        return doc.diagnostic(path, f"unsupported scene format version {_short(found)}; this rt reads version 1")

    if kind == "extra_forbidden":
        key = loc[-1]
        model = type_at(root, loc[:-1])
        allowed = list(model.model_fields) if isinstance(model, type) and issubclass(model, BaseModel) else []
        allowed = (["type"] if "type" in allowed else []) + [a for a in allowed if a != "type"]
        hint = did_you_mean(key, allowed)
        if key == "interior" and "type" in allowed:
            hint = "; only closed shapes (sphere, moving_sphere, box) can hold an interior medium"
        elif not hint and allowed:
            hint = f"; expected one of: {', '.join(allowed)}"
        return doc.diagnostic(path, f"unknown key '{key}'{hint}", of_key=True)

    if kind == "union_tag_invalid":
        tag = ctx.get("tag")
        tags = _expected_tags(root, loc)
        return doc.diagnostic(
            path + ("type",) if isinstance(value_at(doc.data, path), dict) else path,
            f"unknown type '{tag}'{did_you_mean(tag, tags)}" + (f" (expected one of: {', '.join(tags)})" if tags else ""),
        )

    if kind == "union_tag_not_found":
        tags = _expected_tags(root, loc)
        return doc.diagnostic(path, "missing key 'type'" + (f"; expected one of: {', '.join(tags)}" if tags else ""))

    if kind == "transform_step":
        message = err["msg"]
        if isinstance(found, dict) and found:
            first = next(iter(found))
            message = f"unknown transform step '{first}'{did_you_mean(first, STEP_KINDS)} ({message})"
        else:
            message = f"{message}, found {_short(found)}"
        return doc.diagnostic(path, message)

    if kind == "background" and isinstance(found, dict) and isinstance(found.get("type"), str):
        tags = ["solid", "sky"]
        tag = found["type"]
        return doc.diagnostic(path + ("type",), f"unknown type '{tag}'{did_you_mean(tag, tags)} (expected one of: {', '.join(tags)})")

    if kind in ("texture_slot", "material_slot", "medium_slot", "group_slot", "background"):
        return doc.diagnostic(path, f"{err['msg']}, found {_short(found)}")

    if kind == "value_error":
        message = err["msg"].removeprefix("Value error, ")
        return doc.diagnostic(path, message)

    if kind == "string_pattern_mismatch" and "A-Za-z_" in str(ctx.get("pattern", "")):
        return doc.diagnostic(
            path,
            f"{_short(found)} is not a valid name: use letters, digits, '_', '.' or '-', starting with a letter or '_'",
            of_key=bool(loc) and loc[-1] == "[key]",
        )

    bounds = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}
    if kind in bounds:
        limit = next(iter(ctx.values()))
        limit = f"{limit:g}" if isinstance(limit, (int, float)) else limit
        return doc.diagnostic(path, f"expected a number {bounds[kind]} {limit}, found {_short(found)}")
    message = err["msg"]
    if message.startswith("Input should be "):
        message = "expected " + message.removeprefix("Input should be ")
    if not isinstance(found, (dict, list)) or kind.endswith(("_type", "literal_error")):
        message += f", found {_short(found)}"
    if loc and loc[-1] == "[key]":
        message = f"key {message}"
    return doc.diagnostic(path, message)


def diagnostics_from(exc: ValidationError, doc: SourceDocument, root: type) -> Iterator[Diagnostic]:
    seen = set()
    errors = exc.errors(include_url=False)
    # A misspelt key shows up twice: as an unknown key and as the missing one it was meant to be.
    # The did-you-mean says it all, so the "missing" half is dropped.
    misspelt = set()
    for err in errors:
        if err["type"] == "extra_forbidden":
            model = type_at(root, tuple(err["loc"])[:-1])
            if isinstance(model, type) and issubclass(model, BaseModel):
                hint = did_you_mean(err["loc"][-1], list(model.model_fields))
                if hint:
                    misspelt.add((data_path(doc.data, tuple(err["loc"])[:-1]), hint.split("'")[1]))
    for err in errors:
        if err["type"] == "missing" and (data_path(doc.data, tuple(err["loc"])), err["loc"][-1]) in misspelt:
            continue
        diag = _diagnostics_for(err, doc, root)
        key = (diag.line, diag.column, diag.message)
        if key not in seen:
            seen.add(key)
            yield diag
