"""From parsed data to a checked scene and its graph, reporting every error of a file in one run.

Model validation stops nothing: when some definitions or shapes are invalid, the rest are
validated on their own and resolved into a graph too, so a dangling reference elsewhere in
the file is reported in the same run. References to definitions that were themselves invalid
are not reported twice.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Optional

from pydantic import ValidationError

from .diagnostics import Diagnostic, SceneError
from .errors import data_path, diagnostics_from
from .files import reading_within
from .graph import SceneGraph, build_graph, graph_problems
from .includes import resolve_includes
from .loading import STDIN_NAME, SourceDocument, parse_file, parse_stream, parse_text, paused_gc
from .overrides import apply_overrides
from .scene import Scene
from .shapes import SphereColumns, plain_spheres

_SECTIONS = ("textures", "materials", "media", "groups")


@dataclass
class LoadedScene:
    """A scene that passed every check: the models, the resolved graph, and any warnings."""

    scene: Scene
    graph: SceneGraph
    document: SourceDocument

    @property
    def warnings(self) -> list[Diagnostic]:
        return self.graph.warnings


def _partial_problems(doc: SourceDocument, exc: ValidationError) -> list[Diagnostic]:
    """Graph errors of the valid remainder of a scene whose models failed validation."""
    data = doc.data
    if not isinstance(data, dict):
        return []
    bad_paths = {data_path(data, tuple(e["loc"])) for e in exc.errors(include_url=False)}
    broken: dict[str, set] = {s: set() for s in _SECTIONS}
    bad_shapes: set[int] = set()
    drop_top: set[str] = set()
    for path in bad_paths:
        if not path:
            continue
        if path[0] in _SECTIONS and len(path) >= 2:
            broken[path[0]].add(path[1])
        elif path[0] == "shapes" and len(path) >= 2:
            bad_shapes.add(path[1])
        else:
            drop_top.add(path[0])
    pruned: dict[str, Any] = {k: v for k, v in data.items() if k not in drop_top and k not in _SECTIONS and k != "shapes"}
    for section in _SECTIONS:
        entries = data.get(section)
        if isinstance(entries, dict):
            pruned[section] = {k: v for k, v in entries.items() if k not in broken[section]}
        elif section in data:
            return []
    shapes = data.get("shapes", [])
    if not isinstance(shapes, list):
        return []
    pruned["shapes"] = [s for i, s in enumerate(shapes) if i not in bad_shapes]
    shape_paths = [("shapes", i) for i in range(len(shapes)) if i not in bad_shapes]
    try:
        partial = Scene.model_validate(pruned)
    except ValidationError:
        return []  # errors hide each other too much to say more with confidence
    return graph_problems(partial, doc, broken, shape_paths)


def _with_plain_spheres(data: Any) -> tuple[Any, dict[tuple, SphereColumns]]:
    """`data` with the plain spheres of its shape lists already validated (shapes.plain_spheres),
    and their columns by the path of their list; `data` itself is left as parsed, for the diagnostics."""
    columns: dict[tuple, SphereColumns] = {}
    if not isinstance(data, dict):
        return data, columns
    out = data
    shapes = data.get("shapes")
    fast, columns[("shapes",)] = plain_spheres(shapes)
    if fast is not shapes:
        out = {**data, "shapes": fast}
    groups = data.get("groups")
    if isinstance(groups, dict):
        changed = dict(groups)
        for name, group in groups.items():
            if isinstance(group, dict) and "shapes" in group:
                fast, columns[("groups", name, "shapes")] = plain_spheres(group["shapes"])
                if fast is not group["shapes"]:
                    changed[name] = {**group, "shapes": fast}
        if any(changed[name] is not groups[name] for name in groups):
            out = {**out, "groups": changed}
    return out, {path: cols for path, cols in columns.items() if cols is not None}


def check_document(doc: SourceDocument) -> LoadedScene:
    """Validate parsed data as a scene and resolve its graph; raises `SceneError` with every problem."""
    data, columns = _with_plain_spheres(doc.data)
    try:
        scene = Scene.model_validate(data)
    except ValidationError as exc:
        problems = doc.problems + list(diagnostics_from(exc, doc, Scene))
        problems += _partial_problems(doc, exc)
        raise SceneError(problems) from None
    try:
        graph = build_graph(scene, doc, columns=columns)
    except SceneError as exc:
        raise SceneError(doc.problems + exc.diagnostics) from None
    if doc.problems:
        raise SceneError(doc.problems)
    return LoadedScene(scene, graph, doc)


def compose(doc: SourceDocument, overrides: Iterable[str] = ()) -> SourceDocument:
    """Merge the files `doc` includes, then apply the `--set` overrides; raises `SceneError`."""
    resolve_includes(doc)
    return apply_overrides(doc, overrides)


def allowed_folders(home, allow_paths: Iterable = ()) -> list:
    """The folders a scene may read files from: `home` (the main scene file's folder, or the
    current folder for standard input and data) and every folder of `allow_paths`."""
    return [home] + [Path(p) for p in allow_paths]


def load(path, overrides: Iterable[str] = (), syntax: Optional[str] = None, allow_paths: Iterable = ()) -> LoadedScene:
    """Load, validate and resolve a scene file (YAML or JSON), with its includes and `--set`
    overrides; raises `SceneError`. Files the scene names (includes, textures, meshes) are read
    only from the scene file's own folder (symbolic links resolved) and those in `allow_paths`."""
    home = scene_folder(path)
    with paused_gc(), reading_within(allowed_folders(home, allow_paths)):
        return check_document(compose(parse_file(path, syntax), overrides))


def scene_folder(path) -> Path:
    """The real folder of a scene file: where its relative names resolve from, and what it may read."""
    try:
        return Path(os.path.realpath(os.fsdecode(path))).parent
    except (OSError, ValueError, TypeError):
        return Path.cwd()


def loads(text: str, syntax: str = "yaml", file: str = "<string>", base_dir=None, overrides: Iterable[str] = (),
          allow_paths: Iterable = ()) -> LoadedScene:
    """Like `load`, from text (the files it names are relative to `base_dir`, by default the current
    folder, which is also the folder its files may be read from)."""
    home = Path(base_dir) if base_dir is not None else Path.cwd()
    with paused_gc(), reading_within(allowed_folders(home, allow_paths)):
        return check_document(compose(parse_text(text, file, syntax, base_dir=base_dir), overrides))


def load_stream(stream, overrides: Iterable[str] = (), syntax: Optional[str] = None, allow_paths: Iterable = ()) -> LoadedScene:
    """Like `load`, from a binary stream (standard input), bounded as a file is; relative paths in it
    (includes, images, meshes) resolve from the current folder, and files are read only from there
    (and `allow_paths`)."""
    with paused_gc(), reading_within(allowed_folders(Path.cwd(), allow_paths)):
        return check_document(compose(parse_stream(stream, syntax=syntax), overrides))


def load_source(path, overrides: Iterable[str] = (), syntax: Optional[str] = None, allow_paths: Iterable = ()) -> LoadedScene:
    """`load` for a path given on the command line: `-` is standard input."""
    import sys

    if str(path) == "-":
        if sys.stdin is None:  # the process was started with its standard input closed
            raise SceneError([Diagnostic(STDIN_NAME, 1, 1, (), "standard input is closed, so - names no scene")])
        return load_stream(sys.stdin.buffer, overrides, syntax, allow_paths)
    return load(path, overrides, syntax, allow_paths)
