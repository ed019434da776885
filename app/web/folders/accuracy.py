"""The page's "Accuracy" folder: what the current speed costs, live and before running.

* **Live**: the relative energy-balance error of the running state (``Frame.energy_balance_error``,
  0 for the exact dynamics) as a number and its own plot (in %, ppm or ppb: the unit that keeps
  its ticks readable; emptied at a reset); amber above the tolerance, red above ten
  times it, with a sentence saying why it happens for this integrator and what to do.
* **Predicted**: the energy and phase error that the current integrator and dt will have after
  the scene's duration, from the normal modes of the scene's initial state (``sim.theory.prediction``),
  computed in a background thread whenever the model, integrator or dt changes.
* **Choose for me**: ``app.study.choose`` on the scene as it is now (``app.web.choosing``, the
  code of `oscillators choose` and of the Speed-vs-accuracy folder): the cheapest integrator and
  dt whose error over the scene's duration meets the tolerance (the field error where a
  reference is affordable, else the energy error; the message says which), verified by running
  it before it is offered; *Apply* sets exactly that setting, as ordinary commands.

Like every folder of the page, callbacks act only on events a browser sent (``from_user``) and
check the values they get.
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import viser

import sim
from app.csv_table import csv_text
from app.web.choosing import ChoiceCancelled, apply_choice, cancel_choice, choose_on_page
from app.web.downloads import add_csv_button
from app.web.host import Folder, PanelHost
from app.web.inputs import (
    InputRefused,
    amber_html,
    as_html,
    from_user,
    number,
    ok_html,
    warning_html,
)
from app.web.plots import LivePlot
from app.web.widgets import RATIO_UNITS, History, PlotAxis, axis_range, say
from sim.integrators.registry import describe
from sim.runtime.runner import Frame

HISTORY = 600
"""Points kept in the error plot."""
PLOT_INTERVAL = 0.25
"""Seconds between two updates of the error plot."""
DEFAULT_TOLERANCE = 0.01
"""Relative energy-balance error (1 %) above which the page warns."""


def has_time_step_error(integrator: str) -> bool:
    """Whether ``integrator``'s error depends on the time step (every method of some order; not
    an exact solution such as the normal-mode solver, registered with order 0)."""
    return describe(integrator).order > 0


def explanation(integrator: str, error: float, model: sim.Model) -> str:
    """Why the energy balance drifts for this integrator (its registry entry says), and what to
    do on ``model``, in plain words."""
    applicable = [describe(name) for name in sim.integrators.names(model)]
    remedies = ["a smaller dt"]
    if not describe(integrator).symplectic:
        remedies += [other.label for other in applicable if other.symplectic]
    if has_time_step_error(integrator):
        remedies += [f"the {other.label} (no time-step error on this scene)"
                     for other in applicable if not has_time_step_error(other.name)]
    remedy = "Try " + ", or ".join(remedies) + " (Choose for me picks the cheapest)."
    return f"{describe(integrator).drift_explanation(error)} {remedy}"


def error_words(error: float, history: History) -> str:
    """The error in the unit the plot's axis shows for the run so far (%, ppm, ppb, ...), so the
    words and the plot speak one unit."""
    if not math.isfinite(error):
        return f"{error}"
    _, values = history.columns()
    factor, unit, _ = axis_range(values[0] if values.size else np.array([error]), "",
                                 RATIO_UNITS)
    if unit == "%":
        return f"{error:+.3%}"
    return f"{error / factor:+.3g} {unit}"


class AccuracyFolder(Folder):
    name = "accuracy"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        self.control = host.control
        self.history = History(HISTORY)
        """The energy-balance error (%) against time."""
        self._prediction_key: tuple | None = None
        self._prediction_text = ""
        self._predictors: dict[int, Any] = {}
        self._predicting = threading.Lock()
        self._last_plot = 0.0
        with gui.add_folder("Accuracy") as folder:
            self.live = gui.add_html("")
            self.why = gui.add_html("", visible=False)
            self.error_plot = LivePlot(
                gui, folder,
                ({"label": "t (s)"},
                 {"label": "energy-balance error", "stroke": "#c0392b", "width": 1.5}),
                PlotAxis("error", "", "simulated time t (s)", RATIO_UNITS),
                aspect=2.2)
            self.download = add_csv_button(
                gui, "Download CSV", "the plotted energy-balance error",
                lambda: host.runner.simulation.scene.name, self.csv, "energy-balance-error")
            self.predicted = gui.add_html("")
            self.tolerance = gui.add_number(
                "Tolerance (%)", DEFAULT_TOLERANCE * 100, step=0.1,
                hint="error allowed over the scene's duration (the live energy-balance error is "
                "compared with it; Choose for me uses the field error where it can)",
            )
            self.choose_button = gui.add_button(
                "Choose for me", icon=viser.Icon.WAND,
                hint="find the cheapest integrator and dt meeting the tolerance, verified by "
                "running it over the scene's duration (the code of `oscillators choose`)",
            )
            self.message = gui.add_html("")
            self.apply_button = gui.add_button(
                "Apply", icon=viser.Icon.CHECK, visible=False,
                hint="run exactly the verified integrator and dt")
        self._answer: Any = None
        self._choosing = False

        @self.tolerance.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                number(self.tolerance.value, "tolerance (%)", 0.0, 100.0, low_open=True)
            except InputRefused as error:
                say(self.message, error)
                return
            self.message.content = ""

        @self.choose_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # thread pool: the runs take a while
            if self._choosing:  # the button reads "Cancel the choice"
                if cancel_choice(host):
                    self.message.content = as_html("cancelling…")
                return
            self._choosing = True
            self.choose_button.label = "Cancel the choice"
            self.choose_button.icon = viser.Icon.PLAYER_STOP
            self.apply_button.visible = False
            self._answer = None
            try:
                tolerance = self.tolerance_value()
                self.message.content = as_html("measuring…")
                choice = self.choose(tolerance)
            except ChoiceCancelled:
                self.message.content = as_html("choice cancelled")
                return
            except (InputRefused, sim.ModelError, ValueError) as error:
                say(self.message, error, "could not choose")
                return
            except Exception as error:  # a failed choice must not take the page down
                say(self.message, error, "could not choose")
                return
            finally:
                self._choosing = False
                self.choose_button.label = "Choose for me"
                self.choose_button.icon = viser.Icon.WAND
            answer = choice.answer
            if answer is None:
                best = choice.best_reached
                self.message.content = warning_html(
                    f"nothing meets {tolerance:.3g} ({choice.measure} error)"
                    + (f"; the best reached: {best.describe()}" if best else "")
                    + "; loosen the tolerance")
                return
            self._answer = answer
            self.apply_button.visible = True
            self.message.content = ok_html(
                f"verified over {choice.duration:.4g} s: {answer.describe()}, {choice.measure} "
                f"error within {tolerance:.3g}. Apply sets exactly this integrator and dt.")

        @self.apply_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            answer = self._answer
            if answer is None:
                return
            try:
                integrator, dt = apply_choice(host, answer)
            except (sim.ModelError, ValueError, TimeoutError) as error:
                say(self.message, error, "could not apply")
                return
            self.message.content = ok_html(f"now running {integrator} at dt = {dt!r} s")

    # --- values -------------------------------------------------------------------------------

    def tolerance_value(self) -> float:
        return number(self.tolerance.value, "tolerance (%)", 0.0, 100.0, low_open=True) / 100

    def _predictor(self, simulation: sim.Simulation) -> Any:
        """The scene's initial state in the current model's modes (cached per model)."""
        from sim.theory.prediction import predictor_for_scene

        key = id(simulation.model)
        if key not in self._predictors:
            self._predictors = {key: predictor_for_scene(
                simulation.model, np.asarray(simulation.scene.initial_positions),
                np.asarray(simulation.scene.initial_velocities))}
        return self._predictors[key]

    def choose(self, tolerance: float) -> Any:
        """``app.study.choose`` on the scene as it is now (``app.web.choosing``)."""
        return choose_on_page(self.host, tolerance, self.message)

    # --- keeping in step ----------------------------------------------------------------------

    @property
    def plot(self) -> Any:
        """The viser plot of the error shown now."""
        return self.error_plot.handle

    def csv(self) -> str:
        """The plotted series: simulated time (s), the energy-balance error (relative)."""
        headings = [("simulated time t", "s"), ("energy-balance error", "")]
        if not len(self.history):
            return csv_text(headings, [])
        times, errors = self.history.columns()
        return csv_text(headings, zip(times, errors[0], strict=True))

    def clear(self) -> None:
        self.history.clear()
        self.error_plot.clear()
        self._prediction_key = None

    def show_scene(self, simulation: sim.Simulation) -> None:
        self.clear()

    def update(self, frame: Frame, now: float) -> None:
        error = frame.energy_balance_error
        if self.history.add(frame.time, (error,)):  # a reset: the old line goes at once
            self.error_plot.clear()
            self._prediction_key = None
        try:
            tolerance = self.tolerance_value()
        except InputRefused:
            tolerance = DEFAULT_TOLERANCE
        text = f"energy-balance error {error_words(error, self.history)} (tolerance " \
               f"{100 * tolerance:.3g} %)"
        size = abs(error) if math.isfinite(error) else math.inf
        if size > 10 * tolerance:
            live = warning_html(text)
        elif size > tolerance:
            live = amber_html(text)
        else:
            live = ok_html(text)
        if self.live.content != live:
            self.live.content = live
        if size > tolerance:
            why = as_html(explanation(frame.integrator, error, frame.model))
            if self.why.content != why:
                self.why.content = why
            self.why.visible = True
        elif self.why.visible:
            self.why.visible = False
        if now - self._last_plot > PLOT_INTERVAL and len(self.history) > 1:
            self._last_plot = now
            times, errors = self.history.columns()
            self.error_plot.show(times, errors)
        self._update_prediction(frame)

    def _update_prediction(self, frame: Frame) -> None:
        key = (id(frame.model), frame.integrator, frame.dt)
        if key == self._prediction_key or self._predicting.locked():
            return
        self._prediction_key = key
        simulation = self.host.runner.simulation
        if not has_time_step_error(frame.integrator):
            self.predicted.content = ok_html(
                f"{describe(frame.integrator).short_label} solver: no time-step error at any dt")
            return

        def work() -> None:
            with self._predicting:
                try:
                    prediction = self._predictor(simulation).predict(
                        frame.integrator, frame.dt, simulation.scene.duration)
                    text = prediction.describe()
                    tolerance = self.tolerance_value()
                    good = prediction.stable and abs(prediction.energy_error) <= tolerance
                    self.predicted.content = ok_html(text) if good else amber_html(text)
                except Exception as error:  # a prediction that cannot be made says why
                    self.predicted.content = as_html(f"no prediction: {error}")

        threading.Thread(target=work, name="web-prediction", daemon=True).start()
