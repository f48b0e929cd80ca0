"""The import graph of scenefmt, renderer and rt, read from the source: circles and upward arrows.

    python benchmarks/imports.py            # the circles, then renderer's upward arrows
    python benchmarks/imports.py --all      # also every arrow inside renderer/
    python benchmarks/imports.py --root DIR # another checkout (git worktree, git archive): before/after

Nothing is imported: each module's source is parsed (`ast`) and every `import` statement in it,
at the top of the module or inside a function, becomes an arrow from that module to the module it
names. `from package import name` points at the submodule `package.name` when there is one, else
at the package itself (its `__init__.py`). Imports under `if TYPE_CHECKING:` never run and make
no arrow. An arrow is *function-level* when the statement sits inside a function (it runs when
the function is first called, not when the module is imported); such arrows still make circles in
the design, so both kinds count, and the printout marks the function-level ones.

A *circle* is a set of two or more modules each reachable from every other along arrows (a
strongly connected component), or a module that imports itself.

An arrow inside renderer/ is *upward* when it runs from a lower layer to a higher one. The layers,
lowest first:

0. the floor, what every kernel and table may stand on: the numerics (`numerics/vec`, `rng`,
   `cdf`, `simd`: arithmetic, random numbers, sampling tables, the four-wide box test; before
   issue 30 they sat in `kernels/`), `columns` (table declarations), `config` (tuning constants),
   `kernel_flags`, `jit_cache`, `target` (how kernels are declared), `trees` (the instance and
   tree tables), `flat` (the flat scene's fields and the estimators' codes), `sampling` (the
   samplers' codes and the kernels' sampling settings), `film_sums` (how a sample is added to a
   pixel's sums) and `adaptive` (when a pixel may stop: issue 32). Before issue 30
   the whole `kernels/` folder counts here, since the categories stood on it for their vectors
   and random numbers; its tracing modules then import the categories, and those arrows run up:
   the folder was floor and roof at once.
1. the categories, each owning one kind of scene element, its rows and its kernels: `shapes/*`,
   `materials`, `textures`, `media`, `camera`, `background`, `environment`, `lights` (with the
   light tree's `light_tree` and `light_bounds`), the sun and sky (`sky`, `sky_data`, `sun`), and
   the path guide's kernels (`guiding`: its tables and the sampling the integrator asks of it).
2. the tracing layer, `tracing/*`: traversal, shadow rays, the integrator, tiles, probes.
3. everything else: flattening (`compile`), building trees (`bvh`), the render session and its executors,
   kernel variants, film and state.

The packages' `__init__` modules count with their layer (Python runs a package's `__init__`
before any module in it).
"""

from __future__ import annotations

import argparse
import ast
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("scenefmt", "renderer", "rt")

FLOOR = frozenset({
    "renderer", "renderer.columns", "renderer.config", "renderer.kernel_flags", "renderer.jit_cache", "renderer.target",
    "renderer.trees", "renderer.flat", "renderer.sampling", "renderer.film_sums", "renderer.adaptive",
    "renderer.guide_records", "renderer.motion",
})
CATEGORIES = frozenset({
    "renderer.shapes", "renderer.materials", "renderer.textures", "renderer.media", "renderer.camera",
    "renderer.background", "renderer.environment", "renderer.lights", "renderer.light_table", "renderer.punctual",
    "renderer.light_tree", "renderer.light_bounds", "renderer.sky", "renderer.sky_data", "renderer.sun",
    "renderer.guiding", "renderer.caustic_targets", "renderer.light_emission", "renderer.grid_media",
})


def layer(module: str) -> int:
    """The layer of a renderer module (see the module's docstring): 0 floor .. 3 the rest."""
    if module in FLOOR or module.split(".")[:2] in (["renderer", "numerics"], ["renderer", "kernels"]):
        return 0
    if module in CATEGORIES or module.startswith(("renderer.shapes.", "renderer.materials.")):
        return 1
    if module.split(".")[:2] == ["renderer", "tracing"]:
        return 2
    return 3


@dataclass(frozen=True)
class Arrow:
    """`source` imports `target` at `line`; `in_function`: the statement runs only when a function does."""

    source: str
    target: str
    line: int
    in_function: bool

    def __str__(self) -> str:
        kind = " (in a function)" if self.in_function else ""
        return f"{self.source} -> {self.target}  [line {self.line}{kind}]"


def module_files(root: Path = ROOT, packages=PACKAGES) -> dict[str, Path]:
    """Dotted module name -> source file, for every module of `packages` under `root`."""
    found = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _statements(tree: ast.Module):
    """(import statement, whether it sits inside a function), skipping `if TYPE_CHECKING:` blocks."""
    def walk(node, in_function):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                for other in child.orelse:
                    yield from walk_one(other, in_function)
                continue
            yield from walk_one(child, in_function)

    def walk_one(node, in_function):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node, in_function
            return
        inside = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        yield from walk(node, inside)

    yield from walk(tree, False)


def _absolute(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute name a `from ... import` starts from (resolving leading dots)."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def import_arrows(root: Path = ROOT, packages=PACKAGES) -> list[Arrow]:
    """Every arrow between modules of `packages` (imports of anything else are left out)."""
    files = module_files(root, packages)
    arrows = []
    for module, path in files.items():
        is_package = path.name == "__init__.py"
        tree = ast.parse(path.read_text(), str(path))
        for node, in_function in _statements(tree):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = _absolute(module, is_package, node)
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in files else base for alias in node.names]
            for target in targets:
                while target and target not in files and "." in target:
                    target = target.rsplit(".", 1)[0]  # `import a.b.c` of a name inside a module
                if target in files:
                    arrows.append(Arrow(module, target, node.lineno, in_function))
    return sorted(set(arrows), key=lambda a: (a.source, a.target, a.line))


def external_imports(root: Path = ROOT, packages=PACKAGES) -> list[tuple[str, str, int, bool]]:
    """(module, top-level name of an outside package it imports, line, in a function) for every import
    of something outside `packages`: what the tests check for numba, pydantic and dask."""
    files = module_files(root, packages)
    found = []
    for module, path in files.items():
        tree = ast.parse(path.read_text(), str(path))
        for node, in_function in _statements(tree):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top not in packages:
                    found.append((module, top, node.lineno, in_function))
    return found


def circles(arrows: list[Arrow]) -> list[list[str]]:
    """The strongly connected components of two or more modules (and modules that import
    themselves), each sorted, in sorted order: every import circle lies inside one of them."""
    graph: dict[str, set] = {}
    for arrow in arrows:
        graph.setdefault(arrow.source, set()).add(arrow.target)
        graph.setdefault(arrow.target, set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set = set()
    found = []

    def connect(v: str) -> None:  # Tarjan's algorithm, iteratively: no recursion limit to meet
        work = [(v, iter(sorted(graph[v])))]
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        while work:
            node, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on_stack:
                    low[node] = min(low[node], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == node:
                            break
                    if len(component) > 1 or node in graph[node]:
                        found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return sorted(found)


def is_upward(arrow: Arrow) -> bool:
    """Whether an arrow inside renderer/ runs up the layers (see the module's docstring)."""
    source, target = arrow.source, arrow.target
    if not (source.startswith("renderer") and target.startswith("renderer")) or source == target:
        return False
    return layer(source) < layer(target)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--all", action="store_true", help="also print every arrow inside renderer/")
    parser.add_argument("--root", type=Path, default=ROOT, help="the checkout to read (default: this one)")
    args = parser.parse_args(argv)
    arrows = import_arrows(args.root)
    inside = [a for a in arrows if a.source.startswith("renderer") and a.target.startswith("renderer")]
    pairs = {(a.source, a.target) for a in inside}
    if args.all:
        print(f"arrows inside renderer/ ({len(pairs)} module pairs):")
        for arrow in inside:
            print(f"  {arrow}")
    found = circles(arrows)
    print(f"import circles in {', '.join(PACKAGES)}: {len(found)}")
    for component in found:
        within = [a for a in arrows if a.source in component and a.target in component]
        print(f"  {' <-> '.join(component)}")
        for arrow in within:
            print(f"      {arrow}")
    upward = [a for a in inside if is_upward(a)]
    upward_pairs = {(a.source, a.target) for a in upward}
    print(f"upward arrows inside renderer/: {len(upward_pairs)} of {len(pairs)} module pairs")
    for arrow in upward:
        print(f"  {arrow}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
