"""numba's on-disk cache of the compiled kernels, keyed on every kernel source of ``sim`` at once.

numba keys a cached function on its own source file alone, but a compiled kernel carries inside it
the machine code of the functions it calls from other modules (LLVM inlines them): the matched
layer's pass is inside Verlet's loops, the spring law inside every sweep.  After an edit to
``sim/forces/springs.py`` alone, ``sim/loops/row_sweep.py``'s cached loops would still run the old spring law.
This locator stamps each cached kernel of ``sim`` with a hash of all of the package's modules that
define kernels, so an edit to any of them recompiles every kernel (on a fresh clone nothing is
cached and nothing changes).  Kernels compiled at another optimisation level than numba's default,
the package's and any other module's, are kept in a subfolder of their own
(``optimisation_folder``).

It is registered before any kernel is defined (``sim/__init__.py`` imports this module first).
Where ``NUMBA_CACHE_DIR`` is set the cache is in the directory it names (numba's own layout there),
stamped and split by level the same way.  An index of cached versions that cannot
be read (it names a type the sources no longer define) counts as a miss, not an error.  If
numba's cache internals differ from what this expects, numba's default locators stay in place.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import pickle
import sys
import time
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent
"""The ``sim`` package: its rooms' modules that define kernels are stamped together."""


@functools.lru_cache(maxsize=1)
def _kernel_files() -> tuple[Path, ...]:
    """The package's modules that define numba kernels (read once per process)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        try:
            if "njit" in path.read_text(encoding="utf-8"):
                found.append(path)
        except OSError:
            continue
    return tuple(found)


def _kernel_sources() -> tuple[tuple[str, float, int], ...]:
    """(path, mtime, size) of every module of the package that defines numba kernels."""
    found = []
    for path in _kernel_files():
        try:
            stat = path.stat()
        except OSError:
            continue
        found.append((str(path), stat.st_mtime, stat.st_size))
    return tuple(found)


@functools.lru_cache(maxsize=8)
def _stamp(sources: tuple[tuple[str, float, int], ...]) -> str:
    digest = hashlib.sha256()
    for path, _, _ in sources:
        digest.update(path.encode())
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()


_SOURCES_CHECKED: list = [-math.inf, ()]
"""When the kernel sources were last looked at (``time.monotonic``) and what was seen."""


def package_stamp() -> str:
    """A hash of the package's kernel sources (recomputed when one changes on disk; looked at
    once a second at most: importing ``sim`` asks for it once per kernel)."""
    now = time.monotonic()
    if now - _SOURCES_CHECKED[0] > 1.0:
        _SOURCES_CHECKED[:] = [now, _kernel_sources()]
    return _stamp(_SOURCES_CHECKED[1])


def optimisation_folder() -> str:
    """The cache's subfolder for numba's optimisation level (``NUMBA_OPT``), "" at the default
    (3): numba's cache key leaves the level out, so kernels compiled at another level (the
    default test suite's, ``Makefile``) must not be found by a run at the default one."""
    from numba.core import config

    level = str(getattr(config.OPT, "_raw_value", config.OPT))  # an int, or "max"
    return "" if level == "3" else f"opt-{level}"


def follow_level() -> int:
    """Point the caches of the kernels made so far (the ``@njit(cache=True)`` functions of the
    modules of ``sim`` and ``app`` imported so far) at the folder of the optimisation level now in
    effect; returns how many.  numba fixes a kernel's cache folder when the kernel is made (at
    import), so without this a process that changes its level after ``import sim``
    (``sim.runtime.optimisation.use_numba_default``) would look for its kernels in the folder of
    the level before, miss the kernels a child process compiled, and compile them itself."""
    try:
        from numba.core.caching import FunctionCache
        from numba.core.dispatcher import Dispatcher
    except ImportError:  # pragma: no cover - numba's internals moved (tests/test_kernel_cache.py)
        return 0
    count = 0
    for name, module in list(sys.modules.items()):
        if module is None or not (name in ("sim", "app") or name.startswith(("sim.", "app."))):
            continue
        for value in list(vars(module).values()):
            if isinstance(value, Dispatcher) and isinstance(getattr(value, "_cache", None),
                                                            FunctionCache):
                value.enable_caching()
                count += 1
    return count


@functools.lru_cache(maxsize=256)
def _inside_package(py_file: str) -> bool:
    try:
        return PACKAGE in Path(py_file).resolve().parents
    except (OSError, ValueError):
        return False


def _locators(base: type, user_directory: bool) -> tuple[type, type]:
    """(the package's stamped locator, the level locator) over numba's ``base``: its in-tree
    cache (``user_directory`` False: answers when ``NUMBA_CACHE_DIR`` is unset) or the
    directory ``NUMBA_CACHE_DIR`` names (True: answers when it is set)."""

    def wanted() -> bool:
        return bool(os.environ.get("NUMBA_CACHE_DIR")) == user_directory

    class LevelCacheLocator(base):  # type: ignore[misc, valid-type]
        """numba's cache, in the subfolder of a non-default optimisation level; for kernels
        outside ``sim`` (e.g. ``app.movie.raster``) only at such a level, numba's own locators
        answering at the default one."""

        def get_cache_path(self):  # noqa: D102 - numba's interface
            return os.path.join(super().get_cache_path(), optimisation_folder())

        @classmethod
        def from_function(cls, py_func, py_file):  # noqa: D102 - numba's interface
            if not optimisation_folder() or not wanted():
                return None
            return super().from_function(py_func, py_file)

    class PackageCacheLocator(LevelCacheLocator):
        """The cache of the kernels of ``sim``, at every level, stamped with every kernel source
        of the package."""

        def get_source_stamp(self):  # noqa: D102 - numba's interface
            return package_stamp()

        @classmethod
        def from_function(cls, py_func, py_file):  # noqa: D102 - numba's interface
            if not _inside_package(py_file) or not wanted():
                return None
            return super(LevelCacheLocator, cls).from_function(py_func, py_file)  # numba's

    if user_directory:
        LevelCacheLocator.__name__ = LevelCacheLocator.__qualname__ = "LevelUserCacheLocator"
        PackageCacheLocator.__name__ = PackageCacheLocator.__qualname__ = \
            "PackageUserCacheLocator"
    return PackageCacheLocator, LevelCacheLocator


def _register() -> None:
    try:
        from numba.core import caching
    except ImportError:  # pragma: no cover - numba is a dependency
        return
    in_tree = getattr(caching, "InTreeCacheLocator", None)
    user = getattr(caching, "UserProvidedCacheLocator", None)
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if in_tree is None or user is None or impl is None or not isinstance(
            getattr(impl, "_locator_classes", None), list):
        return
    # NUMBA_CACHE_DIR set (clusters, containers, read-only installs): the same stamp and levels
    # in the directory it names; unset: beside the sources
    ours = (*_locators(user, True), *_locators(in_tree, False))
    for position, locator in enumerate(ours):
        if not any(cls.__name__ == locator.__name__ for cls in impl._locator_classes):
            impl._locator_classes.insert(position, locator)

    index_file = getattr(caching, "IndexDataCacheFile", None)
    load = getattr(index_file, "_load_index", None)
    if load is not None and not getattr(load, "unreadable_is_a_miss", False):

        def _load_index(self):
            """numba's index of a kernel's cached versions, empty (a miss) when it cannot be
            read: an index written from other sources may name a type that these lack."""
            try:
                return load(self)
            except (AttributeError, ImportError, EOFError, pickle.UnpicklingError):
                return {}

        _load_index.unreadable_is_a_miss = True  # type: ignore[attr-defined]
        index_file._load_index = _load_index


_register()
