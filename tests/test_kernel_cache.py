"""The compiled kernels' disk cache is keyed on every kernel source of ``sim``: a kernel that
inlines a function from another module is recompiled when that module changes."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import sim  # noqa: F401  (registers the locator before the kernels are defined)
from sim.forces import springs as kernels
from sim.loops import leapfrog
from sim.runtime import kernel_cache as _kernel_cache


def test_the_kernels_cache_is_stamped_with_every_kernel_source_of_the_package():
    """Beside the sources, or in the directory NUMBA_CACHE_DIR names where a user set it."""
    expected = ("PackageUserCacheLocator" if os.environ.get("NUMBA_CACHE_DIR")
                else "PackageCacheLocator")
    for kernel in (kernels.spring_force, leapfrog.leapfrog_steps):
        locator = kernel._cache._impl._locator
        assert type(locator).__name__ == expected
        assert locator.get_source_stamp() == _kernel_cache.package_stamp()
    sources = [path for path, _, _ in _kernel_cache._kernel_sources()]
    assert any(path.endswith("absorbing_layer.py") for path in sources)
    assert any(path.endswith("leapfrog.py") for path in sources)
    assert not any(path.endswith("presets.py") for path in sources)  # data, no kernel


def test_the_stamp_changes_when_any_one_source_changes(tmp_path):
    first, second = tmp_path / "a.py", tmp_path / "b.py"
    first.write_text("@njit\ndef f(x):\n    return x\n")
    second.write_text("@njit\ndef g(x):\n    return 2 * x\n")

    def stamp():
        files = tuple((str(p), p.stat().st_mtime, p.stat().st_size) for p in (first, second))
        return _kernel_cache._stamp(files)

    before = stamp()
    assert stamp() == before
    second.write_text("@njit\ndef g(x):\n    return 3 * x\n")
    assert stamp() != before


def test_kernels_compiled_at_another_optimisation_level_are_cached_apart():
    """numba's cache key leaves out its optimisation level: a run at the default level must not
    load the kernels the default test suite compiles at level 1."""
    ask = ("from sim.forces import springs as kernels; from app.movie import raster\n"
           "for kernel in (kernels.spring_force, raster.upscale_nearest):\n"
           "    print(kernel._cache._impl._locator.get_cache_path())")
    paths = {}
    for level in ("3", "1"):
        environment = dict(os.environ, NUMBA_OPT=level)
        environment.pop("NUMBA_CACHE_DIR", None)
        paths[level] = [Path(line) for line in subprocess.run(
            [sys.executable, "-c", ask], env=environment, capture_output=True, text=True,
            check=True).stdout.split()]
    from app.movie import raster
    assert paths["3"] == [Path(kernels.__file__).parent / "__pycache__",
                          Path(raster.__file__).parent / "__pycache__"]
    assert paths["1"] == [path / "opt-1" for path in paths["3"]]


def test_with_numba_cache_dir_the_kernels_are_stamped_and_split_by_level_there(tmp_path):
    """Clusters, containers and read-only installs set NUMBA_CACHE_DIR: the cache goes there,
    stale kernels are still told by the package's stamp, and levels stay apart."""
    ask = ("import sim; from sim.loops import leapfrog; from sim.runtime import kernel_cache\n"
           "locator = leapfrog.leapfrog_steps._cache._impl._locator\n"
           "print(type(locator).__name__, locator.get_cache_path(),\n"
           "      locator.get_source_stamp() == kernel_cache.package_stamp())")
    answers = {}
    for level in ("3", "1"):
        environment = dict(os.environ, NUMBA_OPT=level, NUMBA_CACHE_DIR=str(tmp_path))
        answers[level] = subprocess.run([sys.executable, "-c", ask], env=environment,
                                        capture_output=True, text=True, check=True).stdout.split()
    name, path, stamped = answers["3"]
    assert name == "PackageUserCacheLocator" and stamped == "True"
    assert Path(path).is_relative_to(tmp_path)
    assert Path(answers["1"][1]) == Path(path) / "opt-1"


def test_an_index_naming_a_type_the_sources_lack_is_a_miss(tmp_path):
    """numba unpickles a kernel's whole cache index before it compares the sources' stamp; an
    index that names a type no longer defined is a miss (the kernel compiles), not an error."""
    from numba.core import caching

    index = caching.IndexDataCacheFile(str(tmp_path), "kernel-1.py311", "stamp")
    with open(index._index_path, "wb") as file:
        pickle.dump(index._version, file, protocol=-1)
        file.write(b"csim.integrators.butcher\nNoSuchRecord\n.")
    assert index._load_index() == {}
