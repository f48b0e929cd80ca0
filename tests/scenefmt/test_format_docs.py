"""docs/format.md is generated from the models and covers every type, field and example of the format."""

from __future__ import annotations

import inspect
import re
import typing

import pytest
from pydantic import BaseModel

from scenefmt import docgen, models
from scenefmt.loading import parse_text
from scenefmt.scene import Scene
from scenefmt.validation import loads

def _reachable_models(root: type[BaseModel]) -> list[type[BaseModel]]:
    """Every model reachable from `root` through field annotations (independent of docgen's walk)."""
    found: list[type[BaseModel]] = []

    def visit(tp: typing.Any) -> None:
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if tp not in found:
                found.append(tp)
                for info in tp.model_fields.values():
                    visit(info.annotation)
            return
        for arg in typing.get_args(tp):
            visit(arg)

    visit(root)
    return found


def _exported_models() -> list[type[BaseModel]]:
    out = []
    for name in models.__all__:
        value = getattr(models, name)
        if isinstance(value, type) and issubclass(value, BaseModel):
            out.append(value)
    return out


ALL_MODELS = sorted(set(_reachable_models(Scene)) | set(_exported_models()), key=lambda m: m.__name__)


def _docstring(model: type[BaseModel]) -> str:
    return inspect.cleandoc(model.__dict__.get("__doc__") or "")


def _description(model: type[BaseModel]) -> str:
    return " ".join(_docstring(model).split("```", 1)[0].split())


def _example(model: type[BaseModel]) -> str | None:
    m = re.search(r"```yaml\n(.*?)```", _docstring(model), re.S)
    return m.group(1) if m else None


@pytest.fixture(scope="module")
def doc_text() -> str:
    return docgen.DOC_PATH.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def blocks(doc_text: str) -> list[tuple[str, str]]:
    """(heading, body up to the next heading) for every heading of the document."""
    out: list[tuple[str, str]] = []
    heading, body = "", []
    in_code = False
    for line in doc_text.splitlines():
        if line.startswith("```"):
            in_code = not in_code
        if not in_code and re.match(r"^#{1,6} ", line):
            out.append((heading, "\n".join(body)))
            heading, body = line.lstrip("#").strip(), []
        else:
            body.append(line)
    out.append((heading, "\n".join(body)))
    return out


def _table_keys(body: str) -> list[str]:
    return re.findall(r"^\| `([^`]+)` \|", body, re.M)


# (1) The committed file is what the models generate.


def test_committed_reference_is_up_to_date(doc_text: str) -> None:
    assert doc_text == docgen.render_reference(), (
        "docs/format.md is out of date with the models in scenefmt/; regenerate it with: python -m scenefmt.docgen"
    )


def test_check_flag_reports_a_stale_file(tmp_path, monkeypatch, capsys) -> None:
    assert docgen.main(["--check"]) == 0
    stale = tmp_path / "format.md"
    stale.write_text(docgen.render_reference().replace("## Camera", "## Kamera"), encoding="utf-8")
    monkeypatch.setattr(docgen, "DOC_PATH", stale)
    assert docgen.main(["--check"]) == 1
    assert "python -m scenefmt.docgen" in capsys.readouterr().err


# (2) Every model of the format has a section, and every field a row in its table.


def test_the_walk_finds_the_whole_format() -> None:
    names = {m.__name__ for m in ALL_MODELS}
    for expected in ("Scene", "Camera", "Sphere", "Instance", "Group", "ConstantMedium", "Rotation", "MatrixStep"):
        assert expected in names


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: m.__name__)
def test_every_model_has_a_section_with_all_its_fields(model, blocks) -> None:
    description = _description(model)
    matches = [(h, body) for h, body in blocks if description and description in " ".join(body.split())]
    assert matches, f"docs/format.md has no section describing {model.__name__} ({description!r})"
    assert len(matches) == 1, f"{model.__name__}'s description appears under several headings"
    heading, body = matches[0]
    info = model.model_fields.get("type")
    if info is not None:
        (value,) = typing.get_args(info.annotation)
        assert f"`{value}`" in heading or heading.lower().startswith(str(value)), heading
    keys = _table_keys(body)
    assert sorted(keys) == sorted(model.model_fields), f"table of {model.__name__} under '{heading}'"
    example = _example(model)
    if example is not None:
        assert "```yaml\n" + example in body, f"the example of {model.__name__} is missing under '{heading}'"


def test_inherited_shape_fields_appear_in_each_shape_table(blocks) -> None:
    for heading, body in blocks:
        if heading.endswith(" shape") and heading != "`instance` shape":
            keys = _table_keys(body)
            assert "material" in keys and "transform" in keys, heading


def test_accepted_values_are_written_for_humans(doc_text: str) -> None:
    rows = [line for line in doc_text.splitlines() if line.startswith("| `")]
    assert rows
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split(" | ")]
        assert len(cells) == 4, row
        key, accepted, default, description = cells
        assert accepted and default and description, row
        for leak in ("typing.", "<class", "Annotated", "tuple[", "FieldInfo", "NoneType", "PydanticUndefined"):
            assert leak not in accepted and leak not in default, row


def test_internal_links_point_at_headings(doc_text: str, blocks) -> None:
    anchors = {docgen.slug(h) for h, _ in blocks if h}
    for target in re.findall(r"\]\(#([^)]+)\)", doc_text):
        assert target in anchors, f"link to #{target} has no heading"


# (3) Every example in the docstrings is valid on its own model.


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: m.__name__)
def test_docstring_example_validates(model) -> None:
    example = _example(model)
    assert example is not None, f"{model.__name__}'s docstring has no ```yaml example"
    if model is Scene:
        loaded = loads(example)
        assert isinstance(loaded.scene, Scene)
        return
    doc = parse_text(example)
    model.model_validate(doc.data)


# (4) Every model and field is described.


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: m.__name__)
def test_every_model_and_field_has_a_description(model) -> None:
    assert _description(model), f"{model.__name__} has no docstring description"
    for name, info in model.model_fields.items():
        assert info.description and info.description.strip(), f"{model.__name__}.{name} has no description"


def test_introduction_example_loads() -> None:
    (example,) = re.findall(r"```yaml\n(.*?)```", docgen.INTRODUCTION, re.S)
    assert example.startswith("# yaml-language-server: $schema=")
    loads(example)
