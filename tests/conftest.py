"""Fixtures shared by the test modules: a running web app on a small grid, and a real headless
Chromium (Debian's, driven by Playwright) for the browser tests."""

from __future__ import annotations

import os

import pytest

# One 1/sqrt variant for the whole run: the per-host measurement (``sim.loops.host_tuning``) compiles
# both variants of two loops on a fresh machine; tests/test_host_tuning.py checks that the
# variants agree and that the measurement answers.
os.environ.setdefault("OSCILLATORS_INVERSE_SQRT", "divide")
# Runs may ask for at most numba's threads (``sim.integrators.registry.max_threads``); the tests
# split lattices into up to 4 row blocks on threads whatever the machine's cores.
os.environ.setdefault("NUMBA_NUM_THREADS", str(max(4, os.cpu_count() or 1)))
# The servers the tests start warm no other presets' kernels in the background (app.cli.warm).
os.environ.setdefault("OSCILLATORS_NO_WARM", "1")

import sim
from app.web.app import WebApp
from tests.helpers import CHROMIUM, CHROMIUM_ARGS, free_port, wait_for


@pytest.fixture
def web_app(tmp_path):
    """An 11x7 grid served on a free localhost port, its scene and recording folders in
    ``tmp_path``, the first frame drawn; stopped afterwards.  Modules that need another app
    define their own ``web_app``."""
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings")
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None)
    yield app
    app.stop()


@pytest.fixture
def browser():
    """Debian's Chromium, headless, launched by Playwright; closed afterwards.  Its absence is a
    failure, not a skip: the README's test command installs it (``scripts/ensure-chromium.sh``)."""
    if not os.path.exists(CHROMIUM):
        pytest.fail(f"the browser tests need Debian's Chromium at {CHROMIUM} "
                    "(apt install chromium, or run `make test`)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield chromium
        finally:  # the pages' contexts first: Chromium closed with a download under way may
            for context in chromium.contexts:  # never answer (Playwright's issue 22185)
                context.close()
            chromium.close()
