"""The page's "Probes" folder: selected particles' displacement against time, and its spectrum.

*Probe the selection* watches up to ``MAX_PROBES`` selected particles: a runner subscriber (in the
simulation thread, cheap: a few numbers per frame) appends their displacements to a
``sim.instruments.probes.ProbeSeries`` at every published frame; about twice a second the folder plots the
chosen component against time and its spectrum (amplitude against frequency), and lists the
dominant frequencies with the nearest normal modes of the lattice (equal masses).  A reset or a
new scene starts the series again and empties the plots at once.  The plots' value axes take the
SI prefix that keeps their ticks readable (``app.web.plots.LivePlot``).

*Hear the probes* renders the last seconds of the first one or two probes' chosen component as
sound (``sim.instruments.sound``: the motion sped up by a round factor, stereo for two) into an
``<audio controls>`` player with the WAV inline as a data URL, under the factor ("×500: 0.487 Hz
sounds as 244 Hz").  It is made on demand only; the player goes with a reset, a new scene, new
probes or Stop probing.  At ``SOUND_RATE`` for at most ``SOUND_SECONDS`` the WAV is at most
192 kB (256 kB as base64 in the page).
"""

from __future__ import annotations

import base64
import threading
from typing import Any

import numpy as np
import viser

import sim
from app.csv_table import csv_text
from app.web.downloads import add_csv_button
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, choice, from_user, ok_html, warning_html
from app.web.plots import LivePlot
from app.web.widgets import PlotAxis
from sim.instruments.probes import ProbeSeries, nearest_modes, spectrum, uniform_series
from sim.instruments.sound import (
    LEAST_SECONDS,
    MAX_CHANNELS,
    needed_simulated_seconds,
    probe_sound,
)
from sim.runtime.runner import Frame
from sim.theory.modes import POLARISATION_NAMES

MAX_PROBES = 4
"""Particles probed at once (one line each in the plots)."""
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")
REFRESH_SECONDS = 0.5
SOUND_RATE = 16000
"""Audio samples per second of the page's player (Hz): 8 kHz of sound, far above the tones."""
SOUND_SECONDS = 3.0
"""The most sound the player gets (s): with ``SOUND_RATE``, stereo, a 192 kB WAV."""


def shown_band(frequencies: np.ndarray, columns: list[np.ndarray]) -> tuple[np.ndarray, ...]:
    """The spectrum up to where it carries motion: frequencies (Hz) up to 1.5 times the highest
    one whose amplitude reaches 2 % of the largest (at least 8 bins), so a peak under 2 Hz is
    not drawn as a sliver at the left of a 0-50 Hz axis."""
    amplitudes = np.max(np.abs(np.array(columns)), axis=0)
    top = float(amplitudes.max()) if amplitudes.size else 0.0
    if top <= 0.0:
        return (frequencies, *columns)
    last = int(np.flatnonzero(amplitudes >= 0.02 * top)[-1])
    keep = max(8, int(np.searchsorted(frequencies, 1.5 * frequencies[last])) + 1)
    return (frequencies[:keep], *(column[:keep] for column in columns))


class ProbesFolder(Folder):
    name = "probes"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        self.series: ProbeSeries | None = None
        self._lock = threading.Lock()
        self._unsubscribe: Any = None
        self._last = 0.0
        self._gui = gui
        with gui.add_folder("Probes", expand_by_default=False):
            self.probe_button = gui.add_button(
                "Probe the selection", icon=viser.Icon.CHART_DOTS,
                hint=f"watch the selected particles (up to {MAX_PROBES}): displacement against "
                "time and its spectrum")
            self.clear_button = gui.add_button("Stop probing", icon=viser.Icon.X)
            self.component = gui.add_dropdown("Component", ["x", "y"], initial_value="y")
            self.text = gui.add_html(as_html("Select particles, then press Probe the selection."))
            self.hear_button = gui.add_button(
                "Hear the probes", icon=viser.Icon.VOLUME,
                hint="the last seconds of the probes' motion as sound, sped up into hearing "
                "(the first two probes: left and right)")
            self.player = gui.add_html("")
            scene = lambda: host.runner.simulation.scene.name  # noqa: E731
            self.series_download = add_csv_button(
                gui, "Download series CSV", "every probe's displacement against time", scene,
                self.series_csv, "probes")
            self.spectrum_download = add_csv_button(
                gui, "Download spectrum CSV", "the plotted spectrum of the chosen component",
                scene, self.spectrum_csv, "probe-spectra")
            self._heard_until: float | None = None
            """The series' last time when the player was made (None: no player)."""
            self.time_plot: LivePlot | None = None
            self.spectrum_plot: LivePlot | None = None
            self._plotted = False
            """Whether the plots show a series (so a restarted one empties them)."""
            self._plots_folder = gui.add_folder("Plots")

        @self.probe_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            selection = np.asarray(self.host.view.selection)
            if selection.size == 0:
                self.text.content = warning_html("select particles first (click one)")
                return
            self.start([int(p) for p in selection[:MAX_PROBES]])

        @self.clear_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self.stop()
            self.text.content = as_html("not probing")

        @self.component.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self._last = 0.0

        @self.hear_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self.hear()

    # --- probing -------------------------------------------------------------------------------

    def start(self, particles: list[int]) -> None:
        """Probe these particle indices from now on (replacing any earlier probes)."""
        self.stop()
        model = self.host.runner.simulation.model
        series = ProbeSeries(model, particles)
        with self._lock:
            self.series = series

        def receive(frame: Frame) -> None:
            with self._lock:
                current = self.series
            if current is None:
                return
            if frame.model is not current.model:  # a new scene: these probes mean nothing now
                return
            current.add(frame.time, frame.positions)

        self._unsubscribe = self.host.runner.subscribe(receive)
        count = len(particles)
        self._build_plots(count)
        rows = [f"{p} (column {p % model.nx}, row {p // model.nx})" for p in particles]
        self.text.content = ok_html("probing " + ", ".join(rows) + "; press Play")

    def stop(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        with self._lock:
            self.series = None
        self.clear_player()

    # --- hearing ---------------------------------------------------------------------------------

    def time_still_needed(self) -> str | None:
        """Why the run should go on past the scene's duration: the probes' series is shorter
        than ``LEAST_SECONDS`` of their sound need (``sim.instruments.sound``), or None."""
        with self._lock:
            series = self.series
        if series is None:
            return None
        try:
            component = POLARISATION_NAMES.index(
                choice(self.component.value, "component",
                       list(POLARISATION_NAMES[: series.model.dim])))
            times, displacements = series.samples()
            factor, frequency, needed = needed_simulated_seconds(
                times, displacements[:, :MAX_CHANNELS, component])
        except ValueError:  # too few samples, or no motion: nothing to wait for
            return None
        if times[-1] - times[0] >= needed:
            return None
        return (f"the run goes on past the scene's duration for the probes: {LEAST_SECONDS:g} "
                f"s of their sound (x{factor:g}: {frequency:.3g} Hz sounds as "
                f"{factor * frequency:.0f} Hz) need {needed:.4g} s of simulated time, "
                f"{times[-1] - times[0]:.4g} s so far; a faster Speed gets there sooner")

    def hear(self) -> None:
        """Put the sound of the first one or two probes' chosen component in the player."""
        with self._lock:
            series = self.series
        if series is None:
            self.player.content = warning_html("probe particles first (Probe the selection)")
            return
        try:
            component = POLARISATION_NAMES.index(
                choice(self.component.value, "component",
                       list(POLARISATION_NAMES[: series.model.dim])))
            times, displacements = series.samples()
            values = displacements[:, :MAX_CHANNELS, component]
            sound = probe_sound(times, values, rate=SOUND_RATE, longest=SOUND_SECONDS)
        except (InputRefused, ValueError) as error:
            self.player.content = warning_html(f"nothing to hear yet: {error}")
            self._heard_until = series.last_time
            return
        used = len(series.particles)
        which = ("probe 1" if used == 1 else
                 "probe 1 left, probe 2 right" + (f" (of {used} probes)" if used > 2 else ""))
        data = base64.b64encode(sound.wav).decode("ascii")
        self.player.content = (
            f'<audio controls src="data:audio/wav;base64,{data}" style="width: 100%"></audio>'
            + as_html(f"{sound.describe()}; {which}, {POLARISATION_NAMES[component]} motion"
                      + (f" (each second of sound needs {sound.factor:g} s of the run: probe "
                         "longer for a longer sound)" if sound.seconds < SOUND_SECONDS - 0.01
                         else "")))
        self._heard_until = float(times[-1])

    def clear_player(self) -> None:
        """No player (a reset, a new scene, new probes or none)."""
        self._heard_until = None
        if self.player.content:
            self.player.content = ""

    def _probes(self) -> tuple[Any, list[str]]:
        """The probed series (None: none) and each probe's name."""
        with self._lock:
            series = self.series
        if series is None:
            return None, []
        nx = series.model.nx
        return series, [f"probe {k + 1} (column {p % nx}, row {p // nx})"
                        for k, p in enumerate(series.particles)]

    def series_csv(self) -> str:
        """Every probe's displacement (m) of each component against simulated time (s)."""
        series, names = self._probes()
        if series is None:
            return csv_text([("simulated time t", "s")], [])
        times, displacements = series.samples()
        dim = series.model.dim
        columns = [("simulated time t", "s")] + [
            (f"{name} displacement {POLARISATION_NAMES[c]}", "m") for name in names
            for c in range(dim)]
        return csv_text(columns, (
            (time, *row.ravel()) for time, row in zip(times, displacements, strict=True)))

    def spectrum_csv(self) -> str:
        """The spectrum of the chosen component: frequency (Hz), each probe's amplitude (m)."""
        series, names = self._probes()
        if series is None or len(series.times) < 8:
            return csv_text([("frequency f", "Hz")], [])
        component = POLARISATION_NAMES.index(
            choice(self.component.value, "component",
                   list(POLARISATION_NAMES[: series.model.dim])))
        times, displacements = series.samples()
        amplitudes, frequencies = [], np.zeros(0)
        for k in range(len(names)):
            even, interval = uniform_series(times, displacements[:, k, component])
            frequencies, amplitude = spectrum(even, interval)
            amplitudes.append(amplitude)
        columns = [("frequency f", "Hz")] + [
            (f"{name} amplitude {POLARISATION_NAMES[component]}", "m") for name in names]
        return csv_text(columns, zip(frequencies, *amplitudes, strict=True))

    def _build_plots(self, count: int) -> None:
        for plot in (self.time_plot, self.spectrum_plot):
            if plot is not None:
                plot.handle.remove()
        with self._plots_folder:
            self.time_plot = LivePlot(
                self._gui, self._plots_folder,
                ({"label": "t (s)"}, *(
                    {"label": f"probe {k + 1}", "stroke": COLOURS[k], "width": 1.2}
                    for k in range(count))),
                PlotAxis("displacement", "m", "simulated time t (s)"), aspect=2.0)
            self.spectrum_plot = LivePlot(
                self._gui, self._plots_folder,
                ({"label": "f (Hz)"}, *(
                    {"label": f"probe {k + 1} amplitude", "stroke": COLOURS[k], "width": 1.2}
                    for k in range(count))),
                PlotAxis("amplitude", "m", "frequency f (Hz)"), aspect=2.0)
        self._plotted = False

    # --- keeping in step -------------------------------------------------------------------------

    def show_scene(self, simulation: sim.Simulation) -> None:
        self.stop()
        self.component.options = list(POLARISATION_NAMES[: simulation.model.dim])
        self.text.content = as_html("Select particles, then press Probe the selection.")

    def update(self, frame: Frame, now: float) -> None:
        with self._lock:
            series = self.series
        if self._heard_until is not None:
            last = None if series is None else series.last_time
            if last is None or last < self._heard_until:  # a reset: the old run's sound goes
                self.clear_player()
        if (self._plotted and series is not None and self.time_plot is not None
                and len(series.times) < 8):  # started again (a reset): the old lines go at once
            self.spectrum_plot.clear()  # the spectrum first: an empty time plot means both are
            self.time_plot.clear()
            self._plotted = False
        if now - self._last < REFRESH_SECONDS:
            return
        self._last = now
        if series is None or len(series.times) < 8 or self.time_plot is None:
            return
        try:
            component = POLARISATION_NAMES.index(
                choice(self.component.value, "component",
                       list(POLARISATION_NAMES[: series.model.dim])))
        except InputRefused as error:
            self.text.content = warning_html(str(error))
            return
        times, displacements = series.samples()
        values = displacements[:, :, component]
        self.time_plot.show(times, values.T)
        self._plotted = True
        columns = []
        lines = []
        frequencies = None
        for k in range(values.shape[1]):
            even, interval = uniform_series(times, values[:, k])
            frequencies, amplitudes = spectrum(even, interval)
            columns.append(amplitudes)
            peaks = series.dominant(k, component, count=2)
            described = []
            for frequency, _ in peaks:
                try:
                    near = nearest_modes(series.model, frequency)
                except sim.ModelError:  # periodic rows: their modes are not sine modes (m, n)
                    near = []
                described.append(f"{frequency:.4g} Hz" + (f" ≈ {near[0].describe()}" if near
                                                           else ""))
            lines.append(f"probe {k + 1}: " + ("; ".join(described) or "no motion"))
        if frequencies is not None:
            band = shown_band(frequencies, columns)
            self.spectrum_plot.show(band[0], band[1:])
        span = max(times[-1] - times[0], 1e-12)
        nyquist = 0.5 * (times.size - 1) / span
        self.text.content = as_html(
            "\n".join(lines) + f"\n(resolution {1 / span:.2g} Hz: longer runs resolve closer "
            f"frequencies; sampled at each frame, so motion above {nyquist:.3g} Hz folds back "
            "to lower frequencies: fewer steps per frame raise that limit)")
