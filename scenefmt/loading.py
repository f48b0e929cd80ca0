"""Safe loading of YAML and JSON scene files into plain data, keeping the line and column of every node.

Both syntaxes load to the same plain values (dicts, lists, str, int, float, bool, None)
plus a `Positions` table, so later stages can point at `file:line:column` for any key path.

Safety: no object is ever constructed from a tag; file size, nesting depth and the number of
values (YAML aliases counted at their expanded size) are bounded, each checked at the event or
character that passes it, before anything more is built: a "billion laughs" file fails at its
alias, a document too big for this machine's memory at the value past the limit (`node_limit`);
a recursive alias is refused; duplicate keys are errors; and YAML uses the YAML 1.2 core schema,
so `on`, `off`, `yes`, `no` stay strings and `1e3` is a number.
"""

from __future__ import annotations

import bisect
import copy
import gc
import json
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional

import yaml
from yaml.composer import ComposerError
from yaml.parser import Parser
from yaml.reader import Reader
from yaml.resolver import BaseResolver
from yaml.scanner import Scanner

from .diagnostics import Diagnostic, SceneError, quote_key, quote_tag, quote_text  # what a message may quote
from .files import FileProblem, read_regular_file, read_stream

MAX_FILE_BYTES = 128 * 1024 * 1024
MAX_DEPTH = 64
# Nodes of a document, counted before anything is built: YAML counts keys too (12 for a sphere written
# {type: sphere, center: [x, y, z], radius: r, material: m}), JSON its values (8). A million such
# spheres fit; with MAX_FILE_BYTES this bounds what parsing allocates (docs/robustness.md).
MAX_NODES = 16_000_000  # and fewer where memory is smaller: node_limit()
# Values that aliases add by repeating their anchors: reuse (a material, a transform) adds a few
# each time; a "billion laughs" adds millions, which a plain file of the same size could not.
MAX_ALIASED = 200_000
# JSON text longer than this is read by Python's C parser first, its positions found only when a
# diagnostic needs them (parse_json); shorter text by `_JsonParser` at once.
FAST_JSON_BYTES = 1 << 20
# No field takes an integer near this long; longer ones are refused before Python converts them
# (which it refuses itself past 4300 digits, and which takes quadratic time before that).
MAX_INTEGER_DIGITS = 400

Position = tuple[int, int]  # 1-based line, 1-based column


def node_limit() -> int:
    """Values a document may hold here: MAX_NODES, or fewer where this machine's memory could not
    hold that many once read (`bounds.document_value_limit`)."""
    from .bounds import document_value_limit

    return min(MAX_NODES, document_value_limit())


def too_many_values(limit: int, syntax: str = "yaml") -> str:
    """Why a document of more than `limit` values is refused."""
    from .bounds import DOCUMENT_VALUE_BYTES, gib

    held = "expands to" if syntax == "yaml" else "holds"
    if limit < MAX_NODES:
        why = (f", as many as this machine's memory allows reading (about {DOCUMENT_VALUE_BYTES} bytes a value, "
               f"{gib(limit * DOCUMENT_VALUE_BYTES)} in all)")
    else:
        why = " (through YAML aliases or sheer size)" if syntax == "yaml" else ""
    return f"the document {held} more than {limit:,} values{why}; refusing to load it"


@dataclass
class SourceDocument:
    """A parsed scene file: its plain data and where each value and key sits in the text.

    A composed scene (`include:` files merged in, `--set` values applied) is one document whose
    `data` holds everything, and whose `origins` say which parts were read from another document:
    a diagnostic about such a part is placed in the file (or `--set` argument) it was written in.
    """

    file: str
    data: Any
    base_dir: Path = field(default_factory=Path.cwd)
    # Problems that leave the data well defined (a duplicate key keeps its first value), reported
    # together with the schema errors instead of stopping the load.
    problems: list[Diagnostic] = field(default_factory=list)
    # Key path here -> (the document that part was read from, its key path there).
    origins: dict[tuple, tuple["SourceDocument", tuple]] = field(default_factory=dict)
    # Appended to every diagnostic placed in this document: " (included from main.yaml:3:5)".
    note: str = ""
    # Where each value and key is written (`values`, `keys`). A large JSON file is read by Python's
    # own parser, which keeps no positions; `_place` then finds them when first asked, which only
    # a diagnostic does (see parse_json).
    _values: dict[tuple, Position] = field(default_factory=dict, repr=False)
    _keys: dict[tuple, Position] = field(default_factory=dict, repr=False)
    _place: Optional[Callable[[], tuple[dict, dict]]] = field(default=None, repr=False)
    # Where positions are not placed yet, a diagnostic finds the one it needs from the text's
    # structure (`_JsonStructure`), made by this when first asked.
    _find: Optional[Callable[[], Any]] = field(default=None, repr=False)
    _structure: Any = field(default=None, repr=False)

    def _placed(self) -> None:
        if self._place is not None:
            place, self._place = self._place, None
            self._values, self._keys = place()

    @property
    def values(self) -> dict[tuple, Position]:
        """Key path -> where its value is written."""
        self._placed()
        return self._values

    @values.setter
    def values(self, values: dict[tuple, Position]) -> None:
        self._place = None
        self._values = values

    @property
    def keys(self) -> dict[tuple, Position]:
        """Key path -> where its key is written."""
        self._placed()
        return self._keys

    def locate(self, path: tuple) -> tuple["SourceDocument", tuple]:
        """The document `path` was written in, and its key path there."""
        path = tuple(path)
        if self.origins:
            for k in range(len(path), -1, -1):
                origin = self.origins.get(path[:k])
                if origin is not None:
                    doc, there = origin
                    return doc.locate(there + path[k:])
        return self, path

    def _finder(self) -> Any:
        """The structure that places a single path, while every position is not placed yet."""
        if self._place is None or self._find is None:
            return None
        if self._structure is None:
            self._structure = self._find()
        return self._structure

    def _own_position(self, path: tuple, of_key: bool) -> Position:
        finder = self._finder()
        if finder is not None:
            return finder.position(path, of_key)
        if of_key and path in self.keys:
            return self.keys[path]
        while path:
            if path in self.values:
                return self.values[path]
            path = path[:-1]
        return self.values.get((), (1, 1))

    def position(self, path: tuple, of_key: bool = False) -> Position:
        """Where `path` is written; for a missing path, where its nearest written parent is."""
        doc, there = self.locate(path)
        return doc._own_position(there, of_key)

    def written(self, path: tuple) -> bool:
        """Whether `path` itself is written (not only a parent of it)."""
        doc, there = self.locate(path)
        finder = doc._finder()
        return finder.written(there) if finder is not None else there in doc.values

    def base_dir_of(self, path: tuple) -> Path:
        """The folder relative file names at `path` are resolved from: that of the file it is written in."""
        return self.locate(path)[0].base_dir

    def diagnostic(self, path: tuple, message: str, of_key: bool = False, severity: str = "error") -> Diagnostic:
        doc, there = self.locate(path)
        line, col = doc._own_position(there, of_key)
        return Diagnostic(doc.file, line, col, tuple(there), message + doc.note, severity)


@contextmanager
def paused_gc():
    """Python's cycle collector off while a scene is read or flattened. Those steps make millions
    of lists, dicts and models that all live on, and the collector, run every 700 of them and
    through the whole heap every so often, took a third of the time to read a million spheres.
    Cycles made meanwhile are collected once it is back on."""
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_on:
            gc.enable()


# ----------------------------------------------------------------------------------------------
# YAML


class _CoreSchemaResolver(BaseResolver):
    """Implicit typing by the YAML 1.2 core schema instead of PyYAML's YAML 1.1 rules."""

    yaml_implicit_resolvers: dict = {}


_CoreSchemaResolver.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF")
)
_CoreSchemaResolver.add_implicit_resolver(
    "tag:yaml.org,2002:null", re.compile(r"^(?:~|null|Null|NULL|)$"), ["~", "n", "N", ""]
)
_CoreSchemaResolver.add_implicit_resolver(
    "tag:yaml.org,2002:int",
    re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"),
    list("-+0123456789"),
)
_CoreSchemaResolver.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
    ),
    list("-+0123456789."),
)


class _PureEventLoader(Reader, Scanner, Parser, _CoreSchemaResolver):
    """PyYAML's parser, for its events only; `_YamlBuilder` makes the values, never a tag constructor."""

    def __init__(self, stream: str):
        Reader.__init__(self, stream)
        Scanner.__init__(self)
        Parser.__init__(self)
        _CoreSchemaResolver.__init__(self)


if yaml.__with_libyaml__:
    from yaml.cyaml import CParser

    class _LibyamlEventLoader(CParser, _CoreSchemaResolver):
        """The same, with libyaml's C parser (about ten times faster)."""

        def __init__(self, stream: str):
            CParser.__init__(self, stream)
            _CoreSchemaResolver.__init__(self)

    _EventLoader: type = _LibyamlEventLoader
else:  # pragma: no cover - PyYAML wheels ship libyaml
    _EventLoader = _PureEventLoader


def _mark_position(mark: Any) -> Position:
    return (mark.line + 1, mark.column + 1) if mark is not None else (1, 1)


class _Frame:
    """An open sequence or mapping while `_YamlBuilder` reads the events inside it."""

    __slots__ = ("value", "path", "anchor", "mark", "count", "height", "record", "is_map", "key", "want_key", "skip",
                 "seen", "log_start", "as_key")

    def __init__(self, value, path, anchor, mark, record, as_key):
        self.value = value
        self.path = path
        self.anchor = anchor
        self.mark = mark
        self.count = 1  # values in it so far, itself included, aliases at their expanded size
        self.height = 1  # levels of nesting in it
        self.record = record  # whether positions are kept (not inside a duplicate key's value)
        self.is_map = isinstance(value, dict)
        self.key = None
        self.want_key = True
        self.skip = False  # the value of the current key is read and dropped (a duplicate, a merge key)
        self.seen: dict = {}  # key -> position, for duplicates
        self.log_start = 0
        self.as_key = as_key  # a list or mapping written where a key should be


class _Anchor:
    """What an alias repeats: the anchored value, its values and levels of nesting (for the bounds),
    where it is written, its text if it is a scalar (which can be a key), and the positions inside
    it, by key path from it."""

    __slots__ = ("value", "count", "height", "mark", "text", "log")

    def __init__(self, value, count, height, mark, text, log):
        self.value, self.count, self.height, self.mark, self.text, self.log = value, count, height, mark, text, log


class _YamlBuilder:
    """Plain values, their positions and the problems of a YAML document, built from the parser's
    events in one pass.

    No node tree is composed first: every bound (nesting, values, values added by aliases, a
    recursive alias) is checked at the event that passes it, before anything more is built, so a
    document too big for this machine costs what was read up to that point. A value repeated by an
    alias is a copy of its anchor's, placed where the anchor is written, as the composed tree gave."""

    def __init__(self, text: str, doc: SourceDocument):
        self.text = text
        self.doc = doc
        self.file = doc.file
        self.problems: list[Diagnostic] = []
        self.anchors: dict[str, _Anchor] = {}
        self.open_anchors: dict[str, _Frame] = {}
        self.log: list = []  # (path, position, is_key) recorded while an anchored collection is open
        self.total = 0
        self.aliased = 0
        self.limit = node_limit()

    def problem(self, mark: Any, path: tuple, message: str) -> None:
        self.problems.append(Diagnostic(self.file, *_mark_position(mark), path, message))

    def refuse(self, mark: Any, message: str, path: tuple = ()) -> SceneError:
        return SceneError([Diagnostic(self.file, *_mark_position(mark), path, message)])

    def record(self, path: tuple, position: Position, is_key: bool = False) -> None:
        (self.doc.keys if is_key else self.doc.values)[path] = position
        if self.open_anchors:
            self.log.append((path, position, is_key))

    def counted(self, mark: Any, size: int) -> None:
        self.total += size
        if self.total > self.limit:
            raise self.refuse(mark, too_many_values(self.limit))

    # -- the events --

    def build(self) -> Any:
        loader = _EventLoader(self.text)
        try:
            loader.get_event()  # the stream's start
            if loader.check_event(yaml.StreamEndEvent):
                return _EMPTY
            loader.get_event()  # the document's start
            value = self.document(loader)
            loader.get_event()  # the document's end
            if not loader.check_event(yaml.StreamEndEvent):
                event = loader.get_event()
                raise ComposerError("expected a single document in the stream", None, "but found another document", event.start_mark)
            return value
        finally:
            loader.dispose()

    def document(self, loader) -> Any:
        stack: list[_Frame] = []
        get_event = loader.get_event
        values = self.doc._values  # YAML's positions are placed as it is read (no _place)
        while True:
            event = get_event()
            kind = type(event)
            if kind is yaml.SequenceEndEvent or kind is yaml.MappingEndEvent:
                frame = stack.pop()
                value, done = self.closed(frame, stack)
            else:
                parent = stack[-1] if stack else None
                if parent is not None and parent.is_map and parent.want_key:
                    if kind is yaml.ScalarEvent or kind is yaml.AliasEvent:
                        self.key(parent, event, kind, len(stack))
                        continue
                    path, record, as_key = parent.path, False, True
                    self.problem(event.start_mark, parent.path, "keys must be plain names, not lists or mappings")
                elif parent is None:
                    path, record, as_key = (), True, False
                elif parent.is_map:
                    path, record, as_key = parent.path + (parent.key,), parent.record and not parent.skip, False
                else:
                    path, record, as_key = parent.path + (len(parent.value),), parent.record, False
                if kind is yaml.ScalarEvent:
                    self.total += 1
                    if self.total > self.limit:
                        raise self.refuse(event.start_mark, too_many_values(self.limit))
                    if parent is not None:
                        parent.count += 1
                    mark = event.start_mark
                    position = (mark.line + 1, mark.column + 1)
                    if record:
                        values[path] = position
                        if self.open_anchors:
                            self.log.append((path, position, False))
                    text, tag = event.value, event.tag
                    if tag is None or tag == "!":
                        tag = _plain_tag(text) if event.implicit[0] else _STR_TAG
                    value = text if tag is _STR_TAG else self.scalar(tag, text, mark, path)
                    if event.anchor is not None:
                        self.define(event.anchor, event.start_mark, _Anchor(value, 1, 0, event.start_mark, event.value, [((), position, False)]))
                elif kind is yaml.AliasEvent:
                    value = self.alias(event, path, record, len(stack), parent)
                else:
                    frame = self.opened(loader, event, kind, path, record, as_key, len(stack) + 1)
                    stack.append(frame)
                    continue
                done = True
            if not done:
                continue
            if not stack:
                return value
            self.attach(stack[-1], value)

    def opened(self, loader, event, kind, path: tuple, record: bool, as_key: bool, depth: int) -> _Frame:
        if depth > MAX_DEPTH:
            raise self.refuse(event.start_mark, f"nesting deeper than {MAX_DEPTH} levels")
        self.counted(event.start_mark, 1)
        is_map = kind is yaml.MappingStartEvent
        tag = event.tag
        if tag is None or tag == "!":
            tag = loader.resolve(yaml.MappingNode if is_map else yaml.SequenceNode, None, event.implicit)
        if tag != ("tag:yaml.org,2002:map" if is_map else "tag:yaml.org,2002:seq"):
            self.problem(event.start_mark, path, f"the tag {quote_tag(tag)} is not allowed in a scene file")
        frame = _Frame({} if is_map else [], path, event.anchor, event.start_mark, record, as_key)
        if event.anchor is not None:
            self.define(event.anchor, event.start_mark, None)
            frame.log_start = len(self.log)
            self.open_anchors[event.anchor] = frame
        if record:
            self.record(path, _mark_position(event.start_mark))
        return frame

    def closed(self, frame: _Frame, stack: list) -> tuple[Any, bool]:
        parent = stack[-1] if stack else None
        if parent is not None:
            parent.count += frame.count
            parent.height = max(parent.height, 1 + frame.height)
        if frame.anchor is not None:
            del self.open_anchors[frame.anchor]
            cut = len(frame.path)
            log = [(path[cut:], position, is_key) for path, position, is_key in self.log[frame.log_start:]]
            self.anchors[frame.anchor] = _Anchor(frame.value, frame.count, frame.height, frame.mark, None, log)
            if not self.open_anchors:
                self.log = []
        if frame.as_key:  # a list or mapping where a key should be: reported, and its value dropped
            parent.want_key, parent.skip = False, True
            return None, False
        return frame.value, True

    def attach(self, parent: _Frame, value: Any) -> None:
        if not parent.is_map:
            parent.value.append(value)
            return
        if not parent.skip:
            parent.value[parent.key] = value
        parent.want_key, parent.skip, parent.key = True, False, None

    def key(self, parent: _Frame, event, kind, depth: int) -> None:
        parent.want_key = False
        if kind is yaml.AliasEvent:
            anchor = self.anchored(event, parent.path)
            self.expanded(event, anchor, depth, parent)
            if anchor.text is None:
                self.problem(anchor.mark, parent.path, "keys must be plain names, not lists or mappings")
                parent.skip = True
                return
            text, mark = anchor.text, anchor.mark
        else:
            self.counted(event.start_mark, 1)
            parent.count += 1
            text, mark = event.value, event.start_mark
            if event.anchor is not None:
                position = _mark_position(mark)
                self.define(event.anchor, mark, _Anchor(text, 1, 0, mark, text, [((), position, False)]))
        path = parent.path + (text,)
        if text == "<<":
            self.problem(mark, parent.path, "YAML merge keys ('<<') are not supported; define the part once under a name and refer to it")
            parent.skip = True
            return
        position = _mark_position(mark)
        first = parent.seen.get(text)
        if first is not None:
            self.problem(mark, path, f"duplicate key {quote_key(text)} (first given at line {first[0]}, column {first[1]})")
            parent.skip = True
            return
        parent.seen[text] = position
        parent.key = text
        if parent.record:
            self.record(path, position, is_key=True)

    # -- anchors and aliases --

    def define(self, name: str, mark: Any, anchor: Optional[_Anchor]) -> None:
        if name in self.anchors or name in self.open_anchors:
            first = self.anchors[name].mark if name in self.anchors else self.open_anchors[name].mark
            raise ComposerError(f"found duplicate anchor {quote_key(name)}; first occurrence", first, "second occurrence", mark)
        if anchor is not None:
            self.anchors[name] = anchor

    def anchored(self, event, path: tuple) -> _Anchor:
        name = event.anchor
        if name in self.open_anchors:
            # Its node would contain itself: the composed tree never ended, nor any walk of it.
            raise self.refuse(event.start_mark, f"the YAML alias *{name} refers to the node that contains it (recursive alias)", path)
        anchor = self.anchors.get(name)
        if anchor is None:
            raise ComposerError(None, None, f"found undefined alias {quote_key(name)}", event.start_mark)
        return anchor

    def expanded(self, event, anchor: _Anchor, depth: int, parent: Optional[_Frame]) -> None:
        """Count what the alias repeats; refuse it where the repetition passes a bound."""
        name = event.anchor
        if depth + anchor.height > MAX_DEPTH:
            raise self.refuse(event.start_mark, f"nesting deeper than {MAX_DEPTH} levels once the alias *{name} is expanded")
        self.aliased += anchor.count
        if self.aliased > MAX_ALIASED:
            raise self.refuse(
                event.start_mark,
                f"the document expands to more than {MAX_ALIASED:,} values through its aliases (at *{name}: anchors are "
                "for reuse, not for multiplying data); refusing to load it",
            )
        self.counted(event.start_mark, anchor.count)
        if parent is not None:
            parent.count += anchor.count
            parent.height = max(parent.height, 1 + anchor.height)

    def alias(self, event, path: tuple, record: bool, depth: int, parent: Optional[_Frame]) -> Any:
        anchor = self.anchored(event, path)
        self.expanded(event, anchor, depth, parent)
        if record:
            for sub, position, is_key in anchor.log:
                self.record(path + sub, position, is_key)
        return copy.deepcopy(anchor.value) if anchor.text is None else anchor.value

    # -- scalars --

    def scalar(self, tag: str, text: str, mark: Any, path: tuple) -> Any:
        """The value of a scalar whose tag is resolved (`_plain_tag`)."""
        if tag == "tag:yaml.org,2002:float":
            try:
                return float(text)
            except ValueError:
                pass  # .inf, .nan and their spellings, below
        if tag == _STR_TAG:
            return text
        if tag == "tag:yaml.org,2002:null":
            return None
        if tag == "tag:yaml.org,2002:bool":
            return text.lower() == "true"
        if tag == "tag:yaml.org,2002:int":
            if len(text) > MAX_INTEGER_DIGITS:
                self.problem(mark, path, f"the integer has {len(text):,} digits, more than the {MAX_INTEGER_DIGITS} any value of a scene may have")
                return text
            try:
                if text.startswith("0o"):
                    return int(text[2:], 8)
                if text.startswith("0x"):
                    return int(text[2:], 16)
                return int(text, 10)
            except ValueError:
                self.problem(mark, path, f"{quote_text(text)} is not an integer")
                return text
        if tag == "tag:yaml.org,2002:float":
            low = text.lower()
            if low.endswith(".inf"):
                return float("-inf") if low.startswith("-") else float("inf")
            if low == ".nan":
                return float("nan")
            try:
                return float(text)
            except ValueError:
                self.problem(mark, path, f"{quote_text(text)} is not a number")
                return text
        self.problem(mark, path, f"the tag {quote_tag(tag)} is not allowed in a scene file")
        return text


_EMPTY = object()  # a document with no value at all
_STR_TAG = "tag:yaml.org,2002:str"
# The core schema's resolvers by a plain scalar's first character ('' for the empty scalar): what
# BaseResolver.resolve does for a plain scalar, without the per-call work done for path resolvers.
_PLAIN_RESOLVERS = {first: tuple(resolvers) for first, resolvers in _CoreSchemaResolver.yaml_implicit_resolvers.items()}


def _plain_tag(text: str) -> str:
    for tag, regexp in _PLAIN_RESOLVERS.get(text[:1], ()):
        if regexp.match(text):
            return tag
    return _STR_TAG


_OPENERS = {"[": "]", "{": "}", '"': '"', "'": "'"}


def _yaml_syntax_error(exc: yaml.MarkedYAMLError, text: str, file: str) -> Diagnostic:
    """A YAML syntax error, placed where the mistake most likely is.

    An unclosed bracket or quote is noticed only where the parser runs into the next thing it
    cannot fit in, often a line or more later; the diagnostic then points at the opening bracket
    or quote (the parser's context mark) and says where the parser stopped."""
    mark = exc.problem_mark or exc.context_mark
    what = exc.problem or "invalid YAML"
    context = exc.context or ""
    if exc.context_mark is not None and exc.problem_mark is not None and context.startswith(
        ("while parsing a flow", "while scanning a quoted scalar")
    ):
        line, col = _mark_position(exc.context_mark)
        lines = text.splitlines()
        opener = lines[line - 1][col - 1] if line <= len(lines) and col <= len(lines[line - 1]) else ""
        if opener in _OPENERS:
            stop_line, stop_col = _mark_position(exc.problem_mark)
            return Diagnostic(
                file, line, col, (),
                f"YAML syntax error: this {opener!r} is never closed by a {_OPENERS[opener]!r} "
                f"({what} at line {stop_line}, column {stop_col})",
            )
    if context:
        what = f"{what} ({context})"
    return Diagnostic(file, *_mark_position(mark), (), f"YAML syntax error: {what}")


def parse_yaml(text: str, file: str) -> SourceDocument:
    doc = SourceDocument(file=file, data=None)
    builder = _YamlBuilder(text, doc)
    try:
        data = builder.build()
    except yaml.MarkedYAMLError as exc:
        raise SceneError([_yaml_syntax_error(exc, text, file)]) from None
    except yaml.YAMLError as exc:
        raise SceneError([Diagnostic(file, 1, 1, (), f"YAML error: {exc}")]) from None
    if data is _EMPTY:
        doc.data = {}
        doc.values[()] = (1, 1)
        return doc
    doc.data = data
    duplicates = [p for p in builder.problems if p.message.startswith("duplicate key")]
    if len(duplicates) < len(builder.problems):
        raise SceneError(builder.problems)
    doc.problems = duplicates
    return doc


# ----------------------------------------------------------------------------------------------
# JSON

_JSON_NUMBER = re.compile(r"-?(?:0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)?")
_JSON_SPACE = re.compile(r"[ \t\n\r]*")


class _JsonParser:
    """A strict RFC 8259 parser that records positions and rejects duplicate keys.

    Python's `json` module cannot report where a value sits, so scene files get this small
    recursive-descent parser; strings are still decoded by `json.decoder.scanstring`.
    """

    def __init__(self, text: str, doc: SourceDocument):
        self.text = text
        self.doc = doc
        self.line_starts = [0] + [m.end() for m in re.finditer("\n", text)]
        self.nodes = 0
        self.limit = node_limit()
        self.muted = 0  # inside a duplicate key's value: read, its positions not kept
        self.problems: list[Diagnostic] = []

    def where(self, offset: int) -> Position:
        line = bisect.bisect_right(self.line_starts, offset) - 1
        return (line + 1, offset - self.line_starts[line] + 1)

    def fail(self, offset: int, message: str, syntax: bool = True) -> SceneError:
        prefix = "JSON syntax error: " if syntax else ""
        return SceneError([Diagnostic(self.doc.file, *self.where(offset), (), prefix + message)])

    def skip(self, i: int) -> int:
        return _JSON_SPACE.match(self.text, i).end()

    def parse(self) -> Any:
        i = self.skip(0)
        value, i = self.value(i, (), 1)
        i = self.skip(i)
        if i != len(self.text):
            raise self.fail(i, "extra data after the end of the document")
        self.doc.problems = self.problems
        return value

    def value(self, i: int, path: tuple, depth: int) -> tuple[Any, int]:
        self.nodes += 1
        if self.nodes > self.limit:
            raise self.fail(i, too_many_values(self.limit, "json"), syntax=False)
        if depth > MAX_DEPTH:
            raise self.fail(i, f"nesting deeper than {MAX_DEPTH} levels", syntax=False)
        if not self.muted:
            self.doc.values[path] = self.where(i)
        if i >= len(self.text):
            raise self.fail(i, "unexpected end of file, expected a value")
        ch = self.text[i]
        if ch == "{":
            return self.obj(i, path, depth)
        if ch == "[":
            return self.array(i, path, depth)
        if ch == '"':
            return self.string(i)
        for word, val in (("true", True), ("false", False), ("null", None)):
            if self.text.startswith(word, i):
                return val, i + len(word)
        m = _JSON_NUMBER.match(self.text, i)
        if m and m.end() > i:
            s = m.group(0)
            if not (m.group(1) or m.group(2)):
                if len(s) > MAX_INTEGER_DIGITS:
                    raise self.fail(i, f"the integer has {len(s) - s.startswith('-'):,} digits, more than the {MAX_INTEGER_DIGITS} any value of a scene may have", syntax=False)
                return int(s), m.end()
            number = float(s)
            if number in (float("inf"), float("-inf")):
                raise self.fail(i, f"the number {s} is too large to represent")
            return number, m.end()
        raise self.fail(i, f"unexpected character {ch!r}, expected a value")

    def string(self, i: int) -> tuple[str, int]:
        try:
            return json.decoder.scanstring(self.text, i + 1, True)
        except json.JSONDecodeError as exc:
            if exc.msg.startswith(("Invalid control character", "Unterminated string")):
                raise self.fail(i, "unterminated string starting here (missing closing quote?)") from None
            raise self.fail(exc.pos, exc.msg[0].lower() + exc.msg[1:]) from None

    def obj(self, i: int, path: tuple, depth: int) -> tuple[dict, int]:
        out: dict[str, Any] = {}
        i = self.skip(i + 1)
        if self.text.startswith("}", i):
            return out, i + 1
        while True:
            if not self.text.startswith('"', i):
                if self.text.startswith("}", i) and out:
                    raise self.fail(i, "trailing comma before '}'")
                raise self.fail(i, "expected a key in double quotes")
            key_at = i
            key, i = self.string(i)
            i = self.skip(i)
            if not self.text.startswith(":", i):
                raise self.fail(i, "expected ':' after the key")
            i = self.skip(i + 1)
            if key in out:
                if not self.muted:
                    line, col = self.doc.keys[path + (key,)]
                    self.problems.append(Diagnostic(
                        self.doc.file, *self.where(key_at), path + (key,), f"duplicate key {quote_key(key)} (first given at line {line}, column {col})"
                    ))
                # Read, but its positions not kept: the first value's stay (a copy of every position
                # made for each duplicate made many duplicates quadratic).
                self.muted += 1
                _, i = self.value(i, path + (key,), depth + 1)
                self.muted -= 1
            else:
                if not self.muted:
                    self.doc.keys[path + (key,)] = self.where(key_at)
                out[key], i = self.value(i, path + (key,), depth + 1)
            i = self.skip(i)
            if self.text.startswith(",", i):
                i = self.skip(i + 1)
                continue
            if self.text.startswith("}", i):
                return out, i + 1
            raise self.fail(i, "expected ',' or '}'")

    def array(self, i: int, path: tuple, depth: int) -> tuple[list, int]:
        out: list[Any] = []
        i = self.skip(i + 1)
        if self.text.startswith("]", i):
            return out, i + 1
        while True:
            if self.text.startswith("]", i):
                raise self.fail(i, "trailing comma before ']'")
            item, i = self.value(i, path + (len(out),), depth + 1)
            out.append(item)
            i = self.skip(i)
            if self.text.startswith(",", i):
                i = self.skip(i + 1)
                continue
            if self.text.startswith("]", i):
                return out, i + 1
            raise self.fail(i, "expected ',' or ']'")


_JSON_SPACE_BYTES = re.compile(rb"[^ \t\n\r]")


class _JsonStructure:
    """The brackets, commas, colons and opening quotes of a JSON text without backslashes, found
    with numpy (a bracket is outside every string when an even number of quotes comes before it).

    It answers two questions without reading the values: how many values the text holds, and,
    given a key path, where that value (and its key) is written. The second lets a diagnostic
    about a large file be placed in milliseconds, where placing every value (`_JsonParser`) cost
    minutes and gigabytes for a few million."""

    def __init__(self, text: str):
        import numpy as np

        self.raw = text.encode("utf-8")
        raw = np.frombuffer(self.raw, np.uint8)
        interesting = np.zeros(256, bool)
        interesting[[ord(c) for c in '"[]{},:']] = True
        pos = np.flatnonzero(interesting[raw])
        ch = raw[pos]
        quote = ch == ord('"')
        opening = np.cumsum(quote, dtype=np.int64) & 1  # 1 at an opening quote and inside a string
        keep = np.where(quote, opening == 1, opening == 0)
        self.pos, self.ch = pos[keep], ch[keep]
        step = np.zeros(len(self.ch), np.int8)
        step[(self.ch == ord("[")) | (self.ch == ord("{"))] = 1
        step[(self.ch == ord("]")) | (self.ch == ord("}"))] = -1
        after = np.cumsum(step, dtype=np.int32)
        self.depth = after - step  # open brackets before each symbol
        self.deepest = int(after.max()) if len(after) else 0
        self._items: dict[int, Any] = {}
        self._members: dict[int, dict] = {}

    def start(self, offset: int) -> int:
        """The byte offset of the first character at or after `offset` that is not white space."""
        m = _JSON_SPACE_BYTES.search(self.raw, offset)
        return m.start() if m else len(self.raw)

    def value_starts(self):
        """Byte offsets of the symbols a value follows, in order: every comma and every bracket
        that opens a non-empty list or object (the document's own value comes before them all)."""
        import numpy as np

        ch, pos = self.ch, self.pos
        opener = (ch == ord("[")) | (ch == ord("{"))
        # An opener is empty when the next symbol closes it with only white space between.
        nxt = np.append(ch[1:], 0)
        maybe_empty = np.flatnonzero(opener & ((nxt == ord("]")) | (nxt == ord("}"))))
        empty = [i for i in maybe_empty.tolist() if self.start(int(pos[i]) + 1) == int(pos[i + 1])]
        opener[empty] = False
        return pos[opener | (ch == ord(","))]

    def where(self, offset: int) -> Position:
        line_start = self.raw.rfind(b"\n", 0, offset) + 1
        return (self.raw.count(b"\n", 0, offset) + 1, len(self.raw[line_start:offset].decode("utf-8", "replace")) + 1)

    def _inside(self, opener: int):
        """The symbols directly inside the list or object whose bracket is at byte `opener`."""
        import numpy as np

        i = int(np.searchsorted(self.pos, opener))
        level = self.depth[i] + 1
        close = (self.depth[i + 1 :] == level) & ((self.ch[i + 1 :] == ord("]")) | (self.ch[i + 1 :] == ord("}")))
        j = i + 1 + int(np.argmax(close))
        sel = np.flatnonzero(self.depth[i + 1 : j] == level) + i + 1
        return self.pos[sel], self.ch[sel]

    def item(self, opener: int, index: int) -> Optional[int]:
        """Byte offset of item `index` of the list opened at `opener`, or None."""
        commas = self._items.get(opener)
        if commas is None:
            pos, ch = self._inside(opener)
            commas = self._items[opener] = pos[ch == ord(",")]
        if index > len(commas):
            return None
        at = self.start((opener if index == 0 else int(commas[index - 1])) + 1)
        return None if index == 0 and self.raw[at : at + 1] == b"]" else at

    def member(self, opener: int, key: str) -> Optional[tuple[int, int]]:
        """Byte offsets of `key` and of its value in the object opened at `opener`, or None."""
        members = self._members.get(opener)
        if members is None:
            pos, ch = self._inside(opener)
            members = {}
            previous = ord("{")
            for k, (offset, c) in enumerate(zip(pos.tolist(), ch.tolist())):
                if c == ord('"') and previous in (ord("{"), ord(",")):
                    end = self.raw.index(b'"', offset + 1)
                    name = self.raw[offset + 1 : end].decode("utf-8")
                    colon = int(pos[k + 1])
                    members.setdefault(name, (offset, self.start(colon + 1)))
                previous = c
            self._members[opener] = members
        return members.get(key)

    def walk(self, path: tuple) -> tuple[int, Optional[int], int]:
        """(how many parts of `path` are written, the byte offset of the last one's key if it is
        an object's member, the byte offset of its value)."""
        value, key = self.start(0), None
        for done, part in enumerate(path):
            c = self.raw[value : value + 1]
            found = None
            if c == b"[" and isinstance(part, int) and not isinstance(part, bool) and part >= 0:
                at = self.item(value, part)
                found = None if at is None else (None, at)
            elif c == b"{" and isinstance(part, str):
                found = self.member(value, part)
            if found is None:
                return done, key, value
            key, value = found
        return len(path), key, value

    def position(self, path: tuple, of_key: bool) -> Position:
        done, key, value = self.walk(path)
        if of_key and done == len(path) and key is not None:
            return self.where(key)
        return self.where(value)

    def written(self, path: tuple) -> bool:
        return self.walk(path)[0] == len(path)


class _Unusual(Exception):
    """The fast JSON reading met something only the positional parser reports well."""


def _refuse(*_args):
    raise _Unusual


def _finite_float(text: str) -> float:
    number = float(text)
    if number - number != 0.0:
        raise _Unusual  # too large to represent: the positional parser says so
    return number


def _short_int(text: str) -> int:
    if len(text) > MAX_INTEGER_DIGITS:
        raise _Unusual
    return int(text)


def _unique_keys(pairs: list) -> dict:
    out = dict(pairs)
    if len(out) != len(pairs):
        raise _Unusual  # a duplicate key: the positional parser reports where
    return out


def _json_tables():
    import numpy as np

    # What a byte is to the depth check: 1 a quote, 2 an opening bracket, 3 a closing one.
    symbol = np.zeros(256, np.uint8)
    symbol[ord('"')] = 1
    symbol[[ord("["), ord("{")]] = 2
    symbol[[ord("]"), ord("}")]] = 3
    return symbol


_JSON_SYMBOL = None


class _TooMany(Exception):
    """The JSON text holds more values than `node_limit()`: the first one past it starts at `position`."""

    def __init__(self, position: Position, limit: int):
        self.position, self.limit = position, limit


def _fast_json(text: str) -> Optional[Any]:
    """The data of `text` read by Python's C parser, or None where only `_JsonParser` can answer:
    a syntax error, a duplicate key, NaN or an infinity, a number too large for a float, an
    integer of more than MAX_INTEGER_DIGITS digits, a backslash anywhere, or nesting deeper than
    MAX_DEPTH. Both parsers accept the same documents and read them to the same data; the C one is
    about fifty times faster on a file of a million shapes. Raises `_TooMany` for a text of more
    values than `node_limit()`, counted before any is read."""
    import numpy as np

    global _JSON_SYMBOL
    if "\\" in text:
        return None
    # Each value is the document, or follows an opener or a comma: at most this many (those in
    # strings counted too, and empty lists and objects, which only errs on the safe side). Past
    # the limit they are counted exactly, outside strings.
    limit = node_limit()
    if 1 + text.count("[") + text.count("{") + text.count(",") > limit:
        structure = _JsonStructure(text)
        starts = structure.value_starts()
        if 1 + len(starts) > limit:
            raise _TooMany(structure.where(structure.start(int(starts[limit - 1]) + 1)), limit)
        if structure.deepest + 1 > MAX_DEPTH:
            return None
        del structure, starts
    else:
        if _JSON_SYMBOL is None:
            _JSON_SYMBOL = _json_tables()
        raw = np.frombuffer(text.encode("utf-8"), np.uint8)
        # Without backslashes every '"' opens or closes a string: a bracket is outside one when an
        # even number of quotes comes before it.
        symbols = _JSON_SYMBOL[raw]
        symbols = symbols[symbols != 0]
        quote = symbols == 1
        outside = ~quote & ((np.cumsum(quote, dtype=np.int64) & 1) == 0)
        step = np.where(symbols[outside] == 2, np.int8(1), np.int8(-1))
        if len(step) and int(np.cumsum(step, dtype=np.int64).max()) + 1 > MAX_DEPTH:  # the value at the deepest level is one more
            return None
    try:
        return json.loads(text, object_pairs_hook=_unique_keys, parse_constant=_refuse, parse_float=_finite_float, parse_int=_short_int)
    except (ValueError, RecursionError, _Unusual):
        return None


def parse_json(text: str, file: str) -> SourceDocument:
    doc = SourceDocument(file=file, data=None)
    try:
        data = _fast_json(text) if len(text) > FAST_JSON_BYTES else None
    except _TooMany as exc:
        raise SceneError([Diagnostic(file, *exc.position, (), too_many_values(exc.limit, "json"))]) from None
    if data is None:
        doc.data = _JsonParser(text, doc).parse()
        return doc

    def place() -> tuple[dict, dict]:
        again = SourceDocument(file=file, data=None)
        _JsonParser(text, again).parse()
        return again.values, again.keys

    doc.data = data
    doc._place = place
    doc._find = lambda: _JsonStructure(text)
    return doc


# ----------------------------------------------------------------------------------------------


def syntax_of(path: Path, text: str) -> str:
    """`json` for .json files, `yaml` for .yaml/.yml; otherwise sniff the first character."""
    suffix = path.suffix.lower()
    if suffix == ".json":
        return "json"
    if suffix in (".yaml", ".yml"):
        return "yaml"
    return "json" if text.lstrip().startswith(("{", "[")) else "yaml"


def parse_text(text: str, file: str = "<string>", syntax: str = "yaml", base_dir: Path | None = None) -> SourceDocument:
    """Parse scene text of either syntax into a `SourceDocument`; raises `SceneError`."""
    if len(text) > MAX_FILE_BYTES:
        raise SceneError([Diagnostic(file, 1, 1, (), f"the file is larger than {MAX_FILE_BYTES // (1024 * 1024)} MiB")])
    if text.startswith("\ufeff"):
        text = text[1:]
    doc = parse_json(text, file) if syntax == "json" else parse_yaml(text, file)
    doc.base_dir = base_dir if base_dir is not None else Path.cwd()
    return doc


def parse_bytes(raw: bytes, file: str, syntax: str | None = None, base_dir: Path | None = None) -> SourceDocument:
    """Parse the bytes of a scene (UTF-8, YAML or JSON: `syntax`, or detected); raises `SceneError`."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise SceneError([Diagnostic(file, line, col, (), "the file is not valid UTF-8 text")]) from None
    return parse_text(text, file, syntax or syntax_of(Path(file), text), base_dir=base_dir)


def parse_file(path: str | Path, syntax: str | None = None, limit: int = MAX_FILE_BYTES) -> SourceDocument:
    """Read and parse a scene file; raises `SceneError` naming the file on any problem.

    Only a regular file is read (not a device, FIFO or directory, even through a symlink), and
    never more than `limit` bytes of it (see `scenefmt.files`). `syntax` ("yaml" or "json")
    overrides the detection by suffix and first character.
    """
    name = os.fsdecode(path) if isinstance(path, bytes) else str(path)
    try:
        raw = read_regular_file(path, limit)
    except FileProblem as exc:
        raise SceneError([Diagnostic(name, 1, 1, (), str(exc))]) from None
    path = Path(path)
    try:
        base_dir = path.resolve().parent
    except (OSError, RuntimeError):  # the file was read, so this is a race; keep its folder as named
        base_dir = Path(os.path.abspath(path)).parent
    return parse_bytes(raw, name, syntax, base_dir)


STDIN_NAME = "<stdin>"


def parse_stream(stream, file: str = STDIN_NAME, syntax: str | None = None) -> SourceDocument:
    """Read a scene from a binary stream (standard input), at most `MAX_FILE_BYTES` of it, and parse
    it; relative paths in it resolve from the current folder."""
    try:
        raw = read_stream(stream, MAX_FILE_BYTES)
    except FileProblem as exc:
        raise SceneError([Diagnostic(file, 1, 1, (), str(exc))]) from None
    return parse_bytes(raw, file, syntax, Path.cwd())
