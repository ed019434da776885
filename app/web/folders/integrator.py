"""The page's "Integrator" folder: the method, the time step and how the steps run.

The method dropdown offers the integrators of the registry (``sim.integrators.registry``) that apply to
the running model (e.g. the exact solver once the springs are linearised).  Below the time step a
line says whether it is stable (``Simulation.stability``, computed in the simulation thread
whenever the model or the method changes).  Steps per frame, precision and threads set how the
steps run; each value the page sends is checked, and a refused one puts the value in use back.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from typing import Any

import viser

import sim
from app.web.control import MAX_STEPS_PER_FRAME
from app.web.folders.accuracy import has_time_step_error
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, choice, from_user, number, ok_html, warning_html, whole_number
from app.web.widgets import say
from sim.integrators.registry import PRECISIONS
from sim.runtime.runner import Frame
from sim.theory.observables import StabilityLimit

MAX_DT = 10.0
"""Largest time step (s) the page accepts."""
MAX_THREADS = max(1, os.cpu_count() or 1)
"""Most threads the page lets the compiled steps use: the machine's cores."""


def methods_hint() -> str:
    """The method dropdown's hint: every integrator's order, from the registry."""
    described = []
    for description in sim.integrators.descriptions():
        if not has_time_step_error(description.name):
            what = "no time-step error"
        else:
            what = f"order {description.order}" + (", symplectic" if description.symplectic
                                                   else "")
        applies = "" if description.applies_to is None else ", on some scenes"
        described.append(f"{description.name} ({description.label}: {what}{applies})")
    return "; ".join(described)


class IntegratorFolder(Folder):
    name = "integrator"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        simulation = host.runner.simulation
        self._stability_for: tuple[sim.Model, str] | None = None
        """(model, integrator) the stability line was computed for."""
        self._limit: StabilityLimit | None = None
        """The stability limit of the scene and integrator shown (None until it is known)."""
        self._shown_dt: float | None = None
        """The dt of the last frame shown in the dt box (s)."""
        with gui.add_folder("Integrator"):
            self.method = gui.add_dropdown(
                "Method", sim.integrators.names(simulation.model),
                initial_value=simulation.integrator, hint=methods_hint(),
            )
            self.dt = gui.add_number("Time step dt (s)", simulation.dt, step=1e-4)
            self.stability = gui.add_html("")
            self.steps_per_frame = gui.add_slider(
                "Steps per frame", 1, MAX_STEPS_PER_FRAME, 1, int(host.runner.steps_per_frame),
                hint="simulation steps between two pictures: faster, coarser animation",
            )
            self.precision = gui.add_dropdown(
                "Precision", list(PRECISIONS), initial_value=simulation.precision,
                hint="float32 runs about twice as fast and is less accurate (error floor near "
                "1e-7 of the motion); energies are always summed in float64",
            )
            self.threads = gui.add_slider(
                "Threads", 1, MAX_THREADS, 1, simulation.threads,
                hint="cores the compiled steps use (large lattices; results equal one thread's "
                "to round-off)", disabled=MAX_THREADS == 1,
            )
            self.message = gui.add_html("")

        def checked(handle: Any, read: Callable[[Any], Any], in_use: Callable[[], Any],
                    apply: Callable[[Any], Any]) -> None:
            """Check the page's value of ``handle`` with ``read`` and ``apply`` it, or show the
            value in use again and say why it was refused."""
            @handle.on_update
            @from_user
            async def _(_: viser.GuiEvent) -> None:
                try:
                    value = read(handle.value)
                except InputRefused as error:
                    say(self.message, error)
                    handle.value = in_use()
                    return
                say(self.message, None)
                apply(value)

        running = host.runner
        checked(self.method,
                lambda value: choice(value, "integrator",
                                     sim.integrators.names(running.simulation.model)),
                lambda: running.simulation.integrator, host.control.set_integrator)
        checked(self.dt, lambda value: number(value, "dt (s)", 0.0, MAX_DT, low_open=True),
                lambda: running.simulation.dt, host.control.set_dt)
        checked(self.precision, lambda value: choice(value, "precision", list(PRECISIONS)),
                lambda: running.simulation.precision, host.control.set_precision)
        checked(self.threads, lambda value: whole_number(value, "threads", 1, MAX_THREADS),
                lambda: running.simulation.threads, host.control.set_threads)
        checked(self.steps_per_frame,
                lambda value: whole_number(value, "steps per frame", 1, MAX_STEPS_PER_FRAME),
                lambda: int(running.steps_per_frame), host.control.set_steps_per_frame)

    def show_scene(self, simulation: sim.Simulation) -> None:
        self._stability_for = None
        self.method.options = sim.integrators.names(simulation.model)
        self.method.value = simulation.integrator
        self.dt.value = self._shown_dt = simulation.dt
        self.precision.value = simulation.precision
        self.threads.value = simulation.threads
        self.steps_per_frame.value = int(self.host.runner.steps_per_frame)

    def update(self, frame: Frame, now: float) -> None:
        """Show the method and time step in use and whether the time step is stable."""
        if frame.dt != self._shown_dt:  # the dt in use changed, whoever set it: show it
            self._shown_dt = frame.dt  # (only then: a value a page just sent is the callback's)
            self.dt.value = frame.dt  # posts nothing
        shown_for = self._stability_for
        if shown_for is None or shown_for[0] is not frame.model or shown_for[1] != frame.integrator:
            self._stability_for = (frame.model, frame.integrator)
            applicable = sim.integrators.names(frame.model)
            if tuple(self.method.options) != tuple(applicable):
                self.method.options = applicable  # e.g. exact once springs are linearised
            if self.method.value != frame.integrator:
                self.method.value = frame.integrator  # shows what runs (posts nothing)
            future = self.host.runner.post(lambda simulation: simulation.stability())

            def done(result: Any) -> None:
                if result.exception() is None:
                    self._limit = result.result()

            future.add_done_callback(done)
        limit = self._limit
        stable = None if limit is None else limit.dt
        run_dt = None if limit is None else limit.run_dt
        if stable is None:
            text = warning_html(f"no stable dt for {frame.integrator} here (add damping or change "
                                "integrator)") if limit is not None else ""
        elif math.isinf(stable):
            text = ok_html("stable for any dt")
        elif frame.dt > stable:
            text = warning_html(f"dt = {frame.dt:.4g} s exceeds the stability limit "
                                f"{stable:.4g} s: the run will blow up")
        elif run_dt is not None and frame.dt > run_dt:
            text = warning_html(f"dt = {frame.dt:.4g} s is below the small-amplitude limit "
                                f"{stable:.4g} s but above {run_dt:.4g} s, where this "
                                "scene's own run was measured to stop: its large motion "
                                "stiffens the springs")
        elif run_dt is not None:
            text = ok_html(f"this scene's run was measured stable up to dt = {run_dt:.4g} s "
                           f"({frame.dt / run_dt:.0%} of it; small-amplitude limit "
                           f"{stable:.4g} s)")
        else:
            text = ok_html(f"stable for dt ≤ {stable:.4g} s ({frame.dt / stable:.0%} of the limit)")
        if self.stability.content != text:
            self.stability.content = text
