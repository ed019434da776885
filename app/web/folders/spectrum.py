"""The page's "Modes" folder: the energy in each normal mode, live, and one mode excited alone.

The lattice linearised about its equilibrium is a sum of independent normal modes
(``sim.theory.modes``).  For equal masses the mode (m, n) of a polarisation has m half-waves along x and
n along y; the folder draws the energy of every (m, n) as an nx-by-ny heat map on a log colour
scale with a colour bar, for the chosen polarisation, refreshed about once a second from the
latest frame in a background thread (the simulation never waits for it).  Typing (m, n) shows that
mode's frequency; *Excite mode* puts the lattice at its equilibrium with that mode alone displaced
(a command, like every other change).  With unequal masses the modes are eigenvectors: the
picture is energy against frequency, and exciting one mode is not offered.

In a linear scene without damping each mode's energy stays constant; with nonlinear springs
students watch energy move between modes.

Below the picture, the density of states: a histogram of the exact normal-mode frequencies of the
lattice (``sim.theory.bands.density_from``), when they can be computed (equal masses at any size,
unequal masses up to ``sim.theory.modes.DENSE_PARTICLE_LIMIT`` particles; the folder says why not
otherwise).
"""

from __future__ import annotations

import io
import threading

import numpy as np
import viser

import sim
from app.csv_table import csv_text
from app.web.downloads import add_csv_button
from app.web.host import Folder, PanelHost
from app.web.inputs import (
    InputRefused,
    as_html,
    choice,
    from_user,
    number,
    ok_html,
    warning_html,
    whole_number,
)
from app.web.mode_shares_view import ModeSharesView
from app.web.plots import ENTERING, PADDING
from app.web.widgets import MATPLOTLIB_LOCK, say
from sim.runtime.runner import Frame
from sim.theory.bands import density_from
from sim.theory.modes import (
    POLARISATION_NAMES,
    ModalBasis,
    excited_state,
    mode_energies,
    mode_frequency,
)

REFRESH_SECONDS = 1.0
"""Seconds between two pictures of the spectrum (more on large lattices, see ``_interval``)."""
DENSITY_BINS = 30
"""Bins of the density of states' histogram."""
DYNAMIC_RANGE = 1e-10
"""The colour scale spans this fraction of the largest mode energy up to the largest."""


def render_spectrum(energies: np.ndarray, model: sim.Model, polarisation: int,
                    frequencies: np.ndarray | None = None) -> np.ndarray:
    """An RGB picture (height, width, 3) uint8 of one polarisation's mode energies: a heat map
    over (m, n) with a log colour bar (equal masses), or energy against frequency."""
    with MATPLOTLIB_LOCK:
        return _render_spectrum(energies, model, polarisation, frequencies)


def _render_spectrum(energies: np.ndarray, model: sim.Model, polarisation: int,
                     frequencies: np.ndarray | None) -> np.ndarray:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    figure = Figure(figsize=(4.2, 3.2), dpi=90)
    FigureCanvasAgg(figure)
    axis = figure.add_subplot()
    top = float(energies.max()) if energies.size else 0.0
    name = POLARISATION_NAMES[polarisation]
    if top <= 0.0:
        axis.text(0.5, 0.5, f"no energy in the {name} modes", ha="center", va="center")
        axis.set_axis_off()
    elif energies.ndim == 2:
        floor = top * DYNAMIC_RANGE
        image = axis.imshow(np.maximum(energies, floor), origin="lower", cmap="magma",
                            norm=LogNorm(vmin=floor, vmax=top), aspect="auto",
                            extent=(0.5, model.nx + 0.5, 0.5, model.ny + 0.5),
                            interpolation="nearest")
        figure.colorbar(image, ax=axis, label="mode energy (J)")
        axis.set_xlabel("m (half-waves along x)")
        axis.set_ylabel("n (half-waves along y)")
    else:
        shown = np.maximum(energies, top * DYNAMIC_RANGE)
        x = frequencies if frequencies is not None else np.arange(1, energies.size + 1)
        axis.semilogy(x, shown, ".", markersize=3)
        axis.set_xlabel("ω (rad/s)")
        axis.set_ylabel("mode energy (J)")
    axis.set_title(f"energy per normal mode, {name} polarisation", fontsize=9)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="raw", dpi=90)
    width, height = figure.canvas.get_width_height()
    return np.frombuffer(buffer.getvalue(), np.uint8).reshape(height, width, 4)[..., :3].copy()


class SpectrumFolder(Folder):
    name = "spectrum"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        self._basis: tuple[int, ModalBasis | None, str] | None = None
        self._working = threading.Lock()
        self._last = 0.0
        self.last_energies: list[np.ndarray] | None = None
        self._table: tuple | None = None
        """(model, basis, energies) of the latest picture, for ``csv``."""
        model = host.runner.simulation.model
        with gui.add_folder("Modes", expand_by_default=False) as self._folder:
            self.mode_shares = ModeSharesView(gui, self._folder, host.runner)
            self.polarisation = gui.add_dropdown(
                "Polarisation", list(POLARISATION_NAMES[: model.dim]), initial_value="y",
                hint="x: motion along the rows, y: along the columns, z: out of the plane",
            )
            self.picture = gui.add_image(np.full((8, 8, 3), 255, np.uint8))
            self.density_text = gui.add_html(as_html("density of states: computed with the "
                                                     "first picture"))
            place = gui.add_html("")  # where the density of states' plot goes
            self._density_order = place.order
            place.remove()
            self.density_plot = None
            self.m = gui.add_number("m (along x)", 1, step=1)
            self.n = gui.add_number("n (along y)", 1, step=1)
            self.amplitude = gui.add_number("Amplitude (a)", 0.2, step=0.05,
                                            hint="largest displacement, in lattice spacings")
            self.frequency = gui.add_html("")
            self.excite_button = gui.add_button(
                "Excite mode", icon=viser.Icon.WAVE_SINE,
                hint="the lattice at rest in its equilibrium with this mode alone displaced")
            self.message = gui.add_html("")
            self.download = add_csv_button(
                gui, "Download CSV", "the energy in every normal mode of every polarisation",
                lambda: host.runner.simulation.scene.name, self.csv, "mode-energies")

        def show_frequency(_: viser.GuiEvent) -> None:
            self._show_frequency()

        self.m.on_update(from_user(show_frequency))
        self.n.on_update(from_user(show_frequency))
        self.polarisation.on_update(from_user(show_frequency))

        @self.excite_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                self.excite()
            except (InputRefused, sim.ModelError, ValueError) as error:
                say(self.message, error, "could not excite")

    # --- values -------------------------------------------------------------------------------

    def _mode(self) -> tuple[int, int, int]:
        model = self.host.runner.simulation.model
        polarisation = POLARISATION_NAMES.index(
            choice(self.polarisation.value, "polarisation", list(POLARISATION_NAMES[: model.dim])))
        m = whole_number(self.m.value, "m", 1, model.nx)
        n = whole_number(self.n.value, "n", 1, model.ny)
        return m, n, polarisation

    def _show_frequency(self) -> None:
        model = self.host.runner.simulation.model
        if not model.uniform_mass:
            self.frequency.content = as_html("unequal masses: the modes are not sine waves")
            return
        if model.periodic:
            self.frequency.content = as_html("periodic rows: the modes are waves around the "
                                             "rings, not sine modes (m, n); the picture shows "
                                             "their energy against frequency")
            return
        try:
            m, n, polarisation = self._mode()
        except InputRefused as error:
            self.frequency.content = warning_html(str(error))
            return
        omega = mode_frequency(model, m, n, polarisation)
        text = (f"mode ({m}, {n}) {POLARISATION_NAMES[polarisation]}: ω = {omega:.4g} rad/s, "
                f"f = {omega / (2 * np.pi):.4g} Hz")
        if omega > 0:
            text += f", period {2 * np.pi / omega:.4g} s"
        self.frequency.content = as_html(text)

    def excite(self) -> None:
        """Post the command that puts the lattice in the chosen mode (checks every value)."""
        m, n, polarisation = self._mode()
        amplitude = number(self.amplitude.value, "amplitude", 0.0, 2.0, low_open=True)

        def command(simulation: sim.Simulation) -> None:
            model = simulation.model
            positions, velocities = excited_state(model, m, n, polarisation,
                                                  amplitude * model.spacing)
            simulation.positions[...] = positions
            simulation.velocities[...] = velocities
            simulation.state.dissipated = 0.0

        self.host.control.runner.post(command).result(timeout=30)
        self.message.content = ok_html(
            f"excited mode ({m}, {n}) {POLARISATION_NAMES[polarisation]} alone; press Play")

    # --- keeping in step ----------------------------------------------------------------------

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        names = list(POLARISATION_NAMES[: model.dim])
        self.polarisation.options = names
        self.excite_button.disabled = not model.uniform_mass or model.periodic
        self._last = 0.0
        self._basis = None  # the density of states is drawn again with the next picture
        self._show_frequency()
        self._show_density(None, "computed with the first picture")

    def _show_density(self, basis: ModalBasis | None, reason: str) -> None:
        """The density of states of the exact modes (all polarisations) as a small plot, or why
        there is none (the lattice too large to solve exactly, diagonal springs)."""
        if self.density_plot is not None:
            self.density_plot.remove()
            self.density_plot = None
        if basis is None:
            self.density_text.content = as_html(f"density of states: {reason}")
            return
        frequencies = np.sqrt(np.maximum(np.concatenate(
            [np.ravel(values) for values in basis.omega_squared]), 0.0))
        try:
            centres, density = density_from(frequencies, DENSITY_BINS)
        except sim.ModelError as error:
            self.density_text.content = as_html(f"density of states: {error}")
            return
        top = float(density.max()) * 1.1
        with ENTERING, self._folder:
            self.density_plot = self.host.server.gui.add_uplot(
                data=(centres, density), order=self._density_order, aspect=2.0,
                series=({"label": "ω (rad/s)"},
                        {"label": "modes per rad/s", "stroke": "#444444", "width": 1.5,
                         "fill": "rgba(68, 68, 68, 0.15)"}),
                padding=PADDING, scales={"x": {"time": False}, "y": {"range": [0.0, top]}},
                axes=({"label": "angular frequency ω (rad/s)"},
                      {"label": "modes per rad/s", "size": 50}))
        self.density_text.content = as_html(
            f"density of states: the {frequencies.size:,} exact normal-mode frequencies of this "
            f"lattice (every polarisation) in {DENSITY_BINS} bins up to "
            f"{float(frequencies.max()):.4g} rad/s")

    def _interval(self, model: sim.Model) -> float:
        return REFRESH_SECONDS * max(1.0, model.n_particles / 50_000)

    def csv(self) -> str:
        """The latest picture's numbers: each mode of each polarisation (its numbers m, n of
        half waves along x and y, or its index with unequal masses), its frequency (Hz) and
        energy (J)."""
        if self._table is None:
            return csv_text([("polarisation", ""), ("mode m", ""), ("mode n", ""),
                             ("frequency f", "Hz"), ("energy", "J")], [])
        model, basis, energies = self._table
        rows = []
        for component, energy in enumerate(energies):
            frequency = np.sqrt(np.maximum(
                np.broadcast_to(basis.omega_squared[component], energy.shape), 0.0)) / (2 * np.pi)
            for index in np.ndindex(energy.shape):
                m, n = (index[-1] + 1, index[0] + 1) if energy.ndim == 2 else (index[0] + 1, 0)
                rows.append((component, m, n, frequency[index], energy[index]))
        return csv_text([("polarisation (0 x, 1 y, 2 z)", ""), ("mode m", ""), ("mode n", ""),
                         ("frequency f", "Hz"), ("energy", "J")], rows)

    def update(self, frame: Frame, now: float) -> None:
        self.mode_shares.update(now)
        if now - self._last < self._interval(frame.model) or self._working.locked():
            return
        self._last = now
        threading.Thread(target=self._draw, args=(frame,), name="web-spectrum",
                         daemon=True).start()

    def _draw(self, frame: Frame) -> None:
        with self._working:
            try:
                model, positions, velocities = self.host.runner.post(
                    lambda simulation: (simulation.model,
                                        simulation.state.particle_positions().copy(),
                                        simulation.state.particle_velocities().copy())
                ).result(timeout=30)
                if self._basis is None or self._basis[0] != id(model):
                    try:
                        basis: ModalBasis | None = ModalBasis.of(model)
                        reason = ""
                    except sim.ModelError as error:
                        basis, reason = None, str(error)
                    self._basis = (id(model), basis, reason)
                    self._show_density(basis, reason)
                _, basis, reason = self._basis
                if basis is None:
                    self.message.content = as_html(f"no spectrum: {reason}")
                    return
                energies = mode_energies(model, positions, velocities, basis)
                self.last_energies = energies
                self._table = (model, basis, energies)
                polarisation = POLARISATION_NAMES.index(self.polarisation.value) \
                    if self.polarisation.value in POLARISATION_NAMES[: model.dim] else 0
                frequencies = None
                if not basis.separable:
                    frequencies = np.sqrt(np.maximum(basis.omega_squared[polarisation], 0.0))
                self.picture.image = render_spectrum(energies[polarisation], model, polarisation,
                                                     frequencies)
            except Exception as error:  # a failed picture must not stop the page
                self.message.content = as_html(f"no spectrum: {error}")
