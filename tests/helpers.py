"""Small helpers shared by the tests that run servers, threads and subprocesses."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def wait_for(condition: Callable[[], object], timeout: float = 30.0) -> bool:
    """Poll ``condition`` until it holds or ``timeout`` seconds pass; returns whether it held.

    Tests wait for a state instead of sleeping a fixed time, so a loaded machine only makes
    them slower, never wrong."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


CHROMIUM = "/usr/bin/chromium"
"""Debian's Chromium, which Playwright drives for the browser tests (never a downloaded one)."""
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--no-first-run",
]
VIEWPORT = {"width": 1400, "height": 900}
"""A laptop's page size (CSS pixels)."""


def folder_click_delays(page, clicks: int = 6, pause: float = 0.0,
                        timeout_ms: int = 30_000) -> list[float]:
    """Seconds from a click on the View folder's title until the page shows (or hides) its
    contents, for ``clicks`` clicks ``pause`` seconds apart (the folder opens and closes in
    the page alone)."""
    delays = []
    for k in range(clicks):
        time.sleep(pause)
        started = time.perf_counter()
        page.get_by_text("View", exact=True).click()
        page.get_by_label("Move points", exact=True).wait_for(
            state="visible" if k % 2 == 0 else "hidden", timeout=timeout_ms)
        delays.append(time.perf_counter() - started)
    return delays


RENDERER_NAME = """() => {
  const gl = document.createElement("canvas").getContext("webgl");
  const info = gl && gl.getExtension("WEBGL_debug_renderer_info");
  return info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
}"""


def draws_in_software(page) -> bool:
    """Whether the page's browser draws WebGL in software (WebGL's renderer name, asked in the
    page)."""
    from app.web.page_views import SOFTWARE_RENDERERS

    name = page.evaluate(RENDERER_NAME).lower()
    return any(word in name for word in SOFTWARE_RENDERERS)


def wait_for_reload(page, url: str, timeout_ms: int = 60_000) -> None:
    """After ``page.goto(url)``: a browser drawing in software (this machine's headless
    Chromium) reloads the app's page once at a lower resolution (``app.web.page_views``); wait
    until it has."""
    import re

    if "fixedDpr" not in url and draws_in_software(page):
        page.wait_for_url(re.compile(r"[?&]fixedDpr="), timeout=timeout_ms)


def open_page(page, url: str, timeout_ms: int = 60_000) -> None:
    """Open the app at ``url`` as a reader would and wait until the page is connected (after
    the reload of a page drawing in software, ``wait_for_reload``)."""
    page.goto(url)
    wait_for_reload(page, url, timeout_ms)
    page.get_by_text("Connected").wait_for(timeout=timeout_ms)

