"""`--set KEY.PATH=VALUE`: change one value of a scene from the command line, checked like the file.

`KEY.PATH` is a key path as diagnostics print it (`image.samples_per_pixel`, `materials.glass.ior`,
`shapes[2].radius`); `VALUE` is read as YAML (`64`, `1.33`, `[1, 0, 0]`, `{type: metal, fuzz: 0.1}`)
by the same safe, bounded loader as a scene file. The value replaces whatever the path held
(missing mappings along the way are created), and the scene is then validated as a whole: an
error about the value is placed in the `--set` argument itself, as
`--set image.width=100.5:1:13: error: image.width: ...`, the column counted in the argument.

A definition's name may contain dots (`glass.1`): at each mapping the longest run of the path's
dotted parts that names an existing key is taken.
"""

from __future__ import annotations

import re
from typing import Any, Iterable

from .diagnostics import Diagnostic, SceneError, format_path
from .loading import SourceDocument, parse_text

MAX_OVERRIDES = 1000
_PART = re.compile(r"([^.\[\]]+)|\[(\d{1,9})\]")


class _Problem(Exception):
    pass


def _tokens(key: str) -> list:
    """`shapes[2].radius` -> ['shapes', 2, 'radius'] (names as strings, indices as ints)."""
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
        expect_name = False
        i = m.end()
    if not out or expect_name:
        raise _Problem(f"cannot read the key path {key!r}: expected a name such as image.width or shapes[0].radius")
    return out


def _walk(data: Any, tokens: list) -> tuple:
    """The key path `tokens` names in `data`: dotted names joined where that names an existing key."""
    path: list = []
    node = data
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if isinstance(token, int):
            if not isinstance(node, list):
                raise _Problem(f"{format_path(tuple(path))} is not a list, so [{token}] names nothing")
            if token >= len(node):
                raise _Problem(f"{format_path(tuple(path))} has {len(node)} item{'s' if len(node) != 1 else ''}, so [{token}] names none of them")
            path.append(token)
            node = node[token]
            i += 1
            continue
        if node is not None and not isinstance(node, dict):
            shown = "a list" if isinstance(node, list) else "a single value"
            raise _Problem(f"{format_path(tuple(path))} is {shown}, not a mapping, so it has no key '{token}'")
        # Names may hold dots: take the longest run of parts that is a key already.
        j = i + 1
        if isinstance(node, dict):
            for k in range(len(tokens), i + 1, -1):
                run = tokens[i:k]
                if all(isinstance(t, str) for t in run) and ".".join(run) in node:
                    j = k
                    break
        name = ".".join(tokens[i:j])
        path.append(name)
        node = node.get(name) if isinstance(node, dict) else None
        i = j
    return tuple(path)


def apply_override(doc: SourceDocument, argument: str) -> None:
    """Apply one `KEY.PATH=VALUE` to `doc` (a composed scene); raises `SceneError` placed in the argument."""
    label = f"--set {argument}"

    def problem(message: str, column: int = 1) -> SceneError:
        return SceneError([Diagnostic(label, 1, column, (), message)])

    if "=" not in argument:
        raise problem("expected KEY.PATH=VALUE, such as image.samples_per_pixel=64")
    key, text = argument.split("=", 1)
    try:
        path = _walk(doc.data, _tokens(key.strip()))
    except _Problem as exc:
        raise problem(str(exc)) from None
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
