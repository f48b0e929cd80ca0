"""Generate the scene JSON Schema from the models, in a dialect editors understand.

pydantic emits JSON Schema 2020-12 (`$defs`, `prefixItems` for fixed-length vectors). The
most used YAML editor tooling validates only up to draft-07, so the schema is rewritten into
draft-07: `definitions` instead of `$defs`, tuple `items` arrays instead of `prefixItems`, and
no OpenAPI `discriminator` keyword. `python -m scenefmt.schema_export` rewrites the committed
file; `--check` fails when it is out of date.
"""

from __future__ import annotations

import json
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from .scene import Scene

SCHEMA_FILE = "scene.schema.json"
DRAFT_07 = "http://json-schema.org/draft-07/schema#"
SCHEMA_ID = "https://rt-render.invalid/schemas/scene.schema.json"

# Keywords that draft-07 validators do not know; none may remain in the shipped schema.
NEWER_KEYWORDS = frozenset(
    {"$defs", "prefixItems", "unevaluatedProperties", "unevaluatedItems", "dependentRequired",
     "dependentSchemas", "$anchor", "$dynamicRef", "$dynamicAnchor", "$recursiveRef", "minContains",
     "maxContains", "discriminator"}
)


# What `rt validate` checks and the JSON Schema cannot (listed in docs/format.md; the schema
# agreement test names a reason for each file the two judge differently).
BEYOND_THE_SCHEMA = {
    "names": "names referred to across sections (undefined names, cycles of groups or textures)",
    "files": "files on disk (image textures, included files)",
    "geometry": "rules over several numbers computed together (zero areas, min below max, look_from and look_at "
    "apart, up not parallel to the view, a singular matrix, the shutter's order, the image height from width and "
    "aspect_ratio)",
    "duplicates": "duplicate keys: a parser keeps one value, so a schema never sees the other",
    "integers": "an integer written with a decimal point (100.0): JSON Schema counts it as an integer",
    "magnitudes": "the magnitude of every number (0, or 1e-50 to 1e50): expressible, but it would repeat a "
    "three-way choice at every number of the schema",
    "colours": "a colour's limit where it is used (a texture used as an albedo at most 1, as an emission at most 1e12)",
    "sizes": "what the scene costs once expanded (memory, instance placements, extents through instances)",
}


def _to_draft07(node: Any) -> Any:
    if isinstance(node, list):
        return [_to_draft07(item) for item in node]
    if not isinstance(node, dict):
        return node
    if "discriminator" in node and "oneOf" in node:
        return _to_draft07(_tagged_union(node))
    out: dict[str, Any] = {}
    for key, value in node.items():
        if key == "discriminator":
            continue
        if key == "$defs":
            out["definitions"] = {name: _to_draft07(v) for name, v in value.items()}
        elif key == "$ref" and isinstance(value, str):
            out["$ref"] = value.replace("#/$defs/", "#/definitions/")
        elif key == "prefixItems":
            out["items"] = _to_draft07(value)
            out["additionalItems"] = False
        elif key in ("properties", "definitions", "patternProperties"):
            out[key] = {name: _to_draft07(v) for name, v in value.items()}
        else:
            out[key] = _to_draft07(value)
    # pydantic writes a dict with constrained keys as patternProperties, which lets other keys
    # through unchecked; a propertyNames pattern rejects them as the models do.
    patterns = out.pop("patternProperties", None)
    if patterns is not None:
        (pattern, value_schema), = patterns.items()
        out["propertyNames"] = {**out.get("propertyNames", {}), "pattern": pattern}
        out["additionalProperties"] = value_schema
    # In draft-07 a $ref ignores its siblings; wrap it so descriptions and defaults still apply.
    if "$ref" in out and len(out) > 1:
        ref = out.pop("$ref")
        out = {"allOf": [{"$ref": ref}], **out}
    return out


def _tagged_union(node: dict) -> dict:
    """A union told apart by its `type` key, written so that a validator checks one member only.

    pydantic writes `oneOf` with an OpenAPI `discriminator`, which draft-07 validators ignore: a
    sphere with one misspelt key then fails every member, and an editor says only "not valid
    under any of the given schemas". Here the `type` must be one of the tags, and an `if`/`then`
    per tag applies that member's schema alone, so the error names the wrong key."""
    mapping = node["discriminator"]["mapping"]
    prop = node["discriminator"]["propertyName"]
    out = {k: v for k, v in node.items() if k not in ("discriminator", "oneOf")}
    out.update(
        {
            "type": "object",
            "required": [prop],
            "properties": {prop: {"enum": list(mapping)}},
            "allOf": [
                {"if": {"required": [prop], "properties": {prop: {"const": tag}}}, "then": {"$ref": ref}}
                for tag, ref in mapping.items()
            ],
        }
    )
    return out


def generate_schema() -> dict:
    """The draft-07 JSON Schema of a scene file."""
    schema = _to_draft07(Scene.model_json_schema(mode="validation"))
    return {"$schema": DRAFT_07, "$id": SCHEMA_ID, **schema}


def schema_json() -> str:
    return json.dumps(generate_schema(), indent=2, sort_keys=False) + "\n"


def shipped_schema_text() -> str:
    """The schema file shipped with the installed package."""
    return resources.files("scenefmt.schemas").joinpath(SCHEMA_FILE).read_text(encoding="utf-8")


def committed_schema_path() -> Path:
    """Where the committed schema lives in a source checkout."""
    return Path(__file__).resolve().parent.parent / "schemas" / SCHEMA_FILE


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    path = committed_schema_path()
    text = schema_json()
    if "--check" in args:
        if not path.is_file() or path.read_text(encoding="utf-8") != text:
            print(f"{path} is out of date; run: python -m scenefmt.schema_export", file=sys.stderr)
            return 1
        print(f"{path} is up to date")
        return 0
    path.write_text(text, encoding="utf-8")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
