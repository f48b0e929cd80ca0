"""Write scenes built in Python out as YAML or JSON that load back to the same models."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from .loading import _CoreSchemaResolver
from .scene import Scene

SCHEMA_COMMENT = "# yaml-language-server: $schema={url}\n"


def field_default(info: FieldInfo) -> Any:
    """A field's default value (calling its factory), or `PydanticUndefined` for a required field."""
    if info.default is not PydanticUndefined:
        return info.default
    if info.default_factory is not None:
        return info.default_factory()
    return PydanticUndefined


def to_data(value: Any) -> Any:
    """Plain data for a model tree: `type` first, then the fields that were set or differ from their
    defaults (so a generated file still shows the book's `ior: 1.5`)."""
    if isinstance(value, BaseModel):
        out: dict[str, Any] = {}
        fields = type(value).model_fields
        if "type" in fields and fields["type"].is_required() or (
            "type" in fields and type(value).__name__ != "Group"
        ):
            out["type"] = value.type
        # The kind's own fields first; the ones every shape shares last.
        shared = ("material", "interior", "transform")
        order = [n for n in fields if n != "type" and n not in shared] + [n for n in shared if n in fields]
        for name in order:
            info = fields[name]
            current = getattr(value, name)
            default = field_default(info)
            if default is not PydanticUndefined and _same(current, default) and name not in value.model_fields_set:
                continue
            out[name] = to_data(current)
        return out
    if hasattr(value, "tolist") and hasattr(value, "ndim"):  # a numpy array (an inline mesh)
        return value.tolist()
    if isinstance(value, dict):
        return {k: to_data(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_data(v) for v in value]
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        return int(value)
    return value


def _same(current: Any, default: Any) -> bool:
    if current is None or default is None or hasattr(current, "ndim"):
        return current is default
    return current == default


class _ScalarDumper(yaml.SafeDumper):
    """PyYAML's own quoting of one string, by the rules of the YAML 1.2 core schema scenes are read by."""


# A string is quoted when a reader could take it for something else. PyYAML's dumper knows the
# YAML 1.1 forms; scene files are read by the YAML 1.2 core schema, where `0E0` or `1e5` is a
# number too, so its forms are added (a description "0E0" was written bare and read back as 0).
for _first, _resolvers in _CoreSchemaResolver.yaml_implicit_resolvers.items():
    for _tag, _regexp in _resolvers:
        _ScalarDumper.add_implicit_resolver(_tag, _regexp, [_first])

# Flow collections (a vector, a shape, a material) are used up to this many characters.
_FLOW_WIDTH = 100
_INF = float("inf")


# What YAML takes for a line break inside a string: a string holding one is written in double
# quotes, where PyYAML escapes it (PyYAML's own choice, single quotes over several lines, reads
# back a \x85 or \u2028 as a space).
_BREAKS = re.compile("[\n\r\x85\u2028\u2029]")
# PyYAML folds a long string over lines of this many characters.
_LINE_WIDTH = 120


def _by_pyyaml(key: Any, value: Any, indent: int) -> list:
    """The lines of `key: value` in a mapping indented `indent` spaces, written by PyYAML itself in
    as many mappings as that indentation takes: for a string too long for one line, which PyYAML
    folds where it always has, and for a key that is no plain name."""
    data: Any = {key: value}
    for _ in range(indent // 2):
        data = {"k": data}
    out = yaml.dump(data, Dumper=_ScalarDumper, allow_unicode=True, width=_LINE_WIDTH, default_flow_style=False, sort_keys=False)
    return out.rstrip("\n").split("\n")[indent // 2 :]


class _YamlWriter:
    """Plain data as YAML text: short collections on one line (flow style), the rest in block style,
    laid out as PyYAML lays them out (two spaces a level, a mapping's list items at the key's own
    indentation).

    PyYAML's representer and emitter cost tens of microseconds a value, and deciding each
    collection's style by dumping its values once more cost far more: 81 s for 10,000 spheres. Here
    numbers, booleans and null are written directly (as PyYAML writes them), and each distinct
    string is quoted once by PyYAML itself and remembered, so a scene of many shapes, which repeats
    a few names, costs about what its JSON does."""

    def __init__(self):
        self.strings: dict[tuple, str] = {}

    def string(self, text: str, where: str) -> str | None:
        """`text` as PyYAML writes it on one line as a value (`where` "block" or "flow") or as a key
        ("key", "flow key"); None for a key that cannot be written so (over 128 characters, or
        holding a line break), or a string that cannot be in a flow collection."""
        known = self.strings.get((text, where))
        if known is not None:
            return known
        out = None if _BREAKS.search(text) else self._quoted(text, where, None)
        if out is None or "\n" in out:  # written over several lines (see `mapping`); double quotes keep it on one
            out = self._quoted(text, where, '"')
            if out is not None and "\n" in out:
                out = None
        self.strings[(text, where)] = out
        return out

    @staticmethod
    def _quoted(text: str, where: str, style) -> str | None:
        options = dict(Dumper=_ScalarDumper, allow_unicode=True, width=_INF, default_style=style)
        if where == "block":
            out = yaml.dump(text, explicit_end=False, **options)
            return out.removesuffix("\n...\n").removesuffix("\n")
        if where == "flow":
            out = yaml.dump([text], default_flow_style=True, **options).rstrip("\n")
            return out[1:-1] if out.startswith("[") and out.endswith("]") else None
        flow = where == "flow key"
        out = yaml.dump({text: 0}, default_flow_style=flow, **options).rstrip("\n")
        value = ": 0" if style is None else ': "0"'  # a default style quotes the value too
        if flow:
            out = out[1:-1] if out.startswith("{") and out.endswith("}") else ""
        # A key PyYAML cannot write as a simple key is written as "? key" on a line of its own.
        return out[: -len(value)] if out.endswith(value) and not out.startswith("? ") else None

    def scalar(self, value: Any, where: str) -> str:
        if value is True:
            return "true"
        if value is False:
            return "false"
        if value is None:
            return "null"
        if isinstance(value, int):
            return str(value)
        if isinstance(value, float):
            if value != value:
                return ".nan"
            if value in (_INF, -_INF):
                return ".inf" if value > 0 else "-.inf"
            text = repr(value).lower()
            return text.replace("e", ".0e", 1) if "." not in text and "e" in text else text
        if isinstance(value, str):
            return self.string(value, where)
        raise TypeError(f"cannot write a {type(value).__name__} as YAML")

    def flow(self, data: Any, budget: int) -> str | None:
        """`data` on one line, or None when that is longer than `budget` characters."""
        if isinstance(data, dict):
            parts = []
            for k, v in data.items():
                inner = self.flow(v, budget)
                if inner is None:
                    return None
                key = self.scalar(k, "flow key")
                if key is None:
                    return None
                parts.append(f"{key}: {inner}")
                budget -= len(parts[-1]) + 2
                if budget < 0:
                    return None
            return "{" + ", ".join(parts) + "}"
        if isinstance(data, list):
            parts = []
            for x in data:
                inner = self.flow(x, budget)
                if inner is None:
                    return None
                parts.append(inner)
                budget -= len(inner) + 2
                if budget < 0:
                    return None
            return "[" + ", ".join(parts) + "]"
        text = self.scalar(data, "flow")
        return text if text is not None and len(text) <= budget else None

    def inline(self, data: Any) -> str | None:
        """The text of `data` after a key or a dash, if it goes on that line."""
        if isinstance(data, (dict, list)):
            text = self.flow(data, _FLOW_WIDTH)
            return text if text is not None and len(text) <= _FLOW_WIDTH else None
        return self.scalar(data, "block")

    def mapping(self, data: dict, indent: int, lines: list) -> None:
        pad = " " * indent
        for k, v in data.items():
            name = self.scalar(k, "key")
            key = f"{pad}{name}:"
            if name is None or isinstance(v, str) and len(key) + 1 + len(self.scalar(v, "block")) > _LINE_WIDTH and not _BREAKS.search(v):
                lines += _by_pyyaml(k, v, indent)
                continue
            text = self.inline(v)
            if text is not None:
                lines.append(f"{key} {text}")
            elif isinstance(v, dict):
                lines.append(key)
                self.mapping(v, indent + 2, lines)
            else:
                lines.append(key)
                self.sequence(v, indent, lines)  # a mapping's list: its dashes at the key's indentation

    def sequence(self, data: list, indent: int, lines: list) -> None:
        pad = " " * indent
        for item in data:
            text = self.inline(item)
            if text is not None:
                lines.append(f"{pad}- {text}")
                continue
            # The item's first line follows the dash; the rest keep the indentation under it.
            first = len(lines)
            if isinstance(item, dict):
                self.mapping(item, indent + 2, lines)
            else:
                self.sequence(item, indent + 2, lines)
            lines[first] = f"{pad}- {lines[first][indent + 2:]}"

    def document(self, data: Any) -> str:
        lines: list = []
        text = self.inline(data)
        if text is not None:
            return text + "\n"
        if isinstance(data, dict):
            self.mapping(data, 0, lines)
        else:
            self.sequence(data, 0, lines)
        return "\n".join(lines) + "\n"


def _compact_json(data: Any, indent: str = "") -> str:
    """Indented JSON with lists of numbers (vectors, colours) kept on one line."""
    if isinstance(data, dict) and data:
        inner = indent + "  "
        items = [f"{inner}{json.dumps(k)}: {_compact_json(v, inner)}" for k, v in data.items()]
        return "{\n" + ",\n".join(items) + "\n" + indent + "}"
    if isinstance(data, list) and data and any(isinstance(x, (dict, list)) for x in data):
        inner = indent + "  "
        return "[\n" + ",\n".join(inner + _compact_json(x, inner) for x in data) + "\n" + indent + "]"
    return json.dumps(data)


def dumps(scene: Scene, syntax: str = "yaml", schema_url: str | None = None) -> str:
    """The text of `scene` as YAML or JSON."""
    data = to_data(scene)
    data = {"version": scene.version, **{k: v for k, v in data.items() if k != "version"}}
    if syntax == "json":
        return _compact_json(data) + "\n"
    text = _YamlWriter().document(data)
    return (SCHEMA_COMMENT.format(url=schema_url) if schema_url else "") + text


def dump(scene: Scene, path: str | Path, schema_url: str | None = None) -> None:
    """Write `scene` to `path`, as JSON for a .json name and YAML otherwise (atomically)."""
    path = Path(path)
    syntax = "json" if path.suffix.lower() == ".json" else "yaml"
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(dumps(scene, syntax, schema_url if syntax == "yaml" else None), encoding="utf-8")
    tmp.replace(path)
