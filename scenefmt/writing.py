"""Write scenes built in Python out as YAML or JSON that load back to the same models."""

from __future__ import annotations

import json
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


class _SceneDumper(yaml.SafeDumper):
    """Vectors and short lists of numbers on one line; everything else in block style."""


_FLOW_WIDTH = 100


def _flow_text(data: Any) -> str | None:
    """The text of `data` written on one line (in YAML flow style)."""
    if isinstance(data, dict):
        parts = []
        for k, v in data.items():
            inner = _flow_text(v)
            if inner is None:
                return None
            parts.append(f"{k}: {inner}")
        return "{" + ", ".join(parts) + "}"
    if isinstance(data, list):
        parts = [_flow_text(x) for x in data]
        return None if None in parts else "[" + ", ".join(parts) + "]"
    return yaml.dump(data, Dumper=yaml.SafeDumper, default_flow_style=True).strip().removesuffix("...").strip()


def _short_enough(data: Any) -> bool:
    text = _flow_text(data)
    return text is not None and len(text) <= _FLOW_WIDTH


def _represent_list(dumper: yaml.SafeDumper, data: list) -> yaml.Node:
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=_short_enough(data))


def _represent_dict(dumper: yaml.SafeDumper, data: dict) -> yaml.Node:
    # Small mappings (a shape, a material, a transform step) read best on one line.
    return dumper.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=_short_enough(data))


_SceneDumper.add_representer(list, _represent_list)
_SceneDumper.add_representer(dict, _represent_dict)
# A string is quoted when a reader could take it for something else. PyYAML's dumper knows the
# YAML 1.1 forms; scene files are read by the YAML 1.2 core schema, where `0E0` or `1e5` is a
# number too, so its forms are added (a description "0E0" was written bare and read back as 0).
for _first, _resolvers in _CoreSchemaResolver.yaml_implicit_resolvers.items():
    for _tag, _regexp in _resolvers:
        _SceneDumper.add_implicit_resolver(_tag, _regexp, [_first])


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
    text = yaml.dump(data, Dumper=_SceneDumper, sort_keys=False, allow_unicode=True, width=120)
    return (SCHEMA_COMMENT.format(url=schema_url) if schema_url else "") + text


def dump(scene: Scene, path: str | Path, schema_url: str | None = None) -> None:
    """Write `scene` to `path`, as JSON for a .json name and YAML otherwise (atomically)."""
    path = Path(path)
    syntax = "json" if path.suffix.lower() == ".json" else "yaml"
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(dumps(scene, syntax, schema_url if syntax == "yaml" else None), encoding="utf-8")
    tmp.replace(path)
