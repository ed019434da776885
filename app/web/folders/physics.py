"""The page's "Physics" folder: stiffness, rest length, damping, gravity, linearity, masses, and
a slider for every force term's parameter that its registration gives a page range
(``Parameter.page``: the diagonal springs, drag, the FPU law's alpha and beta).

Each slider's value from the page is checked against the server's own limits (``Limits``), which
widen when a loaded scene's value lies outside them, so that every value shown can be sent back.
Changes go to the running simulation as commands; a refused one is explained in the folder.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import viser

import sim
from app.web.control import MASS_PATTERNS
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, amber_html, choice, from_user
from app.web.widgets import Limits, say
from sim.forces import registry
from sim.model import parameters
from sim.theory.hanging import hanging_problem

MAX_STIFFNESS = 100.0
"""The stiffness slider's maximum (N/m); the paper's default 35 N/m is 35 % of it."""
AS_LOADED = "as loaded"
"""Mass-pattern entry shown for masses that are neither uniform nor the ionic checkerboard."""
LIGHT_MASS = 1.0
"""The light mass (kg) of the ionic checkerboard, and every mass of the uniform pattern."""


def mass_pattern_of(model: sim.Model) -> str:
    """The page's mass pattern for a model: uniform, ionic (the checkerboard), or as loaded."""
    if model.uniform_mass:
        return "uniform"
    masses = np.asarray(model.masses).reshape(model.ny, model.nx)
    rows, columns = np.indices(masses.shape)
    even = masses[(rows + columns) % 2 == 0]
    odd = masses[(rows + columns) % 2 == 1]
    if even.size and odd.size and np.all(even == even.flat[0]) and np.all(odd == LIGHT_MASS):
        return "ionic"
    return AS_LOADED


TERM_ROWS = tuple(row for row in registry.parameters() if row.page is not None)
"""The force terms' parameters shown as sliders of their own (``Parameter.page``)."""


class PhysicsFolder(Folder):
    name = "physics"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        control = host.control
        gui = host.server.gui
        with gui.add_folder("Physics"):
            self.stiffness = gui.add_slider(
                parameters.get("stiffness").caption(), 1.0, MAX_STIFFNESS, 1.0, 35.0,
                hint="35 N/m is the paper's 35 % of maximum",
            )
            self.rest_ratio = gui.add_slider(
                "Rest length L/a", 0.5, 1.2, 0.01, 1.0,
                hint="below 1 the springs are pre-tensioned (transverse waves spread)",
            )
            self.damping_on = gui.add_checkbox("Damping", False)
            self.damping = gui.add_slider(parameters.get("damping").caption(), 0.0, 10.0, 0.1, 0.5)
            self.gravity_on = gui.add_checkbox("Gravity", False)
            self.gravity = gui.add_slider(parameters.get("gravity").caption(), 0.0, 30.0, 0.01, 9.81)
            self.linear = gui.add_checkbox("Linearised springs", False,
                                           hint="springs linearised about the rest lattice")
            self.mass_pattern = gui.add_dropdown(
                "Mass pattern", [*MASS_PATTERNS, AS_LOADED], initial_value="uniform",
                hint="uniform: 1 kg everywhere; ionic: heavy/light checkerboard; "
                "as loaded: the scene's own masses (shown, not chosen)",
            )
            self.heavy_mass = gui.add_slider("Heavy mass (kg)", 0.1, 20.0, 0.1, 4.0)
            self.term_sliders = {  # the other force terms' parameters, from their registration
                row.name: gui.add_slider(row.caption(), *row.page, float(row.default),
                                         hint=row.help)
                for row in TERM_ROWS}
            self.message = gui.add_html("")
            self.hanging = gui.add_html("", visible=False)
            """Amber: why the lattice cannot hang under this gravity (``sim.theory.hanging``)."""
        # The server's own limits; show_scene widens them to show a scene's larger values.
        self.limits = Limits(
            {"stiffness": (1.0, MAX_STIFFNESS),
             "rest_ratio": (0.5, 1.2), "damping": (0.0, 10.0),
             "gravity": (0.0, 30.0), "heavy_mass": (0.1, 20.0),
             **{row.name: row.page[:2] for row in TERM_ROWS}},
            low_open=("stiffness", "heavy_mass"),
            sliders={"stiffness": self.stiffness,
                     "rest_ratio": self.rest_ratio,
                     "damping": self.damping, "gravity": self.gravity,
                     "heavy_mass": self.heavy_mass, **self.term_sliders},
        )
        check = self.limits.check

        def refused(error: BaseException) -> None:
            """Every page shows the values in use again, and why the change was refused."""
            self.show_scene(host.runner.simulation)
            say(self.message, error)

        def report(future: Any) -> None:
            error = future.exception()
            if error is None:
                say(self.message, None)
                self.show_hanging(host.runner.simulation.model)
            else:
                refused(error)

        def physics_callback(post: Callable[[], Any]) -> Callable[[viser.GuiEvent], Any]:
            @from_user
            async def callback(_: viser.GuiEvent) -> None:
                try:
                    future = post()
                except InputRefused as error:
                    refused(error)
                    return
                future.add_done_callback(report)

            return callback

        self.stiffness.on_update(physics_callback(lambda: control.set_stiffness(
            check("stiffness", self.stiffness, "stiffness (N/m)"))))
        self.rest_ratio.on_update(physics_callback(lambda: control.set_rest_length_ratio(
            check("rest_ratio", self.rest_ratio, "L/a"))))
        damping = physics_callback(lambda: control.set_damping(
            bool(self.damping_on.value), check("damping", self.damping, "dashpot c (N s/m)")))
        self.damping_on.on_update(damping)
        self.damping.on_update(damping)
        gravity = physics_callback(lambda: control.set_gravity(
            bool(self.gravity_on.value), check("gravity", self.gravity, "g (m/s²)")))
        self.gravity_on.on_update(gravity)
        self.gravity.on_update(gravity)
        self.linear.on_update(physics_callback(
            lambda: control.set_linear(bool(self.linear.value))))
        for row in TERM_ROWS:
            self.term_sliders[row.name].on_update(physics_callback(
                lambda row=row: control.set_parameters(**{row.name: check(
                    row.name, self.term_sliders[row.name], f"{row.label} ({row.unit})")})))

        def masses() -> Any:
            pattern = choice(self.mass_pattern.value, "mass pattern", [*MASS_PATTERNS, AS_LOADED])
            heavy = check("heavy_mass", self.heavy_mass, "heavy mass (kg)")
            if pattern == AS_LOADED:  # nothing to choose: the scene keeps its masses
                return host.runner.post(lambda simulation: None)
            return control.set_mass_pattern(pattern, heavy=heavy, light=LIGHT_MASS)

        self.mass_pattern.on_update(physics_callback(masses))
        self.heavy_mass.on_update(physics_callback(masses))

    def show_hanging(self, model: sim.Model) -> None:
        """Say, in amber, why the lattice cannot hang under its gravity (or nothing)."""
        problem = hanging_problem(model)
        self.hanging.content = amber_html(problem) if problem else ""
        self.hanging.visible = problem is not None

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        show = self.limits.show
        show("stiffness", self.stiffness, float(model.stiffness))
        show("rest_ratio", self.rest_ratio, float(model.rest_length / model.spacing))
        self.damping_on.value = model.damping > 0
        if model.damping > 0:
            show("damping", self.damping, float(model.damping))
        self.gravity_on.value = model.has_gravity
        if model.has_gravity:
            show("gravity", self.gravity, float(np.linalg.norm(model.gravity)))
        self.linear.value = model.linear
        self.show_hanging(model)
        for row in TERM_ROWS:
            show(row.name, self.term_sliders[row.name], float(getattr(model, row.name)))
        pattern = mass_pattern_of(model)
        self.mass_pattern.value = pattern
        if pattern == "ionic":
            masses = np.asarray(model.masses).reshape(-1)
            show("heavy_mass", self.heavy_mass, float(masses[0]))
        say(self.message, None)
