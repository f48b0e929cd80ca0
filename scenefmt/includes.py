"""`include:`: a scene's named definitions and shapes split over several files, merged into one.

A scene (or an included file) may list files under `include:`, relative to its own folder (the
rule for every file a scene names: `named_files.py`). The
named definitions (`textures`, `materials`, `media`, `groups`) and the `shapes` of each are
merged into the including scene; everything else (camera, image, ...) belongs to the main file
alone. Included files may include others. The merged scene is one `SourceDocument` whose
`origins` point each merged part at the file it came from, so every later check (the models,
the graph, the bounds) places its diagnostics in that file, adding which file included it.

Each included file is read as the main one is (a regular file, bounded, YAML aliases counted);
in addition the whole composition is bounded: at most `MAX_INCLUDE_DEPTH` levels, at most
`MAX_INCLUDED_FILES` files and `loading.MAX_FILE_BYTES` bytes in all. A file that includes
itself, directly or through others, is an error; a file included twice by different files (a
shared library of materials) is read once.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .diagnostics import Diagnostic, SceneError, did_you_mean, quote_key
from .files import FileProblem, read_regular_file
from .loading import MAX_FILE_BYTES, STDIN_NAME, SourceDocument, parse_bytes
from .named_files import NamedFileProblem, locate_named_file

MAX_INCLUDE_DEPTH = 16
MAX_INCLUDED_FILES = 256

SECTIONS = ("textures", "materials", "media", "groups")
SINGULAR = {"textures": "texture", "materials": "material", "media": "medium", "groups": "group"}
# What an included file may hold besides the merged sections.
ALLOWED_IN_INCLUDED = frozenset(SECTIONS + ("shapes", "include", "version", "description"))


class _Composer:
    def __init__(self, root: SourceDocument):
        self.root = root
        self.errors: list[Diagnostic] = []
        self.read: set[str] = set()  # real paths of every file read so far
        self.files = 0
        self.bytes_left = MAX_FILE_BYTES

    def include_all(self, doc: SourceDocument, stack: list[str], depth: int) -> None:
        """Merge every file `doc` includes (and theirs) into `doc`."""
        data = doc.data
        if not isinstance(data, dict) or "include" not in data:
            return
        entries = data["include"]
        if isinstance(entries, str) and entries:  # `include: file.yaml`, one file
            self.include_one(doc, ("include",), entries, stack, depth)
            return
        if not isinstance(entries, list):
            return  # the model reports it: expected a file name or a list of them
        for i, entry in enumerate(entries):
            if not isinstance(entry, str) or not entry:
                continue  # the model reports it
            self.include_one(doc, ("include", i), entry, stack, depth)

    def include_one(self, doc: SourceDocument, at: tuple, name: str, stack: list[str], depth: int) -> None:
        def error(message: str) -> None:
            self.errors.append(doc.diagnostic(at, message))

        try:
            path = locate_named_file("included file", name, doc.base_dir)
        except NamedFileProblem as exc:
            error(str(exc))
            return
        real = str(path)
        if real in stack:
            chain = " -> ".join(os.path.basename(p) for p in stack[stack.index(real):] + [real])
            error(f"include cycle: {chain}")
            return
        if real in self.read:
            return  # already merged through another file
        if depth >= MAX_INCLUDE_DEPTH:
            error(f"includes nested deeper than {MAX_INCLUDE_DEPTH} levels")
            return
        if self.files >= MAX_INCLUDED_FILES:
            error(f"more than {MAX_INCLUDED_FILES} included files in all")
            return
        self.files += 1
        self.read.add(real)
        line, col = doc.position(at)
        where = f"{doc.file}:{line}:{col}"
        note = f" (included from {where}" + (f", {doc.note.strip()[1:-1]}" if doc.note else "") + ")"
        try:
            raw = read_regular_file(path, self.bytes_left)
        except FileProblem as exc:
            reason = str(exc)
            if "larger than" in reason:
                reason += f" (a scene and all its includes share {MAX_FILE_BYTES:,} bytes)"
            error(f"included file '{name}': {reason}")
            return
        self.bytes_left -= len(raw)
        # Named as the including file names its folder, so messages stay short and relative.
        shown = os.path.normpath(os.path.join(os.path.dirname(doc.file), name)) if not doc.file.startswith("<") else name
        try:
            sub = parse_bytes(raw, shown, None, Path(real).parent)
        except SceneError as exc:
            # Placed in the file, but its line is not shown (rt watch would): nothing says yet that
            # the file is a scene rather than a credentials file that does not parse as YAML.
            self.errors += [_with_note(d, note, quote_source=False) for d in exc.diagnostics]
            return
        problem = not_a_scene(sub.data, ALLOWED_IN_INCLUDED | SCENE_KEYS, strict=True, expected=ALLOWED_IN_INCLUDED)
        if problem:
            # One error, in the including file: nothing of a file that is no scene is quoted.
            error(f"included file '{name}' is not a scene file: {problem}")
            return
        sub.note = note
        sub.problems = [_with_note(d, note) for d in sub.problems]
        self.include_all(sub, stack + [real], depth + 1)
        self.merge(doc, sub)

    def merge(self, doc: SourceDocument, sub: SourceDocument) -> None:
        """Merge the sections and shapes of `sub` (an included file, its own includes merged) into `doc`."""
        doc.problems += sub.problems
        data = sub.data
        if data is None:
            return  # an empty file: nothing to merge
        if not isinstance(data, dict):
            return  # include_one refused it (not_a_scene)
        for key in data:
            if key not in ALLOWED_IN_INCLUDED:
                self.errors.append(
                    sub.diagnostic(
                        (key,),
                        f"{quote_key(key)} cannot be given in an included file: only textures, materials, media, groups and "
                        "shapes are merged (and include); give it in the main file",
                        of_key=True,
                    )
                )
        if "version" in data and data["version"] != 1:
            self.errors.append(sub.diagnostic(("version",), f"unsupported scene format version {data['version']!r}; this rt reads version 1"))
        if not isinstance(doc.data, dict):
            return
        for section in SECTIONS:
            if section not in data:
                continue
            entries = data[section]
            if not isinstance(entries, dict):
                self.errors.append(sub.diagnostic((section,), f"expected a mapping of names to {section}"))
                continue
            target = doc.data.get(section)
            if target is None:
                target = doc.data[section] = {}
            if not isinstance(target, dict):
                continue  # the model reports the including file's own mistake
            for name, value in entries.items():
                if name in target:
                    line, col = doc.position((section, name), of_key=True)
                    first, _ = doc.locate((section, name))
                    self.errors.append(
                        sub.diagnostic(
                            (section, name),
                            f"{SINGULAR[section]} '{name}' is defined twice: here and at {first.file}:{line}:{col}",
                            of_key=True,
                        )
                    )
                    continue
                target[name] = value
                doc.origins[(section, name)] = (sub, (section, name))
        if "shapes" in data:
            shapes = data["shapes"]
            if not isinstance(shapes, list):
                self.errors.append(sub.diagnostic(("shapes",), "expected a list of shapes"))
                return
            target = doc.data.get("shapes")
            if target is None:
                target = doc.data["shapes"] = []
            if not isinstance(target, list):
                return
            for j, shape in enumerate(shapes):
                doc.origins[("shapes", len(target))] = (sub, ("shapes", j))
                target.append(shape)


def _size(path) -> int:
    try:
        return os.stat(path).st_size
    except OSError:
        return 0


def _with_note(d: Diagnostic, note: str, quote_source: bool = True) -> Diagnostic:
    return Diagnostic(d.file, d.line, d.column, d.path, d.message + note, d.severity, d.quote_source and quote_source)


def _scene_keys() -> frozenset:
    from .scene import Scene

    return frozenset(Scene.model_fields)


SCENE_KEYS = _scene_keys()


def not_a_scene(data: Any, allowed: frozenset, strict: bool = False, expected: Any = None) -> str | None:
    """Why a parsed document is clearly no scene file, in words that quote nothing of it; None if
    it may be one. A scene is a mapping whose top-level keys are scene keys (`allowed`) or
    misspellings of them; a file named where a scene is expected but holding anything else (a
    list, a line of text, /etc/shadow read as YAML, someone's credentials) gets this one sentence,
    never an error per key or line, since those would print its contents. `strict` (an included
    file): any key that is neither is enough; else (the main file, the user's own) only when no
    key is a scene key, or an unknown key is no identifier."""
    expected = ", ".join(sorted(expected or allowed))
    if data is None:
        return None  # an empty file
    if not isinstance(data, dict):
        kind = "a list" if isinstance(data, list) else "a single value" if not isinstance(data, str) else "text"
        return f"its top level is {kind}, not a mapping of the scene's keys ({expected})"
    strangers = [k for k in data if k not in allowed and not did_you_mean(k, allowed)]
    if not strangers:
        return None
    if not strict and len(strangers) < len(data) and not _looks_foreign(strangers):
        return None  # a scene with a stray key: the model names it
    return f"{len(strangers)} of its {len(data)} top-level keys are not scene keys (expected only {expected})"


def _looks_foreign(keys: list) -> bool:
    """Whether unknown keys look like another file's rather than a mistake in a scene: not identifiers."""
    from .diagnostics import key_shown

    return any(not key_shown(k) for k in keys)


def resolve_includes(doc: SourceDocument) -> SourceDocument:
    """Merge the files `doc` includes into it (in place, and returned); raises `SceneError` with
    every problem of the includes themselves (unreadable, cyclic, a name defined twice)."""
    composer = _Composer(doc)
    if not doc.file.startswith("<"):
        composer.bytes_left = max(0, composer.bytes_left - _size(doc.file))
    real = None
    if doc.file and not doc.file.startswith("<"):
        try:
            real = os.path.realpath(doc.file)
        except (OSError, ValueError):
            real = None
    # Data handed over from Python ("<dict>", "<string>") cannot be someone else's file: its keys
    # are reported one by one. A file, or standard input, may be anything.
    from_file = not doc.file.startswith("<") or doc.file == STDIN_NAME
    problem = not_a_scene(doc.data, SCENE_KEYS) if from_file else None
    if problem:
        # The main file's line 1 is not shown either: the user may have named the wrong file.
        raise SceneError([Diagnostic(doc.file, 1, 1, (), f"is not a scene file: {problem}", quote_source=False)])
    stack = [real] if real else []
    composer.read.update(stack)
    composer.include_all(doc, stack, 0)
    if composer.errors:
        raise SceneError(doc.problems + composer.errors)
    return doc


def included_keys(data: Any) -> list:
    """The file names a document includes, as written (for tools that list dependencies)."""
    if isinstance(data, dict) and isinstance(data.get("include"), str):
        return [data["include"]]
    if isinstance(data, dict) and isinstance(data.get("include"), list):
        return [e for e in data["include"] if isinstance(e, str)]
    return []
