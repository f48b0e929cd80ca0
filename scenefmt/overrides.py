"""`--set KEY.PATH=VALUE`: change one value of a scene from the command line, checked like the file.

`KEY.PATH` is a key path as diagnostics print it (`image.samples_per_pixel`, `materials.glass.ior`,
`shapes[2].radius`); `VALUE` is read as YAML (`64`, `1.33`, `[1, 0, 0]`, `{type: metal, fuzz: 0.1}`)
by the same safe, bounded loader as a scene file. The value replaces whatever the path held, or
adds the path's last key; every key before it must be in the scene already (or be a key of the
format that the file left out, such as `camera`), so a misspelt name is refused with a
did-you-mean instead of creating a new entry. The scene is then validated as a whole: an
error about the value is placed in the `--set` argument itself, as
`--set image.width=100.5:1:13: error: image.width: ...`, the column counted in the argument.

A definition's name may contain dots (`glass.1`): at each mapping the longest run of the path's
dotted parts that names an existing key is taken.
"""

from __future__ import annotations

import re
import typing
from typing import Any, Iterable

from pydantic import BaseModel

from .diagnostics import Diagnostic, SceneError, did_you_mean, format_path
from .errors import _step, _unwrap
from .loading import MAX_DEPTH, SourceDocument, parse_text
from .scene import Scene

MAX_OVERRIDES = 1000
# A key path names at most one key per level of nesting, and a document nests at most MAX_DEPTH
# levels: a longer path can name nothing. The key is bounded in characters too, and the whole
# argument (its value is a YAML document) far below a file, so no argument costs more than a
# moment to read.
MAX_KEY_PARTS = MAX_DEPTH
MAX_KEY_CHARS = 4096
MAX_ARGUMENT_CHARS = 1 << 20
_PART = re.compile(r"([^.\[\]]+)|\[(\d{1,9})\]")


class _Problem(Exception):
    def __init__(self, message: str, path: tuple = ()):
        super().__init__(message)
        self.path = path


class _TooLong(_Problem):
    """The key path is beyond every bound: the diagnostic names the argument by its start only."""


def _tokens(key: str) -> list:
    """`shapes[2].radius` -> ['shapes', 2, 'radius'] (names as strings, indices as ints)."""
    if len(key) > MAX_KEY_CHARS:
        raise _TooLong(f"the key path is {len(key):,} characters long, more than the {MAX_KEY_CHARS:,} allowed")
    out: list = []
    i = 0
    expect_name = True
    while i < len(key):
        if key[i] == "." and not expect_name and out:
            i += 1
            expect_name = True
            continue
        m = _PART.match(key, i)
        if not m or (m.group(1) is not None and not expect_name):
            raise _Problem(f"cannot read the key path {key!r} at character {i + 1}: expected a name such as image.width or shapes[0].radius")
        out.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        if len(out) > MAX_KEY_PARTS:
            raise _TooLong(f"the key path has more than {MAX_KEY_PARTS} parts, deeper than a scene can nest")
        expect_name = False
        i = m.end()
    if not out or expect_name:
        raise _Problem(f"cannot read the key path {key!r}: expected a name such as image.width or shapes[0].radius")
    return out


def _model_at(tp: Any, node: Any) -> Any:
    """The type `tp` with a union (a material, a shape) narrowed by the `type:` its data gives."""
    if tp is None:
        return None
    tp = _unwrap(tp)
    if typing.get_origin(tp) is typing.Union and isinstance(node, dict):
        member = _step(tp, node.get("type"))
        return _unwrap(member) if member is not None else tp
    return tp


def _fields(tp: Any) -> list[str]:
    """The field names of `tp` if it is a model (the keys a file may leave out), else none."""
    return list(tp.model_fields) if isinstance(tp, type) and issubclass(tp, BaseModel) else []


def _dotted_name(node: dict, tokens: list, i: int) -> int:
    """The end of the longest run of names from `i` on that is a key of `node` (definition names
    may hold dots); `i + 1` when none is. The runs are prefixes of one joined string, so each
    costs one slice and one lookup."""
    names = 0
    while i + names < len(tokens) and isinstance(tokens[i + names], str):
        names += 1
    if names == 1 or not any("." in key for key in node if isinstance(key, str)):
        return i + 1
    joined = ".".join(tokens[i : i + names])
    ends = [m.start() for m in re.finditer(r"\.", joined)] + [len(joined)]
    for count in range(names, 1, -1):
        if joined[: ends[count - 1]] in node:
            return i + count
    return i + 1


def _walk(data: Any, tokens: list) -> tuple:
    """The key path `tokens` names in `data`.

    Only the last key may be new: every key before it must be in the data already, or be a field
    of the model there (`camera` when the file gives none); a misspelt name along the way would
    otherwise create an entry nobody asked for (`materials.whit.albedo`)."""
    path: list = []
    node = data
    schema: Any = Scene
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if isinstance(token, int):
            if not isinstance(node, list):
                raise _Problem(f"{format_path(tuple(path))} is not a list, so [{token}] names nothing")
            if token >= len(node):
                raise _Problem(f"{format_path(tuple(path))} has {len(node)} item{'s' if len(node) != 1 else ''}, so [{token}] names none of them")
            schema = _step(_model_at(schema, node), token) if schema is not None else None
            path.append(token)
            node = node[token]
            i += 1
            continue
        if node is not None and not isinstance(node, dict):
            shown = "a list" if isinstance(node, list) else "a single value"
            raise _Problem(f"{format_path(tuple(path))} is {shown}, not a mapping, so it has no key '{token}'")
        j = _dotted_name(node, tokens, i) if isinstance(node, dict) else i + 1
        name = ".".join(tokens[i:j])
        present = isinstance(node, dict) and name in node
        model = _model_at(schema, node)
        fields = _fields(model)
        if not present and j < len(tokens) and name not in fields:
            keys = [k for k in node if isinstance(k, str)] if isinstance(node, dict) else []
            raise _Problem(
                f"no key '{name}' here to set a value inside (only the last key of a --set path may be new)"
                f"{did_you_mean(name, keys + fields)}",
                tuple(path),
            )
        schema = _step(model, name) if model is not None else None
        path.append(name)
        node = node.get(name) if isinstance(node, dict) else None
        i = j
    return tuple(path)


def apply_override(doc: SourceDocument, argument: str) -> None:
    """Apply one `KEY.PATH=VALUE` to `doc` (a composed scene); raises `SceneError` placed in the argument."""
    label = f"--set {argument}"
    # An argument past a bound is named by its start only, not repeated whole in the diagnostic.
    short = f"--set {argument[:40]}..."

    def problem(message: str, column: int = 1, path: tuple = ()) -> SceneError:
        return SceneError([Diagnostic(label, 1, column, path, message)])

    if len(argument) > MAX_ARGUMENT_CHARS:
        label = short
        raise problem(f"the argument is {len(argument):,} characters long, more than the {MAX_ARGUMENT_CHARS:,} allowed")
    if "=" not in argument:
        raise problem("expected KEY.PATH=VALUE, such as image.samples_per_pixel=64")
    key, text = argument.split("=", 1)
    try:
        path = _walk(doc.data, _tokens(key.strip()))
    except _Problem as exc:
        if isinstance(exc, _TooLong):
            label = short
        raise problem(str(exc), path=exc.path) from None
    if not isinstance(doc.data, dict):
        raise problem("the scene is not a mapping of keys, so nothing in it can be set")
    if path[0] == "include":
        raise problem("include cannot be changed by --set: the included files are merged before any --set applies")
    offset = len(key) + 1  # columns before the value, within the argument
    try:
        value_doc = parse_text(text, label, "yaml")
    except SceneError as exc:
        raise SceneError(
            [Diagnostic(label, d.line, d.column + (offset if d.line == 1 else 0), path, d.message) for d in exc.diagnostics]
        ) from None
    # Positions in the argument, keyed by the full path, so diagnostics name the path as set.
    placed = SourceDocument(label, value_doc.data, base_dir=doc.base_dir)
    placed.values[()] = (1, 1)
    placed.keys[path] = (1, 1)
    for sub, (line, col) in value_doc.values.items():
        placed.values[path + sub] = (line, col + (offset if line == 1 else 0))
    for sub, (line, col) in value_doc.keys.items():
        placed.keys[path + sub] = (line, col + (offset if line == 1 else 0))
    placed.problems = [
        Diagnostic(label, d.line, d.column + (offset if d.line == 1 else 0), path + tuple(d.path), d.message)
        for d in value_doc.problems
    ]
    doc.problems += placed.problems
    # Set the value, creating the mappings that lead to it; where one is created, it is the argument's.
    node = doc.data
    for depth, part in enumerate(path[:-1]):
        child = node[part] if isinstance(node, list) else node.get(part)
        if child is None:
            child = node[part] = {}
            doc.origins[path[: depth + 1]] = (placed, path[: depth + 1])
        node = child
    node[path[-1]] = value_doc.data
    # The value replaces what was written there, in the main file or an included one.
    doc.origins = {p: o for p, o in doc.origins.items() if p[: len(path)] != path}
    doc.origins[path] = (placed, path)


def apply_overrides(doc: SourceDocument, arguments: Iterable[str]) -> SourceDocument:
    """Apply every `--set` argument in order (a later one wins); raises `SceneError` listing every
    argument that cannot be applied."""
    arguments = list(arguments)
    if len(arguments) > MAX_OVERRIDES:
        raise SceneError([Diagnostic("--set", 1, 1, (), f"more than {MAX_OVERRIDES} --set arguments")])
    errors: list[Diagnostic] = []
    for argument in arguments:
        try:
            apply_override(doc, argument)
        except SceneError as exc:
            errors += exc.diagnostics
    if errors:
        raise SceneError(errors)
    return doc
