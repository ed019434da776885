"""The compiled kernels' disk cache is keyed on every kernel source of ``sim``: a kernel that
inlines a function from another module is recompiled when that module changes."""

from __future__ import annotations

import sim  # noqa: F401  (registers the locator before the kernels are defined)
from sim import _kernel_cache, kernels, leapfrog


def test_the_kernels_cache_is_stamped_with_every_kernel_source_of_the_package():
    for kernel in (kernels.spring_force, leapfrog.leapfrog_steps):
        locator = kernel._cache._impl._locator
        assert type(locator).__name__ == "PackageCacheLocator"
        assert locator.get_source_stamp() == _kernel_cache.package_stamp()
    sources = [path for path, _, _ in _kernel_cache._kernel_sources()]
    assert any(path.endswith("matched_layer.py") for path in sources)
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
