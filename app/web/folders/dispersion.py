"""The page's "Dispersion" folder: the band structure of the lattice as it is set, what the
integrator at its time step makes of it, and one chosen wave launched into the lattice.

The plot (a uPlot) draws omega (rad/s) of every branch (``sim.theory.bands``) against the
distance along the path Gamma-X-M-Gamma of the square lattice's zone, in units of pi / a (so X
is at 1, M at 2 and the path ends at 2 + sqrt 2; a chain: Gamma-X only), each branch's continuum
line omega = c |q| dashed and the frequency the integrator at the current dt turns it into
dotted (where that wave grows, the dotted line leaves the plot upwards).  The folder follows every
new scene, integrator and time step (it reads them from the frames: ``update``).

A uPlot's clicks do not reach the server, so a slider (position along the path) and a dropdown
(branch) choose one wave; it is drawn as a point on the plot and described in the text (its q
vector, wavelength, omega, phase and group velocity, and its numerical frequency).  *Launch this
wave* puts a wave packet of that q and branch into the lattice (``sim.scenes.packet``) and follows
it with a ``PacketTracker``: the measured group and phase speeds are shown beside the theory and
as a marker on the plot (the measured phase speed times |q|, with a short line of the measured
group speed's slope).  A reset or a new scene takes the measured marker away.  Every value the
page sends is checked; a refused one is said in red and the value in use shown again.
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import viser

import sim
from app.csv_table import csv_text
from app.web.downloads import add_csv_button
from app.web.host import Folder, PanelHost
from app.web.inputs import (
    InputRefused,
    amber_html,
    as_html,
    choice,
    from_user,
    number,
    ok_html,
    warning_html,
)
from app.web.plots import ENTERING, PADDING
from sim.runtime.runner import Frame
from sim.theory.bands import BandError, BandStructure, numerical_omegas
from sim.theory.wave_packet import WaveError, branch, polarisation_names

COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")
"""One colour per branch: its band, continuum and numerical lines share it."""
SAMPLES = 241
"""Points along the path."""
TRACK_SECONDS = 0.5
"""Seconds between two looks at the measured speeds."""
OFF_PLOT = 10.0
"""A growing wave's numerical line is drawn at this many times the plot's top: off the plot."""


def speed_pair(measured: dict) -> tuple[float | None, float | None]:
    """(group, phase) speed (m/s) from ``PacketTracker.speeds()`` (None: not measured yet)."""
    group, phase = measured.get("group_speed"), measured.get("phase_speed")
    return (None if group is None else float(group), None if phase is None else float(phase))


PRESS_PLAY = "press Play"
PLAYING = "it moves as the run plays"


def launch_refusal(model: sim.Model) -> str | None:
    """Why no packet of one wave vector can be launched on ``model`` (None: it can)."""
    try:
        branch(model, polarisation_names(model)[0])
    except WaveError as error:
        return str(error)
    return None


class DispersionFolder(Folder):
    name = "dispersion"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._gui = gui = host.server.gui
        self._lock = threading.RLock()
        self._shown_for: tuple[int, str, float] | None = None
        """(id of the model, integrator, dt) the plot shows."""
        self.structure: BandStructure | None = None
        self._data: list[np.ndarray] = []
        self._table: list[tuple[tuple[str, str], np.ndarray]] = []
        """The plotted lines as columns of ``csv`` ((name, unit), values)."""
        self._marker_index = -1
        self._measured: tuple[float | None, float | None] = (None, None)
        self._tracker: Any = None
        self._tracked: tuple[Any, str, float, float] | None = None
        """(model, branch, qx, qy) of the launched wave."""
        self._unsubscribe: Any = None
        self._last_look = 0.0
        self._last_time = -math.inf
        self._reset_seen = False
        self.plot: Any = None
        with gui.add_folder("Dispersion", expand_by_default=False) as self._folder:
            self.summary = gui.add_html("")
            place = gui.add_html("")  # where the plot goes (it is built in _draw)
            self._plot_order = place.order
            place.remove()
            self.position = gui.add_slider(
                "Position along Γ–X–M–Γ", 0.0, 1.0, 0.001, 0.15,
                hint="where on the path the chosen wave is: 0 at Γ, 1 back at Γ (a chain: at X)")
            self.branch = gui.add_dropdown("Branch", ["x"], initial_value="x",
                                           hint="which branch the chosen wave is on")
            self.point_text = gui.add_html("")
            self.launch_button = gui.add_button(
                "Launch this wave", icon=viser.Icon.WAVE_SINE,
                hint="put a wave packet of this q and branch into the lattice and measure "
                "its group and phase speed")
            self.launch_reason = gui.add_html("", visible=False)
            """Why the launch button is disabled (amber), when it is."""
            self.message = gui.add_html("")
            self.download = add_csv_button(
                gui, "Download CSV", "the plotted bands, continuum lines and numerical "
                "dispersion", lambda: host.runner.simulation.scene.name, self.csv, "dispersion")

        @self.position.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self._chosen_changed()

        @self.branch.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self._chosen_changed()

        @self.launch_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                self.launch()
            except InputRefused as error:
                self.message.content = warning_html(f"refused: {error}")
            except (ImportError, sim.ModelError, ValueError) as error:
                self.message.content = warning_html(f"could not launch: {error}")

    # --- the chosen wave -------------------------------------------------------------------------

    def _chosen(self) -> tuple[float, str]:
        """(position 0..1, branch) checked; a refused value raises ``InputRefused``."""
        structure = self.structure
        if structure is None:
            raise InputRefused("this lattice has no bands")
        fraction = number(self.position.value, "position", 0.0, 1.0)
        branch = choice(self.branch.value, "branch", list(structure.names))
        return fraction, branch

    def _chosen_changed(self) -> None:
        try:
            self._chosen()
        except InputRefused as error:
            self.message.content = warning_html(f"refused: {error}")
            self.position.value = min(max(self._safe_fraction(), 0.0), 1.0)
            if self.structure is not None and self.branch.value not in self.structure.names:
                self.branch.value = self.structure.names[0]
            return
        self.message.content = ""
        with self._lock:
            self._show_point()

    def _safe_fraction(self) -> float:
        value = self.position.value
        return float(value) if isinstance(value, int | float) and math.isfinite(value) else 0.15

    def chosen_wave(self) -> dict[str, float] | None:
        """The chosen wave (``BandStructure.wave``) and where it is on the plot (``x``)."""
        try:
            fraction, branch = self._chosen()
        except InputRefused:
            return None
        structure = self.structure
        assert structure is not None
        distance, qx, qy = structure.point(fraction)
        wave = structure.wave(branch, qx, qy)
        wave["x"] = distance * structure.spacing / math.pi
        return wave

    # --- launching -------------------------------------------------------------------------------

    def launch(self) -> None:
        """Post the command that puts a packet of the chosen wave into the lattice
        (``sim.scenes.packet``), and follow it with a tracker
        (``sim.instruments.packet_tracker``) when this build has one."""
        fraction, branch = self._chosen()
        from sim.scenes.packet import PacketSpec, launch_packet

        structure = self.structure
        assert structure is not None
        _, qx, qy = structure.point(fraction)
        if math.hypot(qx, qy) == 0.0:
            raise InputRefused("at Γ the wave has no wavelength: move along the path")
        spec = PacketSpec(qx, qy, branch)
        self.host.runner.post(lambda simulation: launch_packet(simulation, spec)).result(timeout=30)
        model = self.host.runner.simulation.model
        self._stop_tracking()
        said = ok_html(f"launched a packet on branch {branch} at q = ({qx:.4g}, {qy:.4g}) rad/m; "
                       + (PLAYING if self.host.runner.playing else PRESS_PLAY))
        try:
            from sim.instruments.packet_tracker import PacketTracker
        except ImportError:
            self.message.content = said + amber_html(
                "this build has no packet tracker: the speeds are not measured")
            return
        tracker = PacketTracker(model, spec)
        with self._lock:
            self._tracker, self._tracked = tracker, (model, branch, qx, qy)
            self._measured = (None, None)
            self._last_time = -math.inf

        def receive(frame: Frame) -> None:
            with self._lock:
                current = self._tracker
                if current is None or frame.model is not self._tracked[0]:
                    return
                if frame.time < self._last_time:  # a reset: the packet is gone
                    self._reset_seen = True
                    self._tracker = None
                    return
                self._last_time = frame.time
            current.add(frame.time, frame.positions)

        self._unsubscribe = self.host.runner.subscribe(receive)
        clear = getattr(tracker, "clear_time", None)
        if clear is not None and clear <= 0.0:
            said += amber_html("this packet is too wide for the lattice (it touches a wall from "
                               "the start): its speeds cannot be measured; a shorter wavelength "
                               "or a larger lattice can (the elastic-solid or interference "
                               "presets, or more particles in the Scene folder)")
        elif clear is not None:
            said += as_html(f"its speeds are measured until it nears a wall, {clear:.3g} s "
                            "after the launch")
        self.message.content = said

    def _stop_tracking(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        with self._lock:
            self._tracker = self._tracked = None
            self._measured = (None, None)

    # --- keeping in step -------------------------------------------------------------------------

    def show_scene(self, simulation: sim.Simulation) -> None:
        self._stop_tracking()
        self.message.content = ""
        self._follow(simulation.model, simulation.integrator, float(simulation.dt))

    def update(self, frame: Frame, now: float) -> None:
        self._follow(frame.model, frame.integrator, float(frame.dt))
        if self._reset_seen:
            self._reset_seen = False
            self._stop_tracking()
            self.message.content = as_html("reset: the launched packet and its measurement "
                                           "are gone")
            with self._lock:
                self._show_point()
            return
        if frame.playing and PRESS_PLAY in self.message.content:  # it plays now: say so
            self.message.content = self.message.content.replace(PRESS_PLAY, PLAYING)
        if self._tracker is None or now - self._last_look < TRACK_SECONDS:
            return
        self._last_look = now
        try:
            measured = speed_pair(self._tracker.speeds())
        except Exception as error:  # too few frames yet, or the packet is lost: say so
            self.message.content = amber_html(f"measuring the packet: {error}")
            return
        with self._lock:
            self._measured = measured
            self._show_point()

    def _follow(self, model: sim.Model, integrator: str, dt: float) -> None:
        """Draw the bands again if the lattice, the integrator or dt changed."""
        key = (id(model), integrator, dt)
        with self._lock:
            if key == self._shown_for:
                return
            self._shown_for = key
            try:
                self.structure = BandStructure(model)
            except BandError as error:
                self.structure = None
                self._remove_plot()
                self.summary.content = as_html(f"no bands: {error}")
                self.point_text.content = ""
                self.launch_button.disabled = True
                self.launch_reason.content = amber_html(f"Launch this wave: no bands: {error}")
                self.launch_reason.visible = True
                return
            reason = launch_refusal(model)
            self.launch_button.disabled = reason is not None
            self.launch_reason.content = amber_html(f"Launch this wave: {reason}") if reason \
                else ""
            self.launch_reason.visible = reason is not None
            names = list(self.structure.names)
            if list(self.branch.options) != names:
                self.branch.options = names
            if self.branch.value not in names:
                self.branch.value = names[0]
            self._draw(integrator, dt)

    def _remove_plot(self) -> None:
        if self.plot is not None:
            self.plot.remove()
            self.plot = None

    def csv(self) -> str:
        """The plot's lines: the position along the path (π/a) and each line's ω (rad/s)."""
        if not self._table:
            return csv_text([("wave vector q along the path Γ-X-M-Γ", "π/a")], [])
        headings = [heading for heading, _ in self._table]
        return csv_text(headings, zip(*(values for _, values in self._table), strict=True))

    def _draw(self, integrator: str, dt: float) -> None:
        """Build the plot for the current bands (a new uPlot in the plot's place)."""
        structure = self.structure
        assert structure is not None
        bands = structure.along_path(SAMPLES)
        scale = structure.spacing / math.pi
        x = bands.distance * scale
        series: list[dict] = [{"label": "q along path (π/a)"}]
        data = [x]
        table = [(("wave vector q along the path Γ-X-M-Γ", "π/a"), x)]
        top = float(np.max(bands.omega))
        numerical = [numerical_omegas(integrator, row, dt) for row in bands.omega]
        for found in numerical:
            if found is not None and found.stable.any():
                top = max(top, float(np.max(found.omega_numerical[found.stable])))
        top = 1.12 * top or 1.0
        for row, name in enumerate(bands.names):
            colour = COLOURS[row % len(COLOURS)]
            series.append({"label": name, "stroke": colour, "width": 2})
            data.append(bands.omega[row])
            table.append(((f"{name} ω", "rad/s"), bands.omega[row]))
            if np.isfinite(bands.continuum[row]).all():
                series.append({"label": f"{name} continuum", "stroke": colour, "width": 1,
                               "dash": (6.0, 4.0)})
                data.append(np.minimum(bands.continuum[row], OFF_PLOT * top))
                table.append(((f"{name} continuum ω", "rad/s"), bands.continuum[row]))
            found = numerical[row]
            if found is not None and not found.exact:
                series.append({"label": f"{name} by {integrator}", "stroke": colour,
                               "width": 1.5, "dash": (2.0, 3.0)})
                data.append(np.where(found.stable, found.omega_numerical, OFF_PLOT * top))
                table.append(((f"{name} ω by {integrator} at dt = {dt:g} s (nan: unstable)",
                               "rad/s"), np.where(found.stable, found.omega_numerical, np.nan)))
        self._table = table
        self._marker_index = len(data)
        series.append({"label": "chosen wave", "stroke": "#000000", "width": 0,
                       "points": {"show": True, "size": 10, "fill": "#000000"}})
        series.append({"label": "measured", "stroke": "#e6550d", "width": 2,
                       "points": {"show": True, "size": 8, "fill": "#e6550d"}})
        data += [np.full_like(x, np.nan), np.full_like(x, np.nan)]
        self._data = data
        corners = ", ".join(f"{label} at {distance * scale:.3g}" for label, distance in
                            bands.corners[1:])
        self._remove_plot()
        with ENTERING, self._folder:
            self.plot = self._gui.add_uplot(
                data=tuple(data), series=tuple(series), order=self._plot_order, aspect=1.3,
                padding=PADDING, scales={"x": {"time": False}, "y": {"range": [0.0, top]}},
                axes=({"label": "wave vector q along the path",
                       "splits": tuple(float(distance * scale) for _, distance in bands.corners),
                       "values": tuple(label for label, _ in bands.corners)},
                      {"label": "ω (rad/s)", "size": 50}),
            )
        unstable = [n for n, f in zip(bands.names, numerical, strict=True)
                    if f is not None and not f.stable.all()]
        if numerical and numerical[0] is None:
            how = f"{integrator}'s numerical dispersion is not known"
        elif numerical and numerical[0].exact:
            how = f"{integrator} has no time-step error: each wave keeps its frequency"
        else:
            how = f"dotted: the frequency {integrator} at dt = {dt:g} s gives each wave"
        text = (f"{structure.kind} lattice, branches {', '.join(bands.names)}; solid: ω(q), "
                f"dashed: continuum ω = c|q|; {how}. Path (units of π/a = {1 / scale:.3g} rad/m): "
                f"Γ at 0, {corners}.")
        content = as_html(text)
        if unstable:  # one assignment: a page (or a reader) never sees the text without it
            content += warning_html(
                f"at dt = {dt:g} s {integrator} makes the highest waves of "
                f"{', '.join(unstable)} grow (their dotted lines leave the plot)")
        self.summary.content = content
        self._show_point()

    def _show_point(self) -> None:
        """Put the chosen wave (and the measured marker) on the plot and describe it."""
        if self.plot is None or self.structure is None:
            return
        wave = self.chosen_wave()
        if wave is None:
            return
        data = list(self._data)
        x = data[0]
        index = int(np.argmin(np.abs(x - wave["x"])))
        marker = np.full_like(x, np.nan)
        marker[index] = wave["omega"]
        measured_line = np.full_like(x, np.nan)
        group, phase = self._measured
        text = (f"branch {self.branch.value}: q = ({wave['qx']:.4g}, {wave['qy']:.4g}) rad/m, "
                f"|q| = {wave['q']:.4g} rad/m, wavelength {wave['wavelength']:.4g} m\n"
                f"ω = {wave['omega']:.4g} rad/s (f = {wave['frequency']:.4g} Hz), phase speed "
                f"{wave['phase_speed']:.4g} m/s, group velocity ({wave['group_vx']:.4g}, "
                f"{wave['group_vy']:.4g}) m/s, |v_g| = {wave['group_speed']:.4g} m/s")
        frame_dt = self._shown_for[2] if self._shown_for else None
        integrator = self._shown_for[1] if self._shown_for else None
        if integrator is not None and frame_dt is not None:
            found = numerical_omegas(integrator, np.array([wave["omega"]]), frame_dt)
            if found is not None and not found.exact:
                if found.stable[0]:
                    text += (f"\n{integrator} at dt = {frame_dt:g} s runs it at "
                             f"{found.omega_numerical[0]:.4g} rad/s")
                else:
                    text += f"\n{integrator} at dt = {frame_dt:g} s makes it GROW"
        tracked = self._tracked
        if tracked is not None and (group is not None or phase is not None):
            _, branch, qx, qy = tracked
            size = math.hypot(qx, qy)
            theory = self.structure.wave(branch, qx, qy)
            text += (f"\nlaunched packet (branch {branch}, |q| = {size:.4g} rad/m): measured "
                     f"group speed {_speed(group)} (theory {theory['group_speed']:.4g} m/s), "
                     f"phase speed {_speed(phase)} (theory {theory['phase_speed']:.4g} m/s")
            if integrator is not None and frame_dt is not None:
                text += _integrator_speeds(integrator, frame_dt, theory)
            text += ")"
            launched = self._launched_index(qx, qy)
            if phase is not None and launched is not None:
                omega = phase * size
                measured_line[launched] = omega
                if group is not None and theory["group_speed"] > 0:
                    # the measured slope along the path: the theory's, scaled by measured/theory
                    slope = self._path_slope(x[launched], branch) \
                        * group / theory["group_speed"]
                    near = np.abs(x - x[launched]) <= 0.08
                    measured_line[near] = omega + slope * (x[near] - x[launched])
        data[self._marker_index] = marker
        data[self._marker_index + 1] = measured_line
        self.plot.data = tuple(data)
        self.point_text.content = as_html(text)

    def _launched_index(self, qx: float, qy: float) -> int | None:
        """The plot's sample nearest the launched wave vector (None: it is not on the path)."""
        structure = self.structure
        assert structure is not None
        _, path_x, path_y, _ = structure.path(SAMPLES)
        gaps = np.hypot(path_x - qx, path_y - qy)
        index = int(np.argmin(gaps))
        return index if gaps[index] <= 0.05 * math.pi / structure.spacing else None

    def _path_slope(self, at: float, branch: str) -> float:
        """d omega / d x (rad/s per pi/a) of ``branch`` along the plot at ``at`` (pi/a)."""
        structure = self.structure
        assert structure is not None
        _, qx, qy, _ = structure.path(SAMPLES)
        row = structure.omegas(qx, qy)[structure.branch(branch)]
        x = self._data[0]
        return float(np.interp(at, x, np.gradient(row, x)))


def _integrator_speeds(integrator: str, dt: float, theory: dict[str, float]) -> str:
    """What the integrator at ``dt`` makes of the wave ``theory`` (``BandStructure.wave``): its
    phase speed omega_num / |q| and group speed (d omega_num / d omega) |v_g| (m/s), as text
    ("" for a method without time-step error or one whose matrices are not known)."""
    omega, size = theory["omega"], theory["q"]
    step = 1e-6 * max(omega, 1e-12)
    found = numerical_omegas(integrator, np.array([omega, omega - step, omega + step]), dt)
    if found is None or found.exact or not found.stable.all():
        return ""
    turned = found.omega_numerical
    group = (turned[2] - turned[1]) / (2 * step) * theory["group_speed"]
    return f"; {integrator} at this dt: group {group:.4g} m/s, phase {turned[0] / size:.4g} m/s"


def _speed(value: float | None) -> str:
    return "not yet" if value is None else f"{value:.4g} m/s"
