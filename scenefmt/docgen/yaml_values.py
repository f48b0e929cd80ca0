"""Values written as YAML flow text, as a user would type them: defaults and literals."""

from __future__ import annotations

import json
import math
import re
from typing import Any

from pydantic import BaseModel

from ..writing import field_default


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


def yaml_flow(value: Any) -> str:
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
        return "[" + ", ".join(yaml_flow(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{yaml_flow(k)}: {yaml_flow(v)}" for k, v in value.items()) + "}"
    return json.dumps(value)
