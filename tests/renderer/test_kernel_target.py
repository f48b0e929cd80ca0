"""The kernel target seam (renderer/target.py): every compiled function of the package is declared
through it, and Numba's private option and hand-written LLVM are each confined to one module; the
four-wide box test, in its vector and its plain form, answers bit for bit as the one-box test; the
flags are declared once; specialised kernels, launched through a KernelSet, render what the
general kernel renders."""

from __future__ import annotations

import ast
import math
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("renderer", "rt", "scenefmt")

# The CPU's four-wide box test, written as LLVM vector code (see its docstring for why).
VECTOR_CODE = "renderer/numerics/simd.py"
# Modules that may import numba: the target itself, and the cache's naming (Numba's version, the
# processor it compiles for).
IMPORTS_NUMBA = {"renderer/target.py", "renderer/jit_cache.py", VECTOR_CODE}


def sources():
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            yield path.relative_to(ROOT).as_posix(), path.read_text()


def numba_declarations(tree: ast.AST) -> list[str]:
    """`njit`/`jit` decorators, called or not, plain or as numba.<name>, with their line."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for decorator in node.decorator_list:
                target = decorator.func if isinstance(decorator, ast.Call) else decorator
                name = target.id if isinstance(target, ast.Name) else target.attr if isinstance(target, ast.Attribute) else ""
                if name in ("njit", "jit", "generated_jit", "intrinsic", "vectorize", "guvectorize", "stencil"):
                    found.append(f"{node.name} (line {node.lineno})")
    return found


def imports_numba(tree: ast.AST) -> bool:
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(a.name.split(".")[0] in ("numba", "llvmlite") for a in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] in ("numba", "llvmlite"):
            return True
    return False


def test_every_compiled_function_is_declared_through_the_target_module():
    stray = {}
    for name, text in sources():
        if name == "renderer/target.py":
            continue
        found = numba_declarations(ast.parse(text))
        if name == VECTOR_CODE:
            found = [f for f in found if not f.startswith("slab4 ")]  # the vector form, an intrinsic
        if found:
            stray[name] = found
    assert stray == {}, f"compiled functions declared outside renderer/target.py: {stray}"


def test_only_the_target_and_the_cache_import_numba():
    """Inside the renderer, and in rt: thread counts, too, go through the target."""
    others = sorted(name for name, text in sources()
                    if name.split("/")[0] in ("renderer", "rt") and name not in IMPORTS_NUMBA and imports_numba(ast.parse(text)))
    assert others == [], f"modules importing numba or llvmlite directly: {others}"


def test_numbas_private_option_and_llvm_code_each_have_one_module():
    private, llvm = set(), set()
    for name, text in sources():
        tree = ast.parse(text)
        keywords = {k.arg for node in ast.walk(tree) if isinstance(node, ast.Call) for k in node.keywords if k.arg}
        if any(k.startswith("_") for k in keywords) or "_nrt" in text:
            private.add(name)
        if "llvmlite import ir" in text or "llvmlite.ir" in text or "numba.extending" in text:
            llvm.add(name)
    assert private == {"renderer/target.py"}
    assert llvm == {VECTOR_CODE}


def test_the_flags_are_declared_once():
    from renderer import kernel_flags
    from renderer.variants import KernelFeatures
    from scenefmt.effect_flags import EFFECT_FLAGS, EFFECT_KEYS, flags_tag
    from scenefmt.effects import EFFECTS

    assert [f.name for f in fields(KernelFeatures)] == list(EFFECT_KEYS)
    assert kernel_flags.NAMES == tuple(key.upper() for key in EFFECT_KEYS)
    assert all(getattr(kernel_flags, name) is True for name in kernel_flags.NAMES) and kernel_flags.TAG == "all"
    assert [key for key, _ in EFFECTS] == list(EFFECT_KEYS)
    assert [name for _, name in EFFECTS] == [flag.name for flag in EFFECT_FLAGS]
    assert KernelFeatures().tag == "all" and KernelFeatures(**dict.fromkeys(EFFECT_KEYS, False)).tag == "none"
    assert KernelFeatures(**{**dict.fromkeys(EFFECT_KEYS, False), "sky": True, "media": True}).tag == "media+sky"
    assert flags_tag(["sky", "media"]) == "media+sky"
    values = kernel_flags.values(["sky"])
    assert values["SKY"] is True and values["MEDIA"] is False and values["TAG"] == "sky"
    # The table is pure Python: `rt validate` reads it without numpy or Numba.
    table = ast.parse((ROOT / "scenefmt" / "effect_flags.py").read_text())
    imported = {a.name for n in ast.walk(table) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module for n in ast.walk(table) if isinstance(n, ast.ImportFrom)}
    assert imported <= {"__future__", "dataclasses"}


def test_declaring_sets_numbas_cache_folder_only_for_the_moment():
    import numba

    from renderer import jit_cache, target

    before = numba.config.CACHE_DIR
    with target.declaring():
        inside = numba.config.CACHE_DIR
    assert numba.config.CACHE_DIR == before
    if target.CACHE_FOLDER is not None:
        assert inside == target.CACHE_FOLDER == jit_cache.folder_for("all")
    assert jit_cache.folder_for("media+sky").endswith(str(Path("variants") / "media+sky"))


# --- the four-wide box test, against the one-box test ------------------------------------------

def _edge_case_boxes(rng, n_nodes):
    """Wide-node box rows (lo x of children 0..3, lo y, lo z, hi x, hi y, hi z), with empty
    (NaN) slots, infinite and flat boxes, signed zeros, and boxes the rays start on."""
    lo = rng.uniform(-4.0, 4.0, (n_nodes, 4, 3))
    hi = lo + rng.uniform(0.0, 3.0, (n_nodes, 4, 3))
    pick = rng.random((n_nodes, 4))
    lo[pick < 0.1] = np.nan
    hi[pick < 0.1] = np.nan  # an empty slot
    flat = (pick >= 0.1) & (pick < 0.2)
    hi[flat, 0] = lo[flat, 0]
    lo[(pick >= 0.2) & (pick < 0.25), 1] = -np.inf
    hi[(pick >= 0.25) & (pick < 0.3), 2] = np.inf
    zero = (pick >= 0.3) & (pick < 0.4)
    lo[zero, 0] = -0.0
    hi[zero, 1] = 0.0
    lo[(pick >= 0.4) & (pick < 0.45)] = 0.0  # a corner at the origin some rays start from
    rows = np.empty((n_nodes, 24))
    for axis in range(3):
        rows[:, 4 * axis:4 * axis + 4] = lo[:, :, axis]
        rows[:, 12 + 4 * axis:12 + 4 * axis + 4] = hi[:, :, axis]
    return rows


def _edge_case_rays(rng, n):
    o = rng.uniform(-6.0, 6.0, (n, 3))
    d = rng.normal(size=(n, 3))
    d[: n // 8, 0] = 0.0
    d[n // 8: n // 4, 1] = -0.0
    o[n // 4: n // 3] = 0.0
    o[n // 3: n // 2, 2] = -0.0
    # On a box's plane and parallel to it: with a raw inverse, 0 * inf is NaN on that axis.
    o[n // 2: 5 * n // 8, 1] = d[n // 2: 5 * n // 8, 1] = 0.0
    o[5 * n // 8: 3 * n // 4, 2] = 0.0
    d[5 * n // 8: 3 * n // 4, 2] = -0.0
    tmin = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.0, 3.0, n))
    tmax = np.where(rng.random(n) < 0.3, math.inf, rng.uniform(0.0, 9.0, n))
    tmax[: n // 10] = tmin[: n // 10]  # an empty interval
    return o, d, tmin, tmax


@pytest.mark.slow
def test_the_four_wide_box_test_equals_the_one_box_test_bit_for_bit():
    """The vector form (slab4), the plain lanes (slab4_lanes) and the one-box test (traverse.slab)."""
    from renderer import target
    from renderer.numerics.simd import slab4, slab4_lanes
    from renderer.tracing.traverse import inverse_direction, slab

    @target.kernel
    def three_ways(rows, origins, dirs, tmin, tmax, use_inverse):
        n_rays, n_nodes = origins.shape[0], rows.shape[0]
        out = np.empty((3, n_rays, n_nodes, 4))
        boxes = np.empty((4, 6))
        for r in range(n_rays):
            o = (origins[r, 0], origins[r, 1], origins[r, 2])
            d = (dirs[r, 0], dirs[r, 1], dirs[r, 2])
            # Through inverse_direction (as traversal does: 0 becomes a signed 1e300), or raw
            # (infinities and NaN in the inverse itself).
            inv = inverse_direction(d) if use_inverse else (1.0 / d[0], 1.0 / d[1], 1.0 / d[2])
            for k in range(n_nodes):
                t0, t1, t2, t3 = slab4(rows, k, o, inv, tmin[r], tmax[r])
                out[0, r, k, 0], out[0, r, k, 1], out[0, r, k, 2], out[0, r, k, 3] = t0, t1, t2, t3
                t0, t1, t2, t3 = slab4_lanes(rows, k, o, inv, tmin[r], tmax[r])
                out[1, r, k, 0], out[1, r, k, 1], out[1, r, k, 2], out[1, r, k, 3] = t0, t1, t2, t3
                for c in range(4):
                    for q in range(6):
                        boxes[c, q] = rows[k, 4 * q + c]
                for c in range(4):
                    out[2, r, k, c] = slab(boxes, c, o, inv, tmin[r], tmax[r])
        return out

    rng = np.random.default_rng(30)
    rows = _edge_case_boxes(rng, 200)
    o, d, tmin, tmax = _edge_case_rays(rng, 400)
    for use_inverse in (True, False):
        vector, lanes, one = three_ways(rows, o, d, tmin, tmax, use_inverse)
        assert np.array_equal(vector.view(np.int64), one.view(np.int64))
        assert np.array_equal(lanes.view(np.int64), one.view(np.int64))
        met = np.isfinite(one)
        # The cases are there: boxes met and missed, at an entry of exactly tmin and beyond it.
        assert met.sum() > 1000 and (~met).sum() > 1000
        assert (one == tmin[:, None, None]).any() and (one > tmin[:, None, None]).any()


# --- launching kernels ------------------------------------------------------------------------

SCENE = """
camera: {look_from: [0, 1, 6], look_at: [0, 0.5, 0], vfov: 40}
image: {width: 12, height: 8, samples_per_pixel: 2, max_depth: 6}
background: {type: solid, color: [0.7, 0.8, 1.0]}
materials:
  white: {type: lambertian, albedo: [0.7, 0.7, 0.7]}
shapes:
  - {type: sphere, center: [0, -100, 0], radius: 100, material: white}
  - {type: sphere, center: [0, 0.5, 0], radius: 0.5, material: white}
"""


def _flat():
    from renderer.compile import compile_scene
    from renderer.variants import features_of
    from scenefmt.validation import loads

    graph = loads(SCENE).graph
    return compile_scene(graph), features_of(graph)


def _film_of_pass(kernels, flat, band=(0, 8)):
    from renderer.film import Film
    from renderer.sampling import uniform_sampling

    film = Film.empty(12, 8)
    rays, bad = np.zeros(8, np.int64), np.zeros(8, np.int64)
    kernels.render_pass(flat, 12, 8, 3, 0, 4, 6, 1, uniform_sampling(), film.sums, rays, bad, *band)
    return film.total, film.total_sq, rays, film


@pytest.mark.slow
def test_per_thread_scratch_gives_the_same_film_on_any_number_of_threads():
    from renderer import target
    from renderer.variants import GENERAL, kernel_set

    flat, _ = _flat()
    before = target.thread_count()
    films = []
    try:
        for threads in sorted({1, before}):
            target.set_thread_count(threads)
            films.append(_film_of_pass(kernel_set(GENERAL), flat))
    finally:
        target.set_thread_count(before)
    assert films[0][0].sum() > 0
    for total, total_sq, rays, _ in films[1:]:
        assert np.array_equal(total, films[0][0]) and np.array_equal(total_sq, films[0][1])
        assert np.array_equal(rays, films[0][2])


@pytest.mark.slow
def test_a_specialised_kernel_set_renders_the_general_kernels_film_and_its_tiles_too():
    """Pass and tile, general and specialised: one film, bit for bit; and loading the specialised
    kernel leaves Numba's process-wide cache folder as it was."""
    import numba

    from renderer.variants import GENERAL, kernel_set

    flat, needed = _flat()
    assert not needed.is_general and needed.tag == "none"
    general = _film_of_pass(kernel_set(GENERAL), flat)
    folder = numba.config.CACHE_DIR
    special = _film_of_pass(kernel_set(needed), flat)
    assert numba.config.CACHE_DIR == folder
    assert general[0].sum() > 0
    assert np.array_equal(general[0], special[0]) and np.array_equal(general[1], special[1])
    # The same samples as two tiles of the cluster's kernel: every array of the film, bit for bit.
    from renderer.film import Film
    from renderer.sampling import uniform_sampling

    film = Film.empty(12, 8)
    for x0, width in ((0, 5), (5, 7)):
        tile = Film.empty(width, 8)
        kernel_set(needed).render_tile(flat, 12, x0, 0, 3, 0, 4, 6, 1, uniform_sampling(), tile.sums, np.zeros(8, np.int64),
                                       np.zeros(8, np.int64))
        for whole, part in zip(film.sums, tile.sums):
            whole[:, x0:x0 + width] = part
    for whole, passed in zip(film.sums, general[3].sums):
        assert np.array_equal(whole, passed)
