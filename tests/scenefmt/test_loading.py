"""The loader: YAML 1.2 typing, positions, duplicate keys, and bounds on hostile input."""

import time

import pytest

from scenefmt import loading
from scenefmt.diagnostics import SceneError
from scenefmt.loading import parse_file, parse_text


def only_error(excinfo) -> str:
    diags = excinfo.value.diagnostics
    assert len(diags) == 1, [str(d) for d in diags]
    return diags[0]


@pytest.mark.parametrize("word", ["on", "off", "yes", "no", "y", "n", "On", "NO", "Yes"])
def test_yaml_11_booleans_stay_strings(word):
    assert parse_text(f"name: {word}").data == {"name": word}


@pytest.mark.parametrize(
    "text, value",
    [("1e3", 1000.0), ("-2.5E-1", -0.25), ("0x1f", 31), ("0o17", 15), ("12", 12), (".5", 0.5), ("true", True),
     ("False", False), ("~", None), ("null", None), ("1:20", "1:20"), ("0777", 777), ("2001-12-14", "2001-12-14")],
)
def test_yaml_core_schema_scalars(text, value):
    got = parse_text(f"v: {text}").data["v"]
    assert got == value and type(got) is type(value)


def test_yaml_positions_are_one_based_line_and_column():
    doc = parse_text("camera:\n  vfov: 40\nshapes:\n  - {type: sphere, radius: 2}\n")
    assert doc.position(("camera", "vfov")) == (2, 9)
    assert doc.position(("shapes", 0, "radius")) == (4, 28)
    assert doc.position(("camera", "vfov"), of_key=True) == (2, 3)
    # A path that is not written points at its nearest written parent.
    assert doc.position(("shapes", 0, "center")) == (4, 5)


def test_json_positions_and_types():
    doc = parse_text('{\n  "a": [1, 2.5e0, true, null],\n  "b": {"c": "x"}\n}', syntax="json")
    assert doc.data == {"a": [1, 2.5, True, None], "b": {"c": "x"}}
    assert type(doc.data["a"][0]) is int
    assert doc.position(("a", 1)) == (2, 12)
    assert doc.position(("b", "c")) == (3, 14)
    assert doc.position(("b", "c"), of_key=True) == (3, 9)


@pytest.mark.parametrize("syntax, text, where", [
    ("yaml", "a: 1\nb: 2\na: 3\n", (3, 1)),
    ("json", '{"a": 1,\n "a": 2}', (2, 2)),
])
def test_duplicate_keys_are_errors(syntax, text, where):
    # The first value is kept so the rest of the file can still be checked in the same run.
    doc = parse_text(text, syntax=syntax)
    assert doc.data["a"] == 1
    (diag,) = doc.problems
    assert (diag.line, diag.column) == where
    assert "duplicate key 'a' (first given at line 1" in diag.message


def test_billion_laughs_fails_fast_without_expanding():
    lines = ['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 10):
        refs = ",".join([f"*a{i-1}"] * 10)
        lines.append(f"a{i}: &a{i} [{refs}]")
    start = time.perf_counter()
    with pytest.raises(SceneError) as excinfo:
        parse_text("\n".join(lines))
    assert time.perf_counter() - start < 2.0
    assert "expands to more than" in only_error(excinfo).message


def test_small_aliases_still_work():
    doc = parse_text("base: &v [1, 2, 3]\nother: *v\n")
    assert doc.data["other"] == [1, 2, 3]


@pytest.mark.parametrize("syntax", ["yaml", "json"])
def test_nesting_depth_is_bounded(syntax):
    depth = loading.MAX_DEPTH + 5
    text = "[" * depth + "]" * depth
    with pytest.raises(SceneError) as excinfo:
        parse_text(text, syntax=syntax)
    assert "nesting deeper than" in only_error(excinfo).message


@pytest.mark.parametrize("text", [
    "a: !!python/object/apply:os.system ['echo pwned']",
    "a: !!python/name:os.system",
    "a: !custom 3",
    "a: !!binary aGVsbG8=",
])
def test_tags_never_construct_objects(text, capfd):
    with pytest.raises(SceneError) as excinfo:
        parse_text(text)
    assert "is not allowed in a scene file" in only_error(excinfo).message
    assert "pwned" not in capfd.readouterr().out


def test_merge_keys_are_rejected():
    with pytest.raises(SceneError) as excinfo:
        parse_text("base: &b {x: 1}\nother:\n  <<: *b\n  y: 2\n")
    assert "merge keys" in only_error(excinfo).message


def test_file_size_is_bounded(tmp_path, monkeypatch):
    monkeypatch.setattr(loading, "MAX_FILE_BYTES", 100)
    path = tmp_path / "big.yaml"
    path.write_text("a: " + "x" * 200)
    with pytest.raises(SceneError) as excinfo:
        parse_file(path)
    assert "larger than" in only_error(excinfo).message


def test_node_count_is_bounded_in_json(monkeypatch):
    monkeypatch.setattr(loading, "MAX_NODES", 50)
    with pytest.raises(SceneError) as excinfo:
        parse_text("[" + ",".join(["1"] * 100) + "]", syntax="json")
    assert "more than 50 values" in only_error(excinfo).message


@pytest.mark.parametrize("syntax, text, where, words", [
    # An unclosed bracket or quote is noticed a line later; the error points at where it opens.
    ("yaml", "a: [1, 2\nb: 3\n", (1, 4), "this '[' is never closed by a ']' (did not find expected ',' or ']' at line 2, column 2)"),
    ("yaml", "a: {b: 1\nc: 3\n", (1, 4), "this '{' is never closed by a '}'"),
    ("yaml", 'a: "open\nb: 3\n', (1, 4), "this '\"' is never closed"),
    ("yaml", "a: [1, 2]]\n", (1, 10), "YAML syntax error"),
    ("json", '{"a": [1, 2,]}', (1, 13), "trailing comma before ']'"),
    ("json", '{"a": 1e400}', (1, 7), "too large"),
    ("json", '{"a": "open}', (1, 7), "unterminated string"),
    ("json", '{"a": 1} x', (1, 10), "extra data"),
    ("json", "{'a': 1}", (1, 2), "double quotes"),
    ("json", '{"a": NaN}', (1, 7), "expected a value"),
])
def test_syntax_errors_have_positions(syntax, text, where, words):
    with pytest.raises(SceneError) as excinfo:
        parse_text(text, syntax=syntax)
    diag = only_error(excinfo)
    assert words in diag.message
    assert (diag.line, diag.column) == where


def test_invalid_utf8_is_reported_with_position(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_bytes(b"a: 1\nb: \xff\n")
    with pytest.raises(SceneError) as excinfo:
        parse_file(path)
    diag = only_error(excinfo)
    assert (diag.line, diag.column, diag.file) == (2, 4, str(path))


def test_missing_file_is_reported(tmp_path):
    with pytest.raises(SceneError) as excinfo:
        parse_file(tmp_path / "nope.yaml")
    assert "cannot read the file" in only_error(excinfo).message


def test_syntax_follows_the_suffix_or_the_first_character(tmp_path):
    (tmp_path / "a.scene").write_text('{"a": 1}')
    (tmp_path / "b.yml").write_text("a: 1")
    assert parse_file(tmp_path / "a.scene").data == {"a": 1}
    assert parse_file(tmp_path / "b.yml").data == {"a": 1}


def test_empty_file_is_an_empty_mapping():
    assert parse_text("").data == {}
    assert parse_text("# only a comment\n").data == {}


# Large JSON files are read by Python's C parser and their positions found only when a diagnostic
# asks (loading.parse_json). With the threshold at 0, every document below takes that way.
FAST_CASES = [
    '{"a": [1, 2.5, -0.0, 1e-3, true, false, null], "b": {"c": "x,y]}[", "d": []}, "e": {}}',
    '{"shapes": [\n{"type": "sphere", "center": [0, 1, 2], "radius": 0.5, "material": "m"},\n'
    '{"type": "sphere", "center": [3, 4, 5], "radius": 1, "material": "m"}]}',
    '  [1, {"k": "\\u00e9"}]  ',
    '{"a": 1, "a": 2}',  # duplicate key: reported by the positional parser
    '{"a": NaN}', '{"a": 1e999}', '{"a": [1, 2,]}', '{"a": 1} x', "", '{"a": "' + "9" * 500 + '"}',
    '{"a": ' + "1" * 450 + '}', "[" * 70 + "]" * 70, "[" * 63 + "]" * 63,
    '["' + "]" * 10 + '", ' + "[" * 66 + "]" * 66 + "]",  # closing brackets in a string do not hide the depth
    '["' + "[" * 80 + '", 1]',  # nor do opening ones add to it
]


def _outcome(text):
    try:
        doc = parse_text(text, syntax="json")
    except SceneError as exc:
        return "error", [str(d) for d in exc.diagnostics]
    return doc.data, dict(doc.values), dict(doc.keys), [str(d) for d in doc.problems]


@pytest.mark.parametrize("text", FAST_CASES)
def test_the_fast_json_path_reads_what_the_positional_parser_reads(text, monkeypatch):
    slow = _outcome(text)
    monkeypatch.setattr(loading, "FAST_JSON_BYTES", 0)
    fast = _outcome(text)
    assert repr(fast) == repr(slow)


def test_the_fast_json_path_finds_positions_only_when_asked(monkeypatch):
    monkeypatch.setattr(loading, "FAST_JSON_BYTES", 0)
    doc = parse_text('{"shapes": [\n  {"radius": -1}\n]}', syntax="json")
    assert doc._place is not None
    assert doc.position(("shapes", 0, "radius")) == (2, 14)
    assert doc.position(("shapes", 0, "radius"), of_key=True) == (2, 4)
    assert doc.written(("shapes", 0)) and not doc.written(("shapes", 1))
    assert doc._place is not None  # one path was found from the text's structure, not every one placed
    assert doc.values[("shapes", 0, "radius")] == (2, 14)
    assert doc._place is None


def test_the_fast_json_path_bounds_values_and_depth(monkeypatch):
    monkeypatch.setattr(loading, "FAST_JSON_BYTES", 0)
    monkeypatch.setattr(loading, "MAX_NODES", 50)
    with pytest.raises(SceneError) as excinfo:
        parse_text("[" + ",".join(["1"] * 100) + "]", syntax="json")
    assert "more than 50 values" in only_error(excinfo).message
