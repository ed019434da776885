"""A setup as a link: the link of a changed preset opens that preset with the same parameters,
integrator and dt; a link that names anything else, or a value the page would refuse, is
refused with the reason; and in a real (headless) Chromium the link shown by one page, opened
in a second, runs that setup."""

from __future__ import annotations

import base64
from urllib.parse import parse_qs, unquote, urlsplit

import pytest

import sim
from app.web.share import SETUP_PATH, LinkRefused, setup_from_path, setup_query, share_link
from tests.helpers import open_page, wait_for


def _changed() -> sim.Simulation:
    scene = sim.scenes.build("grid", nx=14, stiffness=50.0, damping=0.3, linear=True,
                             gravity=2.5)
    return sim.Simulation(scene, integrator="rk4", dt=0.015)


def _path(query: str) -> str:
    """The connection path a link with this setup query makes."""
    return f"{SETUP_PATH}/" + base64.urlsafe_b64encode(query.encode()).decode().rstrip("=")


def test_a_link_opens_the_same_setup():
    simulation = _changed()
    query = setup_query(simulation)
    assert "stiffness=50" in query and "nx=14" in query and "ny=" not in query  # changes only
    built = setup_from_path(_path(query)).build()
    again = sim.Simulation(built)
    assert (again.integrator, again.dt) == ("rk4", 0.015)
    for name in ("nx", "ny", "stiffness", "damping", "linear", "rest_length"):
        assert getattr(again.model, name) == getattr(simulation.model, name), name
    assert tuple(again.model.gravity) == tuple(simulation.model.gravity)
    from app.web.view import ViewSettings

    view = ViewSettings(color_by="speed", show_springs=False, particle_scale=1.5)
    shown = ViewSettings()
    setup_from_path(_path(setup_query(simulation, view))).show(shown)
    assert (shown.color_by, shown.show_springs, shown.particle_scale) == ("speed", False, 1.5)
    link = share_link("http://192.168.1.20:8080", simulation)
    socket = unquote(parse_qs(urlsplit(link).query)["websocket"][0])
    assert socket == "ws://192.168.1.20:8080" + _path(query)
    with pytest.raises(LinkRefused):  # a setup this page did not make
        setup_from_path(f"{SETUP_PATH}/%%%not-base64")
    assert setup_from_path("/") is None and setup_from_path("/student") is None


@pytest.mark.parametrize("query, reason", [
    ("scene=../../etc/passwd", "not a preset"),
    ("scene=grid&file=x.toml", "not a parameter"),
    ("scene=grid&stiffness=nan", "finite"),
    ("scene=grid&stiffness=３", "ASCII|not one this page made"),
    ("scene=grid&stiffness=1&stiffness=2", "twice"),
    ("scene=grid&integrator=rm%20-rf", "not an integrator"),
    ("scene=grid&dt=100", "dt"),
    ("scene=grid&nx=2.5", "whole"),
    ("scene=grid&nx=2000&ny=2000", "particles"),
    ("scene=grid&stiffness=1e12", "stiffness"),
    ("scene=grid&view_colour=<script>", "view_colour"),
    ("scene=grid&view_size=10", "view_size"),
])
def test_a_link_the_page_would_refuse_is_refused(query, reason):
    with pytest.raises((LinkRefused, sim.ModelError, sim.SceneError), match=reason):
        setup_from_path(_path(query)).build()


def test_only_presets_are_shared():
    scene = sim.scenes.build("ionic")
    simulation = sim.Simulation(scene)
    with pytest.raises(LinkRefused, match="masses"):
        setup_query(simulation)


@pytest.mark.browser
@pytest.mark.slow  # 20 s: two pages, a compiled run
def test_a_shared_link_opened_in_a_second_page_runs_that_setup(web_app, browser):
    control = web_app.control
    control.set_stiffness(48.0).result(timeout=30)
    control.set_integrator("verlet").result(timeout=30)
    control.set_dt(0.0125).result(timeout=30)
    web_app.view.settings.color_by = "speed"  # as the View folder sets it
    first = browser.new_page(viewport={"width": 1366, "height": 768})
    open_page(first, web_app.url)
    first.get_by_text("Scene", exact=True).first.click()  # open the folder
    first.get_by_role("button", name="Share this setup").click()
    folder = web_app.panel.folders["scene"]
    assert wait_for(lambda: "websocket" in folder.share.link.content, timeout=20), \
        folder.message.content
    link = first.locator("a", has_text="websocket").first
    link.wait_for(timeout=20_000)
    url = link.get_attribute("href")
    control.set_stiffness(20.0).result(timeout=30)  # somebody changes the lattice meanwhile
    second = browser.new_page(viewport={"width": 1366, "height": 768})
    open_page(second, url)
    assert wait_for(lambda: web_app.runner.simulation.model.stiffness == 48.0, timeout=60), (
        web_app.runner.simulation.model.stiffness, web_app.scene_source, web_app.runner.simulation.scene.name)
    simulation = web_app.runner.simulation
    assert (simulation.scene.name, simulation.integrator, simulation.dt) == (
        "grid", "verlet", 0.0125)
    assert (simulation.model.nx, simulation.model.ny) == (11, 7)
    assert web_app.view.settings.color_by == "speed"  # the view came with the link
    assert web_app.panel.folders["view"].color_by.value == "speed"  # and the folder shows it
