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


def format_path(path: Sequence) -> str:
    """`('materials', 'glass', 'ior')` -> `materials.glass.ior`; `('shapes', 3)` -> `shapes[3]`."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
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
