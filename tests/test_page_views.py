"""A page's view size in CSS pixels and its drawing in software (``app.web.page_views``): what a
page reports is checked before it is used, and the script sent to each page writes under the key
the server asks for."""

from __future__ import annotations

import json

import pytest

from app.web import page_views, viser_adapter


@pytest.mark.parametrize("value, size", [
    ("[1366, 768]", (1366, 768)),
    ("[414.0, 896]", (414, 896)),
    (None, None), ("", None), ("not json", None), ("{}", None), ("[1366]", None),
    ("[1366, 768, 1]", None), ("[true, 768]", None), ('["1366", 768]', None),
    ("[NaN, 768]", None), ("[Infinity, 768]", None), ("[1e9, 768]", None), ("[0, 768]", None),
    ("[-1366, 768]", None), ("[" + "1" * 200 + ", 768]", None),
])
def test_only_two_sizes_within_bounds_are_taken(value, size):
    assert page_views.parse_size(value) == size


def test_the_script_writes_where_the_server_asks_and_knows_the_software_renderers():
    source = page_views.script(7, ratio=0.5)
    key = viser_adapter.LOCAL_STORAGE_PREFIX + page_views.KEY_PREFIX + "7"
    assert f"const key = {json.dumps(key)};" in source and "localStorage.setItem(key," in source
    assert "Math.round(100 * 0.5 * (window.devicePixelRatio || 1))" in source
    for renderer in ("ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero)), "
                     "SwiftShader driver)", "llvmpipe (LLVM 15.0.6, 256 bits)",
                     "Microsoft Basic Render Driver"):
        assert any(word in renderer.lower() for word in page_views.SOFTWARE_RENDERERS)
    for renderer in ("ANGLE (Intel, Mesa Intel(R) UHD Graphics 620 (KBL GT2))",
                     "Apple M2", "NVIDIA GeForce RTX 3060/PCIe/SSE2"):
        assert not any(word in renderer.lower() for word in page_views.SOFTWARE_RENDERERS)
    assert "fixedDpr" in source and "location.replace" in source
