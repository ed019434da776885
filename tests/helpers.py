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


CLICK_CLOCKS = """
window.__clicked = null; window.__answered = null; window.__seen = false;
window.__eventTimes = [];
document.addEventListener("click", (event) => {
  const button = event.target.closest("button");
  if (button && button.textContent.trim() === "Pause") {
    window.__clicked = event.timeStamp; window.__answered = null;
  }
}, true);
new MutationObserver(() => {
  if (window.__clicked === null || window.__answered !== null || window.__seen) return;
  for (const button of document.querySelectorAll("button"))
    if (button.textContent.trim() === "Play") {
      window.__seen = true;  // painted by the next frame, whose commit ends rAF's task
      requestAnimationFrame(() => setTimeout(() => {
        window.__answered = performance.now(); window.__seen = false;
      }, 0));
      return;
    }
}).observe(document, {subtree: true, childList: true, characterData: true});
new PerformanceObserver((list) => {
  for (const entry of list.getEntries())
    if (entry.name === "click") window.__eventTimes.push([entry.startTime, entry.duration]);
}).observe({type: "event", durationThreshold: 16, buffered: true});
"""
"""Page-side clocks of clicks (``page.add_init_script``): for a click on *Pause*, the click's
input time and when the frame that shows the server's answer (a button reading *Play*) was
handed to the compositor; for every click, the browser's own Event Timing: from the input to
the next frame painted after the page handled it (what Chrome reports as a click's
"interaction to next paint"; only clicks that took 16 ms or more are listed)."""
FASTEST_LISTED = 0.016
"""Event Timing lists only clicks answered in this many seconds or more."""


def folder_click_delays(page, clicks: int = 6, pause: float = 0.0,
                        timeout_ms: int = 30_000) -> tuple[list[float], list[float]]:
    """(answers, walls) for ``clicks`` clicks on the View folder's title ``pause`` seconds
    apart (the folder opens and closes in the page alone): seconds from the input to the next
    frame the page painted after handling it (Event Timing; needs ``CLICK_CLOCKS``), and
    seconds from Playwright's click until Playwright sees the contents shown or hidden (which
    adds Playwright's own checks: two animation frames before it clicks, then polling)."""
    answers, walls = [], []
    for k in range(clicks):
        time.sleep(pause)
        since = page.evaluate("performance.now()")
        started = time.perf_counter()
        page.get_by_text("View", exact=True).click()
        page.get_by_label("Move points", exact=True).wait_for(
            state="visible" if k % 2 == 0 else "hidden", timeout=timeout_ms)
        walls.append(time.perf_counter() - started)
        listed = page.evaluate(
            f"window.__eventTimes.filter(e => e[0] >= {since}).map(e => e[1])")
        answers.append(max(listed) / 1e3 if listed else FASTEST_LISTED)
    return answers, walls


def pause_click_delays(page, play: Callable[[], object], clicks: int = 5,
                       pause: float = 0.0) -> tuple[list[float], list[float]]:
    """(answers, walls): for ``clicks`` clicks on *Pause* while the run plays, seconds from the
    page's dispatch of the click until the frame showing the server's answer (the button reads
    *Play* again: the round trip through the server; needs ``CLICK_CLOCKS``) is drawn, and from
    Playwright's click until it sees the answer.  ``play()`` plays the run again between
    clicks."""
    answers, walls = [], []
    for _ in range(clicks):
        time.sleep(pause)
        started = time.perf_counter()
        page.get_by_role("button", name="Pause").click()
        page.get_by_role("button", name="Play").wait_for(state="visible", timeout=60_000)
        walls.append(time.perf_counter() - started)
        page.wait_for_function("window.__answered !== null", timeout=60_000)
        clock = page.evaluate("[window.__clicked, window.__answered]")
        answers.append((clock[1] - clock[0]) / 1e3)
        play()
        page.get_by_role("button", name="Pause").wait_for(state="visible", timeout=60_000)
        time.sleep(1.5)  # pictures flow again
    return answers, walls


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

    from playwright.sync_api import Error

    if "fixedDpr" in url:
        return
    try:
        software = draws_in_software(page)
    except Error:  # the page navigated while it was asked: that reload is under way
        software = True
    if software:
        page.wait_for_url(re.compile(r"[?&]fixedDpr="), timeout=timeout_ms)


def open_page(page, url: str, timeout_ms: int = 60_000) -> None:
    """Open the app at ``url`` as a reader would and wait until the page is connected (after
    the reload of a page drawing in software, ``wait_for_reload``)."""
    page.goto(url)
    wait_for_reload(page, url, timeout_ms)
    page.get_by_text("Connected").wait_for(timeout=timeout_ms)

