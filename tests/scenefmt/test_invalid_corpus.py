"""A corpus of invalid scene files, each rejected with its diagnostics pinned.

Every file under `invalid/` is invalid in one way (a few on purpose in several, to prove that all
errors of a file are reported in one run). A YAML file states what it expects in its leading
comment lines, one per diagnostic:

    # expect: LINE:COLUMN KEY.PATH: MESSAGE SUBSTRING

(`(top level)` is the key path of a diagnostic about the whole file.) JSON has no comments, so
the expectations of the JSON files are in `JSON_CASES` below. The test loads each file with
`scenefmt.validation.load` and requires exactly the expected diagnostics: the same count, each
one matched by line, column, key path and message substring, all errors, all naming the file.
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import NamedTuple

import pytest

from scenefmt import loading
from scenefmt.diagnostics import Diagnostic, SceneError, format_path
from scenefmt.validation import load

INVALID_DIR = Path(__file__).parent / "invalid"

_EXPECT = re.compile(r"^#\s*expect:\s*(\d+):(\d+)\s+(.+?):\s+(.+?)\s*$")


class Expect(NamedTuple):
    line: int
    column: int
    path: str  # as `format_path` writes it
    message: str  # a substring of the diagnostic's message

    def matches(self, d: Diagnostic) -> bool:
        return (
            d.line == self.line
            and d.column == self.column
            and format_path(d.path) == self.path
            and self.message in d.message
        )

    def __str__(self) -> str:
        return f"{self.line}:{self.column} {self.path}: ...{self.message}..."


# JSON files cannot hold comments: their reason and expected diagnostics live here.
JSON_CASES: dict[str, tuple[str, list[Expect]]] = {
    "json_trailing_comma.json": (
        "a trailing comma after the last member of an object",
        [Expect(5, 3, "(top level)", "JSON syntax error: trailing comma before '}'")],
    ),
    "json_missing_quote.json": (
        "a string missing its closing quote swallows the next key's opening quote",
        [Expect(7, 24, "(top level)", "JSON syntax error: expected ',' or '}'")],
    ),
    "json_missing_closing_quote.json": (
        "a string value whose closing quote is missing runs into the end of the line",
        [Expect(3, 18, "(top level)", "JSON syntax error: unterminated string starting here")],
    ),
    "json_duplicate_material.json": (
        "two materials with the same name",
        [Expect(5, 5, "materials.red", "duplicate key 'red' (first given at line 4, column 5)")],
    ),
    "json_duplicate_field.json": (
        "the same field twice in one shape",
        [Expect(12, 7, "shapes[0].radius", "duplicate key 'radius' (first given at line 10, column 7)")],
    ),
    "json_bool_for_number.json": (
        "a boolean where a number is expected, reported in the file's own spelling",
        [Expect(4, 44, "materials.glass.ior", "expected a valid number, found true")],
    ),
    "json_misspelt_type.json": (
        "a misspelt shape type",
        [Expect(4, 14, "shapes[0].type", "unknown type 'sphear'; did you mean 'sphere'?")],
    ),
    "json_several_errors.json": (
        "five independent errors in five sections, schema and reference errors reported together",
        [
            Expect(3, 49, "camera.look_at", "look_from and look_at are the same point"),
            Expect(4, 48, "image.samples_per_pixel", "expected a number >= 1, found 0"),
            Expect(6, 67, "textures.board.odd[2]", "expected a number >= 0, found -1"),
            Expect(9, 47, "materials.floor.albedo", "undefined texture 'bord'"),
            Expect(13, 69, "shapes[1].interior", "undefined medium 'smoke'; the scene defines no media"),
        ],
    ),
}



def _yaml_expectations(path: Path) -> list[Expect]:
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break  # expectations are in the leading comment block only
        m = _EXPECT.match(line)
        if m:
            out.append(Expect(int(m.group(1)), int(m.group(2)), m.group(3), m.group(4)))
    return out


def expectations(path: Path) -> list[Expect]:
    if path.suffix == ".json":
        return JSON_CASES[path.name][1]
    return _yaml_expectations(path)


def _case_files() -> list[Path]:
    return sorted(p for p in INVALID_DIR.iterdir() if p.suffix in (".yaml", ".yml", ".json"))


def _params():
    for path in _case_files():
        yield pytest.param(path.name, id=path.name)


def load_errors(path: Path) -> list[Diagnostic]:
    with pytest.raises(SceneError) as info:
        load(path)
    assert str(info.value) == "\n".join(str(d) for d in info.value.diagnostics)
    return info.value.diagnostics


def assert_diagnostics(path: Path, found: list[Diagnostic], expected: list[Expect]) -> None:
    shown = "\n".join(str(d) for d in found)
    for d in found:
        assert d.file == str(path), f"diagnostic names {d.file!r}, not {str(path)!r}"
        assert d.severity == "error", f"not an error: {d}"
    assert len(found) == len(expected), f"expected {len(expected)} diagnostics, got {len(found)}:\n{shown}"
    unmatched = list(found)
    for e in expected:
        hit = next((d for d in unmatched if e.matches(d)), None)
        assert hit is not None, f"no diagnostic matches {e}; got:\n{shown}"
        unmatched.remove(hit)


@pytest.mark.parametrize("name", list(_params()))
def test_invalid_scene(name: str, tmp_path, monkeypatch, capfd) -> None:
    path = INVALID_DIR / name
    expected = expectations(path)
    assert expected, f"{name} states no expected diagnostics"
    # Run from an unrelated folder: relative files must resolve against the scene file, and
    # nothing a hostile file might do can land in the repository.
    monkeypatch.chdir(tmp_path)
    start = time.perf_counter()
    found = load_errors(path)
    elapsed = time.perf_counter() - start
    assert_diagnostics(path, found, expected)

    if name == "billion_laughs.yaml":
        assert elapsed < 2.0, f"the alias bomb took {elapsed:.2f} s to refuse"
    if name == "python_tag.yaml":
        out, err = capfd.readouterr()
        assert "hi" not in out.split() and "hi" not in err.split(), "the python tag was executed"
        assert list(tmp_path.iterdir()) == []
    if name == "image_texture_missing_file.yaml":
        looked_for = (INVALID_DIR / "maps" / "no_such_earthmap.png").resolve()
        assert f"(looked for {looked_for})" in found[0].message


@pytest.mark.parametrize("syntax", ["yaml", "json"])
def test_nesting_deeper_than_limit(syntax: str, tmp_path) -> None:
    depth = loading.MAX_DEPTH + 10
    nested = "[" * depth + "]" * depth
    if syntax == "yaml":
        prefix = "description: "
        text = f"# too deep\n{prefix}{nested}\n"
    else:
        prefix = '{"description": '
        text = f"\n{prefix}{nested}}}\n"
    path = tmp_path / f"deep.{syntax}"
    path.write_text(text, encoding="utf-8")
    start = time.perf_counter()
    found = load_errors(path)
    assert time.perf_counter() - start < 2.0
    # The root mapping is one level, so the limit is passed at the MAX_DEPTH-th bracket.
    column = len(prefix) + loading.MAX_DEPTH
    assert_diagnostics(path, found, [Expect(2, column, "(top level)", f"nesting deeper than {loading.MAX_DEPTH} levels")])


def test_corpus_is_complete() -> None:
    files = _case_files()
    names = {p.name for p in files}
    assert len(files) >= 40
    assert sum(p.suffix == ".json" for p in files) >= 6
    assert not set(JSON_CASES) - names, "JSON_CASES names files that do not exist"
    for path in files:
        if path.suffix == ".json":
            assert path.name in JSON_CASES, f"{path.name} has no entry in JSON_CASES"
        else:
            lines = path.read_text(encoding="utf-8").splitlines()
            assert lines[0].startswith("#") and not _EXPECT.match(lines[0]), f"{path.name}: first line should say why it is invalid"
            assert _yaml_expectations(path), f"{path.name} has no '# expect:' line"
