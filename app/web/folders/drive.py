"""The page's "Drive" folder: push one particle back and forth and watch the lattice respond.

*Drive this particle* drives the selected particle (or, with nothing selected, the particle
driven now) with a sinusoidal force A k sin(2 pi f t) or a prescribed displacement
A sin(2 pi f t) along x, y (or z in 3-D scenes) (``sim.model.forcing.Driver``); the drive starts
at the current time and ramps up over ``DRIVE_RAMP`` seconds.  *Stop driving* removes the driver
(the work it did stays in the energy account).  The folder shows the driver that acts now and
the work it has done, and lists the lattice's lowest normal-mode frequencies for the chosen
direction, so that a student can aim at a resonance (or, in the ionic chain, into the gap).

Like the rest of the panel, the folder is a view: ``show_scene`` and ``update`` only assign
widget values (``from_user`` keeps those from posting commands), and every value a page sends is
checked on the server (``app.web.inputs``) before a command is posted through
``SimulationControl``.
"""

from __future__ import annotations

import math

import numpy as np
import viser

import sim
from app.web.control import DRIVE_RAMP
from app.web.host import Folder, PanelHost
from app.web.inputs import (
    InputRefused,
    as_html,
    choice,
    from_user,
    number,
    ok_html,
    whole_number,
)
from app.web.widgets import say, show_number
from sim.model.forcing import DRIVER_KINDS, Driver
from sim.runtime.runner import Frame
from sim.theory.modes import POLARISATION_NAMES, ModalBasis, polarisations, second_difference_eigenvalues

LISTED_MODES = 5
"""How many of the lowest normal-mode frequencies the folder lists."""
DENSE_MODES_LIMIT = 400
"""Largest unequal-mass lattice whose mode frequencies the folder computes (a dense eigen-solve
per change of the model, in the frame pump's thread: about 20 ms at this size)."""
MAX_AMPLITUDE_SPACINGS = 0.5
"""Largest drive amplitude the page accepts, in lattice spacings (a loaded scene's larger
amplitude widens it)."""
AS_LOADED = "as loaded"
"""Direction entry shown for a loaded driver that acts along no axis."""
REFRESH_SECONDS = 0.5
"""Seconds between two updates of the driver's work."""
ERRORS = (InputRefused, sim.ModelError, ValueError, TimeoutError)
"""What a refused drive raises; shown in the folder, never a traceback."""


def mode_frequencies(model: sim.Model, polarisation: int,
                     count: int = LISTED_MODES) -> tuple[list[float], float]:
    """(the ``count`` lowest distinct normal-mode frequencies, the highest one), in Hz, of the
    lattice linearised about rest for one displacement component (0 x, 1 y, 2 z); modes without
    a restoring force are left out (the highest is 0 when none has one).  Unequal masses above
    ``DENSE_MODES_LIMIT`` particles raise ``ModelError`` (a dense eigen-solve)."""
    if model.uniform_mass:
        across_columns, across_rows, _, _ = polarisations(model)[polarisation]
        columns = second_difference_eigenvalues(model.nx, model.row_ends)
        rows = second_difference_eigenvalues(model.ny)
        mass = float(model.masses.flat[0])
        top = np.zeros(0)
        if across_columns >= 0.0 and across_rows >= 0.0:
            # omega^2 rises with p and q: the `count` lowest distinct values lie among the first
            # `count` distinct eigenvalues of each axis (at most 2 * count entries: a ring's come
            # in pairs) and the highest is the last (no need for all nx * ny of them)
            top = np.array([across_columns * columns[-1] + across_rows * rows[-1]])
            columns, rows = columns[: 2 * count], rows[: 2 * count]
        squared = np.concatenate(
            [(across_columns * columns[None, :] + across_rows * rows[:, None]).ravel(), top]
        ) / mass
    elif model.n_particles <= DENSE_MODES_LIMIT:
        squared = np.asarray(ModalBasis.of(model).omega_squared[polarisation]).ravel()
    else:
        raise sim.ModelError(
            f"with unequal masses the page lists them up to {DENSE_MODES_LIMIT} particles "
            f"(this lattice has {model.n_particles:,}; the Modes folder shows them)"
        )
    frequencies = np.sqrt(np.sort(squared[squared > 0.0])) / (2.0 * math.pi)
    distinct: list[float] = []
    for frequency in frequencies:
        if len(distinct) == count:
            break
        if not distinct or not math.isclose(frequency, distinct[-1], rel_tol=1e-6):
            distinct.append(float(frequency))
    return distinct, float(frequencies[-1]) if frequencies.size else 0.0


def highest_mode_frequency(model: sim.Model) -> float:
    """An upper bound (Hz) of the lattice's normal-mode frequencies (any masses): each particle
    feels at most 2 (|k_columns| + |k_rows|) from its four springs."""
    stiffest = max(abs(columns) + abs(rows) for columns, rows, _, _ in polarisations(model))
    lightest = float(np.min(model.masses))
    return math.sqrt(4.0 * stiffest / lightest) / (2.0 * math.pi)


def round_up(value: float) -> float:
    """``value`` rounded up to 1, 2 or 5 times a power of ten (a slider's end)."""
    if value <= 0.0 or not math.isfinite(value):
        return 1.0
    decade = 10.0 ** math.floor(math.log10(value))
    return next(step * decade for step in (1.0, 2.0, 5.0, 10.0) if step * decade >= value)


def axis_of(direction: tuple[float, float, float]) -> str | None:
    """"x", "y" or "z" when ``direction`` is that axis, else None."""
    for index, name in enumerate(POLARISATION_NAMES):
        if tuple(direction) == tuple(1.0 if k == index else 0.0 for k in range(3)):
            return name
    return None


class DriveFolder(Folder):
    name = "drive"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        self._last = 0.0
        self._shown_state = ""
        self._modes_for: tuple[sim.Model, int, float] | None = None
        """(model, polarisation, dt) the listed modes and the frequency's hint belong to."""
        self._amplitude_limit = MAX_AMPLITUDE_SPACINGS
        model = host.runner.simulation.model
        with gui.add_folder("Drive", expand_by_default=False):
            self.state = gui.add_html(as_html("not driven"))
            self.target = gui.add_html("")
            self.frequency = gui.add_slider(
                "Frequency f (Hz)", 0.001, 4.0, 0.001, 0.5,
                hint="the drive's frequency; near a normal mode's frequency the lattice resonates "
                "(the lowest are listed below)",
            )
            self.modes = gui.add_html("")
            self.amplitude = gui.add_slider(
                "Amplitude A (m)", 0.0, MAX_AMPLITUDE_SPACINGS, 0.001, 0.02,
                hint="force: the force of a spring stretched by A (A k, N); displacement: how far "
                "the particle is moved from its rest position",
            )
            self.kind = gui.add_dropdown(
                "Kind", list(DRIVER_KINDS), initial_value="force",
                hint="force: push with A k sin(2πft); displacement: move the particle along "
                "A sin(2πft), whatever its neighbours do",
            )
            self.direction = gui.add_dropdown(
                "Direction", list(POLARISATION_NAMES[: model.dim]), initial_value="x",
                hint="x: along the rows (longitudinal in a chain), y: across them, z: out of the "
                "plane (3-D scenes)",
            )
            self.drive_button = gui.add_button(
                "Drive this particle", icon=viser.Icon.WAVE_SINE,
                hint="drive the selected particle (nothing selected: the particle driven now) "
                f"from now on; the drive ramps up over {DRIVE_RAMP:g} s",
            )
            self.stop_button = gui.add_button("Stop driving", icon=viser.Icon.PLAYER_STOP)
            self.message = gui.add_html("")

        @self.drive_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # thread pool: waits for the command
            try:
                driver = self.drive_from_page()
            except ERRORS as error:
                self.show_driver(self.host.runner.simulation.model)  # every page: the drive in use
                say(self.message, error, "could not drive")
                return
            self.message.content = ok_html(
                f"driving particle ({driver.column}, {driver.row}) from t = {driver.start:.4g} s; "
                "press Play")

        @self.stop_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                self.host.control.stop_driving().result(timeout=30)
            except ERRORS as error:
                say(self.message, error, "could not stop driving")
                return
            self.message.content = ok_html("stopped driving (the lattice keeps the energy the "
                                           "driver put in)")
            self._show_state(self.host.runner.simulation.model, None)

        @self.direction.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:  # shows the modes of that direction; posts nothing
            self._modes_for = None
            self._show_modes(self.host.runner.simulation.model)

    # --- from the page --------------------------------------------------------------------------

    def _directions(self, model: sim.Model) -> list[str]:
        names = list(POLARISATION_NAMES[: model.dim])
        if model.driver is not None and axis_of(model.driver.direction) is None:
            names.append(AS_LOADED)
        return names

    def max_frequency(self) -> float:
        """The highest drive frequency (Hz) accepted: half the step rate 1 / (2 dt), above which
        the steps cannot follow the drive."""
        return 0.5 / float(self.host.runner.simulation.dt)

    def _target(self, model: sim.Model) -> tuple[int, int]:
        """(column, row) of the particle to drive: the first selected one, or the driven one."""
        selection = np.asarray(self.host.view.selection)
        if selection.size:
            particle = whole_number(selection[0], "particle", 0, model.n_particles - 1)
            return particle % model.nx, particle // model.nx
        if model.driver is not None:
            return model.driver.column, model.driver.row
        raise InputRefused("select the particle to drive first (click it)")

    def drive_from_page(self) -> Driver:
        """Check the folder's values and drive (waits for the command); raises what refused it."""
        model = self.host.runner.simulation.model
        column, row = self._target(model)
        frequency = number(self.frequency.value, "frequency (Hz)", 0.0, self.max_frequency(),
                           low_open=True)
        amplitude = number(self.amplitude.value, "amplitude (m)", 0.0,
                           self._amplitude_limit * model.spacing)
        kind = choice(self.kind.value, "kind", list(DRIVER_KINDS))
        direction: str | tuple[float, float, float] = choice(
            self.direction.value, "direction", self._directions(model))
        if direction == AS_LOADED:
            direction = model.driver.direction
        driver = self.host.control.drive(
            column=column, row=row, direction=direction, amplitude=amplitude,
            frequency=frequency, kind=kind,
        ).result(timeout=30)
        self.show_driver(self.host.runner.simulation.model)
        return driver

    # --- keeping in step ------------------------------------------------------------------------

    def show_driver(self, model: sim.Model) -> None:
        """Show the model's driver in the widgets (assigning values posts nothing)."""
        self.direction.options = self._directions(model)
        driver = model.driver
        if driver is None:
            if self.direction.value not in self.direction.options:
                self.direction.value = self.direction.options[0]
        else:
            spacing = float(model.spacing)
            self._amplitude_limit = max(MAX_AMPLITUDE_SPACINGS, driver.amplitude / spacing)
            show_number(self.frequency, driver.frequency)
            show_number(self.amplitude, driver.amplitude)
            self.kind.value = driver.kind
            self.direction.value = axis_of(driver.direction) or AS_LOADED
        self._modes_for = None
        self._show_modes(model)

    def show_scene(self, simulation: sim.Simulation) -> None:
        """Show a new scene's driver and modes (its work follows with the frames)."""
        model = simulation.model
        self._amplitude_limit = MAX_AMPLITUDE_SPACINGS
        self.amplitude.max = MAX_AMPLITUDE_SPACINGS * float(model.spacing)
        if self.amplitude.value > self.amplitude.max:
            self.amplitude.value = self.amplitude.max
        self.frequency.max = round_up(1.5 * highest_mode_frequency(model))
        if self.frequency.value > self.frequency.max:
            self.frequency.value = self.frequency.max
        self.message.content = ""
        self.show_driver(model)
        self._show_state(model, None)
        self.selection_changed(np.asarray(self.host.view.selection), model)

    def selection_changed(self, selection: np.ndarray, model: sim.Model | None = None) -> None:
        """Say which particle *Drive this particle* drives."""
        model = model or self.host.runner.simulation.model
        if selection.size and 0 <= int(selection[0]) < model.n_particles:
            particle = int(selection[0])
            text = (f"Drive this particle drives particle {particle} (column "
                    f"{particle % model.nx}, row {particle // model.nx})")
            if selection.size > 1:
                text += f", the first of the {selection.size} selected"
        elif model.driver is not None:
            text = (f"Nothing selected: Drive this particle changes the drive of particle "
                    f"({model.driver.column}, {model.driver.row})")
        else:
            text = "Select the particle to drive (click it)."
        self.target.content = as_html(text)

    def _show_modes(self, model: sim.Model) -> None:
        name = self.direction.value
        if name not in POLARISATION_NAMES[: model.dim]:  # a loaded vector: its largest component
            driver = model.driver
            name = POLARISATION_NAMES[int(np.argmax(np.abs(driver.direction[: model.dim])))] \
                if driver is not None else "x"
        polarisation = POLARISATION_NAMES.index(name)
        dt = float(self.host.runner.simulation.dt)
        shown_for = self._modes_for
        if shown_for is not None and shown_for[0] is model and shown_for[1:] == (polarisation, dt):
            return
        self._modes_for = (model, polarisation, dt)
        try:
            lowest, highest = mode_frequencies(model, polarisation)
        except sim.ModelError as error:
            text = f"Normal modes along {name}: not listed; {error}"
        else:
            if lowest:
                listed = ", ".join(f"{f:.4g}" for f in lowest)
                text = (f"Lowest normal modes along {name}: {listed} Hz (the highest: "
                        f"{highest:.4g} Hz)")
            else:
                text = f"No normal mode along {name} has a restoring force"
        hint = (f"the drive's frequency, up to {0.5 / dt:.4g} Hz at this dt; near a "
                f"normal mode's frequency the lattice resonates. {text}")
        if self.frequency.hint != hint:
            self.frequency.hint = hint
        shown = as_html(text)
        if self.modes.content != shown:
            self.modes.content = shown

    def _show_state(self, model: sim.Model, driven: float | None) -> None:
        driver = model.driver
        if driver is None:
            text = "not driven"
            if driven:
                text += f" (the earlier drive did {driven:.4g} J of work)"
        else:
            described = driver.describe()
            text = described[:1].upper() + described[1:] + f", from t = {driver.start:.4g} s"
            if driven is not None:
                text += f"\nwork done by the driver so far: {driven:.4g} J"
        shown = as_html(text)
        if shown != self._shown_state:
            self._shown_state = shown
            self.state.content = shown

    def update(self, frame: Frame, now: float) -> None:
        if frame.model is not self.host.runner.simulation.model:
            return  # a frame of the scene before a change: the folder already shows the new one
        if now - self._last < REFRESH_SECONDS and (self._modes_for is None
                                                   or self._modes_for[0] is frame.model):
            return
        self._last = now
        self._show_state(frame.model, frame.energy.driven)
        self._show_modes(frame.model)
