"""Generate `docs/format.md`, the reference of every type and field of the scene format, from the models.

Everything below the hand-written introduction comes from the models: each model's docstring
(one descriptive paragraph, then a ```yaml example), and each field's annotation, constraints,
default and `description`. `python -m scenefmt.docgen` rewrites the committed file;
`python -m scenefmt.docgen --check` exits 1 when it is out of date.

The parts: `walk` takes annotations apart and finds the models and unions; `accepted_values`
words a field's type and constraints; `yaml_values` writes defaults and literals as YAML;
`sections` places each model under a heading; `introduction` is the hand-written opening;
`page` assembles the Markdown.
`main` reads `DOC_PATH` from this module, so that replacing `scenefmt.docgen.DOC_PATH` (as the
tests do, to check a stale copy) redirects it.

Pure Python: it needs pydantic and the scene models only (no numpy, no numba).
"""

from __future__ import annotations

import difflib
import sys
from pathlib import Path

from .introduction import INTRODUCTION
from .page import render_reference
from .sections import slug

__all__ = ["DOC_PATH", "INTRODUCTION", "REGENERATE", "main", "render_reference", "slug"]

DOC_PATH = Path(__file__).resolve().parent.parent.parent / "docs" / "format.md"
REGENERATE = "python -m scenefmt.docgen"


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    text = render_reference()
    if "--check" in args:
        current = DOC_PATH.read_text(encoding="utf-8") if DOC_PATH.is_file() else ""
        if current != text:
            diff = list(
                difflib.unified_diff(
                    current.splitlines(), text.splitlines(), "docs/format.md (committed)", "generated", lineterm="", n=1
                )
            )
            print("\n".join(diff[:40]) + ("\n..." if len(diff) > 40 else ""), file=sys.stderr)
            print(f"{DOC_PATH} is out of date; run: {REGENERATE}", file=sys.stderr)
            return 1
        print(f"{DOC_PATH} is up to date")
        return 0
    DOC_PATH.parent.mkdir(parents=True, exist_ok=True)
    DOC_PATH.write_text(text, encoding="utf-8")
    print(f"wrote {DOC_PATH}")
    return 0
