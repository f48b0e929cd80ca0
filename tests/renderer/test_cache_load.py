"""Cached machine code loaded without Numba's compile-time set-up (renderer/cache_load.py): the
same results as Numba's own loading, the set-up really skipped, and a cache miss still compiles."""

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

from renderer import cache_load

ROOT = Path(__file__).resolve().parents[2]

needs_tested_numba = pytest.mark.skipif(
    not cache_load.supported(), reason=f"Numba {numba.__version__} is not one cache_load was tested with: it loads as Numba does"
)

# Counts the calls of the set-up itself (the target context's refresh, which loads Numba's typing
# and lowering registries); prepended to the scripts below.
COUNT_SET_UP = """
import numba.core.base as base
refreshes = []
refresh = base.BaseContext.refresh
def counted(self):
    refreshes.append(1)
    return refresh(self)
base.BaseContext.refresh = counted
def set_up():
    return "set-up" if refreshes else "no-set-up"
"""

# argv: "light" or "numba" (Numba's own loading), and where to save the film's sums. Prints
# whether the renderer's kernel came from the disk cache, and whether Numba's set-up ran.
RENDER = COUNT_SET_UP + """
import sys
import numpy as np
import renderer.cache_load as cache_load
if sys.argv[1] == "numba":
    cache_load.supported = lambda: False  # before the renderer's first import installs it
from renderer.variants import GENERAL, kernels_for
from scenefmt import models as m
from tests.renderer.scenes import cluster, render_scene
result = render_scene(cluster(m.Lambertian(albedo=(0.7, 0.6, 0.5))), width=12, height=10, samples=3, seed=5)
np.save(sys.argv[2], result.film.total)
hits = sum(kernels_for(GENERAL).render_pass.stats.cache_hits.values())
print("cache-hit" if hits else "compiled", set_up())
"""

# One small function of ours, in a cache folder of its own (NUMBA_CACHE_DIR).
KEY = COUNT_SET_UP + """
import sys
from renderer.kernels.rng import path_key
print(path_key(7, 1234, 5), "cache-hit" if sum(path_key.stats.cache_hits.values()) else "compiled", set_up())
"""

# A cached function that is not the renderer's, loaded after the renderer installed its loader.
OTHER = COUNT_SET_UP + """
import renderer.jit_cache
from other_module import twice
print(twice(21), "cache-hit" if sum(twice.stats.cache_hits.values()) else "compiled", set_up())
"""


def run(script, *args, env=None):
    out = subprocess.run([sys.executable, "-c", script, *args], cwd=ROOT, capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


@needs_tested_numba
def test_light_loading_skips_the_set_up_and_renders_the_same(tmp_path):
    run(RENDER, "light", str(tmp_path / "warm.npy"))  # compiles the kernel if the cache lacks it
    assert run(RENDER, "light", str(tmp_path / "light.npy")) == ["cache-hit", "no-set-up"]
    assert run(RENDER, "numba", str(tmp_path / "numba.npy")) == ["cache-hit", "set-up"]
    light, numba_own = np.load(tmp_path / "light.npy"), np.load(tmp_path / "numba.npy")
    assert light.mean() > 0.05  # a real image, not an empty film
    assert np.array_equal(light, numba_own)


@needs_tested_numba
def test_a_cache_miss_compiles_and_the_next_process_loads_it(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    key, *first = run(KEY, env=env)
    assert first == ["compiled", "set-up"]  # on a miss the compiler set Numba up in full, then compiled
    again, *second = run(KEY, env=env)
    assert second == ["cache-hit", "no-set-up"]
    assert again == key
    own, *_ = run(KEY.replace("import sys", "import sys, renderer.cache_load as c; c.supported = lambda: False"), env=env)
    assert own == key


def test_other_functions_load_through_numbas_own_method(tmp_path):
    (tmp_path / "other_module.py").write_text("import numba\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2 * x\n")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH", "")]))
    assert run(OTHER, env=env) == ["42", "compiled", "set-up"]
    assert run(OTHER, env=env) == ["42", "cache-hit", "set-up"]  # loaded, with Numba's set-up


def test_only_tested_numba_versions(monkeypatch):
    for version, expected in (("0.58.1", False), ("0.59.0", True), ("0.68.1", True), ("0.69.0", False), ("1.0.0", False),
                              ("0.70.0rc1", False), ("dev", False)):
        monkeypatch.setattr(numba, "__version__", version)
        assert cache_load.supported() is expected, version


def test_other_functions_load_as_numba_loads_them():
    class Cache:
        def __init__(self, module):
            self._py_func = type("F", (), {"__module__": module})

    assert cache_load._is_ours(Cache("renderer.kernels.integrator"))
    assert cache_load._is_ours(Cache("renderer._kernels_motion_sky.integrator"))  # a specialised copy
    assert not cache_load._is_ours(Cache("renderers_of_someone_else"))
    assert not cache_load._is_ours(Cache("__main__"))
