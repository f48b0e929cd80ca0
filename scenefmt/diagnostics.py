"""Diagnostics: one problem found in a scene file, placed at file:line:column and a key path."""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from typing import Iterable, Sequence

KeyPath = tuple  # of str (mapping keys) and int (list indices)

# C0 and C1 control characters, DEL, and the Unicode controls that reorder or hide text
# (bidirectional overrides and isolates, zero-width marks, line and paragraph separators).
_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u200b-\u200f\u2028-\u202e\u2066-\u2069\ufeff]")


def escape_control(text: str) -> str:
    """`text` with every control character written as an escape (`\\x1b`, `\\u202e`), so a
    key, name or file name taken from a hostile file cannot drive the terminal it is printed on."""

    def escaped(match: "re.Match[str]") -> str:
        code = ord(match.group(0))
        return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"

    return _CONTROL.sub(escaped, text)


# What a message may quote from a file. A scene's keys and names are identifiers (`base.Name`),
# words at most (`red glass`); a line of /etc/shadow or a credentials file read as YAML is not. A key is quoted
# only when it looks like one; a found string only when it is a short word. Anything else is
# described by its length, so a misspelt `radious` is still named, and a password never is.
_SHOWN_KEY = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_ .+\-]{0,63}")
_SHOWN_TAG = re.compile(r"[!A-Za-z0-9_:./,\-]{1,80}")  # a YAML tag, `tag:yaml.org,2002:python/object`
_SHOWN_TEXT = re.compile(r"[A-Za-z0-9_ .+\-]{0,32}")


def key_shown(key) -> bool:
    """Whether a key (or a name, a type tag) read from a file may be quoted in a message."""
    return isinstance(key, str) and _SHOWN_KEY.fullmatch(key) is not None


def quote_key(key) -> str:
    """`'radious'` for a key that looks like one; `(not shown: 83 characters)` for anything else."""
    if key_shown(key) or isinstance(key, (bool, int, float)):
        return f"'{key}'"
    return f"(not shown: {_characters(len(str(key)))})"


def _characters(n: int) -> str:
    return f"{n} character{'s' if n != 1 else ''}"


def quote_tag(tag: str) -> str:
    """A YAML tag as a message may show it: quoted if it looks like one, else by its length."""
    return f"'{tag}'" if _SHOWN_TAG.fullmatch(tag) else f"(not shown: {_characters(len(tag))})"


def path_part(key) -> str:
    """A key as a key path prints it: itself if it may be quoted, else `<83 characters>`."""
    return str(key) if key_shown(key) else f"<{_characters(len(str(key)))}>"


def quote_text(text: str) -> str:
    """A string value found in a file as a message may show it: `'red'`, or `a string of 40 characters`."""
    if _SHOWN_TEXT.fullmatch(text):
        return repr(text)
    return f"a string of {_characters(len(text))}"


def format_path(path: Sequence) -> str:
    """`('materials', 'glass', 'ior')` -> `materials.glass.ior`; `('shapes', 3)` -> `shapes[3]`.
    A key that is not an identifier is printed as its length (`path_part`)."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + path_part(part)
    return out or "(top level)"


@dataclass(frozen=True, order=True)
class Diagnostic:
    """A problem (or, with severity `warning`, a remark) about one place in a scene file."""

    file: str
    line: int
    column: int
    path: KeyPath = field(default=(), compare=False)
    message: str = field(default="", compare=False)
    severity: str = field(default="error", compare=False)
    # Whether the line it points at may be shown (rt watch's page does): not for a file that is
    # not known to be a scene (an included file that does not parse, a main file that is no scene).
    quote_source: bool = field(default=True, compare=False)

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}:{self.column}"
        return escape_control(f"{where}: {self.severity}: {format_path(self.path)}: {self.message}")

    def to_json(self) -> dict:
        return {
            "file": self.file,
            "line": self.line,
            "column": self.column,
            "path": format_path(self.path),
            "message": self.message,
            "severity": self.severity,
        }


class SceneError(Exception):
    """A scene could not be loaded; `diagnostics` lists every problem found, in file order."""

    def __init__(self, diagnostics: Iterable[Diagnostic]):
        self.diagnostics = sorted(diagnostics)
        super().__init__("\n".join(str(d) for d in self.diagnostics))


def did_you_mean(word: str, candidates: Iterable[str]) -> str:
    """A ` (did you mean 'x'?)` suffix when `word` looks like a misspelling of a candidate."""
    matches = difflib.get_close_matches(str(word), sorted(set(candidates)), n=1, cutoff=0.6)
    return f"; did you mean '{matches[0]}'?" if matches else ""
