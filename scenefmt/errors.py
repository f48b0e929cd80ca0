"""Turn pydantic validation errors into diagnostics a user can act on.

Each error is placed at the line and column of the offending value (or key), named by its
key path in the file (pydantic's union tags are dropped from the path), and worded as what
was found against what was expected, with a did-you-mean for misspelt keys and type names.
"""

from __future__ import annotations

import re
import typing
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Union

from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from .diagnostics import Diagnostic, did_you_mean, path_part, quote_key, quote_text
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


def _expected_tags(root: type, loc: tuple, typed_only: bool = False) -> list[str]:
    """The tags of the union at `loc`; with `typed_only`, only those of members chosen by a
    `type:` key (the models that have one), not a bare value such as a colour triple."""
    tp = type_at(root, loc)
    if typing.get_origin(tp) is Union:
        return [str(t) for t, member in _union_members(tp) if t is not None and (not typed_only or _has_type_key(member))]
    return []


def _has_type_key(member: Any) -> bool:
    inner = _unwrap(member)
    return isinstance(inner, type) and issubclass(inner, BaseModel) and "type" in inner.model_fields


# ----------------------------------------------------------------------------------------------
# Wording each kind of error: one handler per pydantic error type, looked up in _HANDLERS


def _scalar(value: Any) -> str:
    if value is True or value is False:
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, str):
        return quote_text(value)
    return repr(value)


def _short(value: Any) -> str:
    """A found value as the file spells it, `true`, `null`, `'text'`, `[1, 2]`, as far as a
    message may quote it (diagnostics.quote_text): a long or odd string is given by its length."""
    if isinstance(value, dict):
        keys = [path_part(k) for k in list(value)[:4]]
        return "a mapping {" + ", ".join(keys) + (", ..." if len(value) > 4 else "") + "}"
    if isinstance(value, (list, tuple)):
        if not all(v is None or isinstance(v, (bool, int, float)) for v in value):
            return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
        text = "[" + ", ".join(_scalar(v) for v in value) + "]"
    else:
        text = _scalar(value)
    return text if len(text) <= 60 else text[:57] + "..."


@dataclass(frozen=True)
class _Error:
    """One pydantic error, with what its handler needs: where it points in the file and what was found."""

    kind: str  # pydantic's error type: "missing", "extra_forbidden", ...
    msg: str
    loc: tuple  # pydantic's location, union tags included
    ctx: dict
    path: tuple  # the location through the data: real keys and indices only
    found: Any
    doc: SourceDocument
    root: type


def _missing_key(e: _Error) -> Diagnostic:
    field = e.loc[-1]
    return e.doc.diagnostic(e.path + (field,), f"missing required key '{field}'")


def _field_rule(e: _Error) -> Diagnostic:
    # A rule about several fields, placed at the field the message is about.
    field = e.ctx.get("field")
    return e.doc.diagnostic(e.path + ((field,) if field else ()), e.msg)


def _not_a_mapping(e: _Error) -> Diagnostic:
    return e.doc.diagnostic(e.path, f"expected a mapping of keys to values, found {_short(e.found)}")


def _wrong_length(e: _Error) -> Diagnostic:
    bound = e.ctx.get("min_length") if e.kind == "too_short" else e.ctx.get("max_length")
    word = "at least" if e.kind == "too_short" else "at most"
    return e.doc.diagnostic(
        e.path, f"expected {word} {bound} item{'s' if bound != 1 else ''}, found {e.ctx.get('actual_length')}"
    )


def _unsupported_version(e: _Error) -> Diagnostic:
    if e.path != ("version",):
        return _not_one_of(e)
    return e.doc.diagnostic(e.path, f"unsupported scene format version {_short(e.found)}; this rt reads version 1")


def _not_one_of(e: _Error) -> Diagnostic:
    """A value outside a fixed list of names (a Literal): pydantic's wording, then the nearest name
    when the value looks like a misspelling of one (`sgrb` -> `srgb`)."""
    diag = _worded_by_pydantic(e)
    names = re.findall(r"'([^']*)'", str(e.ctx.get("expected", "")))
    if isinstance(e.found, str) and names:
        hint = did_you_mean(e.found, names)
        if hint:
            diag = e.doc.diagnostic(e.path, diag.message + hint)
    return diag


def _unknown_key(e: _Error) -> Diagnostic:
    key = e.loc[-1]
    model = type_at(e.root, e.loc[:-1])
    allowed = list(model.model_fields) if isinstance(model, type) and issubclass(model, BaseModel) else []
    allowed = (["type"] if "type" in allowed else []) + [a for a in allowed if a != "type"]
    hint = did_you_mean(key, allowed)
    if key == "interior" and "type" in allowed:
        hint = "; only closed shapes (sphere, moving_sphere, box) can hold an interior medium"
    elif not hint and allowed:
        hint = f"; expected one of: {', '.join(allowed)}"
    return e.doc.diagnostic(e.path, f"unknown key {quote_key(key)}{hint}", of_key=True)


def _unknown_type_message(tag: Any, tags: list[str]) -> str:
    return f"unknown type {quote_key(tag)}{did_you_mean(tag, tags)}" + (f" (expected one of: {', '.join(tags)})" if tags else "")


def _unknown_type(e: _Error) -> Diagnostic:
    tag = e.ctx.get("tag")
    at_type_key = isinstance(value_at(e.doc.data, e.path), dict)
    return e.doc.diagnostic(
        e.path + ("type",) if at_type_key else e.path, _unknown_type_message(tag, _expected_tags(e.root, e.loc))
    )


def _missing_type(e: _Error) -> Diagnostic:
    tags = _expected_tags(e.root, e.loc)
    return e.doc.diagnostic(e.path, "missing key 'type'" + (f"; expected one of: {', '.join(tags)}" if tags else ""))


def _unknown_transform_step(e: _Error) -> Diagnostic:
    if isinstance(e.found, dict) and e.found:
        first = next(iter(e.found))
        return e.doc.diagnostic(e.path, f"unknown transform step {quote_key(first)}{did_you_mean(first, STEP_KINDS)} ({e.msg})")
    return e.doc.diagnostic(e.path, f"{e.msg}, found {_short(e.found)}")


def _bad_slot(e: _Error) -> Diagnostic:
    return e.doc.diagnostic(e.path, f"{e.msg}, found {_short(e.found)}")


def _bad_background(e: _Error) -> Diagnostic:
    # The background's callable discriminator reports every failure as one custom error, with no tag;
    # an unknown `type:` is picked out here so it reads like any other union's.
    if isinstance(e.found, dict) and isinstance(e.found.get("type"), str):
        return e.doc.diagnostic(e.path + ("type",), _unknown_type_message(e.found["type"], _expected_tags(e.root, e.loc, typed_only=True)))
    return _bad_slot(e)


def _validator_message(e: _Error) -> Diagnostic:
    return e.doc.diagnostic(e.path, e.msg.removeprefix("Value error, "))


def _invalid_name(e: _Error) -> Diagnostic:
    if "A-Za-z_" not in str(e.ctx.get("pattern", "")):
        return _worded_by_pydantic(e)
    return e.doc.diagnostic(
        e.path,
        f"{_short(e.found)} is not a valid name: use letters, digits, '_', '.' or '-', starting with a letter or '_'",
        of_key=bool(e.loc) and e.loc[-1] == "[key]",
    )


_BOUND_SIGNS = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}


def _out_of_bounds(e: _Error) -> Diagnostic:
    limit = next(iter(e.ctx.values()))
    limit = f"{limit:g}" if isinstance(limit, (int, float)) else limit
    return e.doc.diagnostic(e.path, f"expected a number {_BOUND_SIGNS[e.kind]} {limit}, found {_short(e.found)}")


def _worded_by_pydantic(e: _Error) -> Diagnostic:
    """Any other error: pydantic's own message, reworded as expected-versus-found."""
    message = e.msg
    if message.startswith("Input should be "):
        message = "expected " + message.removeprefix("Input should be ")
    if not isinstance(e.found, (dict, list)) or e.kind.endswith(("_type", "literal_error")):
        message += f", found {_short(e.found)}"
    if e.loc and e.loc[-1] == "[key]":
        message = f"key {message}"
    return e.doc.diagnostic(e.path, message)


# Pydantic's error type -> the handler that explains it; a type not listed gets _worded_by_pydantic.
_HANDLERS: dict[str, Callable[[_Error], Diagnostic]] = {
    "missing": _missing_key,
    "field_rule": _field_rule,
    **dict.fromkeys(("model_type", "model_attributes_type", "dict_type"), _not_a_mapping),
    **dict.fromkeys(("too_short", "too_long"), _wrong_length),
    "literal_error": _unsupported_version,
    "extra_forbidden": _unknown_key,
    "union_tag_invalid": _unknown_type,
    "union_tag_not_found": _missing_type,
    "transform_step": _unknown_transform_step,
    "background": _bad_background,
    **dict.fromkeys(("texture_slot", "material_slot", "medium_slot", "group_slot"), _bad_slot),
    "value_error": _validator_message,
    "string_pattern_mismatch": _invalid_name,
    **dict.fromkeys(_BOUND_SIGNS, _out_of_bounds),
}


def _diagnostic_for(err: dict, doc: SourceDocument, root: type) -> Diagnostic:
    """One pydantic error as a diagnostic, placed in the file and worded by its type's handler."""
    loc = tuple(err["loc"])
    e = _Error(
        kind=err["type"],
        msg=err["msg"],
        loc=loc,
        ctx=err.get("ctx") or {},
        path=data_path(doc.data, loc),
        found=err.get("input"),
        doc=doc,
        root=root,
    )
    return _HANDLERS.get(e.kind, _worded_by_pydantic)(e)


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
        diag = _diagnostic_for(err, doc, root)
        key = (diag.line, diag.column, diag.message)
        if key not in seen:
            seen.add(key)
            yield diag
