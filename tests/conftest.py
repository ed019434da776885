"""Fixtures shared by the test modules: a running web app on a small grid."""

from __future__ import annotations

import pytest

import sim
from app.web.app import WebApp
from tests.helpers import free_port, wait_for


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
