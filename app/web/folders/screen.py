"""The page's "Screen" folder: the intensity along a column of the lattice, with the fringe theory.

Shown for scenes with sources.  The screen (``sim.instruments.screen.IntensityScreen``) watches the frames the
page draws (it never changes the state): <u^2> of the sources' displacement component along the
chosen column, averaged over the last ``PERIODS`` whole periods of the first source.  About once a
second a picture shows it against y (relative to its peak); for a scene with a slit barrier
(``sim.scenes.ripple_tank.SlitSetup``) the theory lines are drawn over it: two slits' maxima at
d sin(theta) = m lambda, one slit's minima at w sin(theta) = m lambda, theta from the slits'
centre, with the lattice's own wave vector at the driving frequency along each ray
(``sim.theory.slits``: d q_y = 2 pi m);
dots mark the measured extrema next to them (``app.study.slits.compare``).  For two point
sources in one column (two-sources) the lines are their maxima, d sin(theta) = (m - dphi / 2 pi)
lambda with dphi the phase difference, so they swing with the Sources folder's slider.  The chosen column is
drawn as a green line on the lattice.

A row of the screen counts only once the sources' full wave has reached it (``sim.theory.front``: the
lattice's group speed at the driving frequency along the path from the source, through the
slits), so before the front has passed the screen says when it will arrive instead of showing
<u²> of the transient.  The screen starts again when the sources or barriers change, the time
goes back (Reset) or the column changes; *Clear the screen* starts it again by hand.  Nothing
here posts a command.
"""

from __future__ import annotations

import io
import math
import threading

import numpy as np
import viser

import sim
from app.csv_table import csv_text
from app.study.slits import compare
from app.web.downloads import add_csv_button
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, from_user, ok_html, whole_number
from app.web.widgets import MATPLOTLIB_LOCK, say
from sim.instruments.screen import IntensityScreen
from sim.runtime.runner import Frame
from sim.scenes import ripple_tank
from sim.theory import front, lattice_waves, slits

PERIODS = 4
"""Whole periods the screen averages over."""
REFRESH_SECONDS = 1.0
"""Seconds between two pictures of the screen."""
MAXIMUM_COLOUR, MINIMUM_COLOUR, MEASURED_COLOUR = "#c0392b", "#7d3c98", "#1f4e79"


def render_screen(y: np.ndarray, intensity: np.ndarray | None, fringes: list[dict],
                  title: str, waiting: str = "waiting for a whole period ...") -> np.ndarray:
    """An RGB picture (height, width, 3) uint8: ``intensity`` (ny,) relative to its peak against
    ``y`` (ny,) m (NaN: a row not counted yet, left out), the theory lines of ``fringes``
    (``compare`` rows) dashed and labelled with their order m, the measured extrema as dots;
    ``waiting`` is said when nothing is measured yet."""
    with MATPLOTLIB_LOCK:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        figure = Figure(figsize=(4.4, 3.1), dpi=90)
        FigureCanvasAgg(figure)
        axis = figure.add_subplot()
        counted = intensity is not None and bool(np.any(np.isfinite(intensity)))
        peak = float(np.nanmax(intensity)) if counted else 0.0
        if peak > 0.0:
            axis.plot(y, intensity / peak, color=MEASURED_COLOUR, lw=1.6, label="measured <u²>")
        else:
            axis.text(0.5, 0.5, waiting, ha="center", va="center", wrap=True, fontsize=8,
                      transform=axis.transAxes)
        for index, fringe in enumerate(fringes):
            colour = MAXIMUM_COLOUR if fringe["kind"] == "maximum" else MINIMUM_COLOUR
            axis.axvline(fringe["theory_y"], color=colour, ls="--", lw=1.1,
                         label=f"theory {fringe['kind']}" if index == 0 else None)
            axis.text(fringe["theory_y"], 1.05, f"m={fringe['order']}", ha="center",
                      fontsize=7)
            if peak > 0.0 and fringe["measured_y"] is not None:
                at = int(np.argmin(np.abs(y - fringe["measured_y"])))
                axis.plot([fringe["measured_y"]], [intensity[at] / peak], "o", color=colour,
                          ms=4)
        axis.set_xlim(float(y[0]), float(y[-1]))
        axis.set_ylim(0.0, 1.14)
        axis.set_xlabel("y along the screen (m)")
        axis.set_ylabel("intensity / peak")
        axis.set_title(title, fontsize=8)
        if peak > 0.0 or fringes:
            axis.legend(fontsize=7, loc="upper right", framealpha=0.8)
        figure.tight_layout()
        buffer = io.BytesIO()
        figure.savefig(buffer, format="raw", dpi=90)
        width, height = figure.canvas.get_width_height()
        return np.frombuffer(buffer.getvalue(), np.uint8).reshape(height, width, 4)[..., :3].copy()


def drive_of(model: sim.Model) -> tuple[float, str] | None:
    """(frequency in Hz, displacement component) of the model's first source (or driver)."""
    drivers = ((model.driver,) if model.driver is not None else ()) + tuple(model.sources)
    if not drivers:
        return None
    direction = drivers[0].direction
    component = "xyz"[max(range(model.dim), key=lambda c: abs(direction[c]))]
    return drivers[0].frequency, component


def two_sources(model: sim.Model) -> tuple | None:
    """(lower, upper) when the model's sources are two point sources in one column at one
    frequency (the two-sources lesson), else None."""
    sources = tuple(model.sources)
    if model.driver is not None or len(sources) != 2 or any(s.row == "all" for s in sources):
        return None
    lower, upper = sorted(sources, key=lambda source: source.row)
    if lower.column != upper.column or lower.row == upper.row \
            or lower.frequency != upper.frequency:
        return None
    return lower, upper


class ScreenFolder(Folder):
    name = "screen"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self.screen: IntensityScreen | None = None
        self._watching: tuple | None = None
        """(sources, barriers, driver, column) the screen was made for."""
        self._theory: tuple[list, str] = ([], "")
        self._arrivals: np.ndarray | None = None
        """(ny,) time (s) the sources' full wave has reached each row of the screen, or None."""
        self._last = 0.0
        self._last_time = -math.inf
        self._working = threading.Lock()
        self.shown_fringes: list[dict] = []
        """The fringes of the last picture (theory and measured y, m)."""
        gui = host.server.gui
        self.folder = gui.add_folder("Screen", expand_by_default=True)
        with self.folder:
            self.picture = gui.add_image(np.full((8, 8, 3), 255, np.uint8))
            self.column = gui.add_number(
                "Screen column", 0, step=1,
                hint="the column whose time-averaged <u²> the screen shows")
            self.clear_button = gui.add_button(
                "Clear the screen", icon=viser.Icon.ERASER,
                hint="start the average again (it also starts again when the sources or the "
                "barrier change)")
            self.download = add_csv_button(
                gui, "Download CSV", "the screen's intensity along its column",
                lambda: host.runner.simulation.scene.name, self.csv, "screen")
            self.about = gui.add_html("")
            self.message = gui.add_html("")

        @self.column.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:  # changes what the page shows; posts nothing
            model = self.host.runner.simulation.model
            try:
                column = whole_number(self.column.value, "screen column", 0, model.nx - 1)
            except InputRefused as error:
                say(self.message, error, "refused")
                self.column.value = self.screen.column if self.screen else 0
                return
            self._watch(model, column)
            self.message.content = ok_html(f"the screen is column {column} now")

        @self.clear_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            if self.screen is not None:
                self.screen.reset()
            self._last = 0.0

    # --- the screen ---------------------------------------------------------------------------

    def _key(self, model: sim.Model, column: int) -> tuple:
        return (model.sources, model.barriers, model.driver, column)

    def _watch(self, model: sim.Model, column: int) -> None:
        """A new screen on ``column`` of ``model`` and its theory lines."""
        drive = drive_of(model)
        self._watching = self._key(model, column)
        self._last = 0.0
        if drive is None:
            self.screen = None
            self.about.content = as_html("No source: nothing to average over.")
            return
        frequency, component = drive
        self.screen = IntensityScreen(model, column, component, 1.0 / frequency, PERIODS)
        try:
            self._arrivals = front.arrival_times(model, column)
        except (lattice_waves.WaveError, ValueError):  # no wave speed: every row counts
            self._arrivals = None
        if self.column.value != column:
            self.column.value = column
        self._theory = self._theory_of(model, column, frequency, component)
        self._draw_line(model, column)

    def _theory_of(self, model: sim.Model, column: int, frequency: float,
                   component: str) -> tuple[list, str]:
        """(fringes, text) of the theory on ``column``."""
        try:
            wave = lattice_waves.polarisation(model, component)
            wavelength = wave.wavelength(2.0 * math.pi * frequency, 0.0)
            continuum = wave.long_wave_speeds()[0] / frequency
        except (lattice_waves.WaveError, sim.ModelError, ValueError) as error:
            return [], f"no wavelength: {error}"
        text = (f"λ = {wavelength:.3g} m from the lattice's dispersion at f = {frequency:.3g} Hz "
                f"(continuum c/f = {continuum:.3g} m)")
        try:
            setup = ripple_tank.SlitSetup.of(model)
            fringes = setup.theory(model, column)
        except (ripple_tank.SlitError, lattice_waves.WaveError) as error:
            two = two_sources(model)
            if two is None:
                return [], f"{text}; theory lines: {error}"
            return self._two_source_theory(model, column, wave, two, text)
        distance = model.origin[0] + column * model.spacing - setup.barrier_x
        law = ("maxima at d q_y = 2π m (d sin θ = m λ" if len(setup.openings) >= 2
               else "minima at w q_y = 2π m (w sin θ = m λ")
        return fringes, (f"{text}; lines: {law} with q the lattice's wave vector along the ray "
                         f"at θ from the slits' centre); screen {distance:.3g} m beyond the "
                         "barrier")

    @staticmethod
    def _two_source_theory(model: sim.Model, column: int, wave, pair, text: str
                           ) -> tuple[list, str]:
        lower, upper = pair
        a = float(model.spacing)
        distance = abs(column - lower.column) * a
        if distance == 0.0:
            return [], f"{text}; theory lines: the screen stands on the sources' column"
        difference = upper.phase - lower.phase
        fringes = slits.two_source_maxima_far_field(
            wave, 2.0 * math.pi * lower.frequency, (upper.row - lower.row) * a, distance,
            model.origin[1] + 0.5 * (upper.row + lower.row) * a,
            0.5 * (model.ny - 1) * a, difference)
        return fringes, (f"{text}; lines: maxima at d q_y = 2π m - Δφ (d sin θ = (m - Δφ/2π) λ "
                         f"with q the lattice's wave vector along the ray), Δφ = "
                         f"{math.remainder(difference, 2 * math.pi):.3g} rad of the upper source "
                         f"over the lower; screen {distance:.3g} m from the sources")

    def _draw_line(self, model: sim.Model, column: int) -> None:
        rest = np.asarray(model.rest_positions)
        ends = rest[[column, (model.ny - 1) * model.nx + column]]
        points = np.zeros((1, 2, 3), np.float32)
        points[0, :, : model.dim] = ends[:, : model.dim]
        points[0, :, 2] = 0.5 * float(model.spacing)
        self.host.server.scene.add_line_segments(
            "/screen_column", points=points, colors=(46, 125, 50), thickness=0.4 * float(model.spacing))

    # --- keeping in step ----------------------------------------------------------------------

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        shown = bool(model.sources or simulation.scene.model.sources)
        self.folder.visible = shown
        self.message.content = ""
        self._last_time = -math.inf
        if not shown:
            self.screen = None
            self._watching = None
            self.host.server.scene.add_line_segments(
                "/screen_column", points=np.zeros((1, 2, 3), np.float32), colors=(46, 125, 50),
                visible=False)
            return
        self._watch(model, ripple_tank.default_screen_column(model))

    def update(self, frame: Frame, now: float) -> None:
        if self._watching is None:
            return
        model = frame.model
        shown = self.host.runner.simulation.model
        if (model.nx, model.ny, model.dim) != (shown.nx, shown.ny, shown.dim):
            return  # a frame of the scene before
        column = self._watching[-1]
        if self._key(model, column) != self._watching:
            self._watch(model, column)
        screen = self.screen
        if screen is None:
            return
        if frame.time < self._last_time:
            screen.reset()  # a reset: the time went back
        self._last_time = frame.time
        screen.observe(frame.time, frame.positions)
        if now - self._last < REFRESH_SECONDS or self._working.locked():
            return
        self._last = now
        intensity = screen.intensity
        y = np.asarray(model.rest_positions[screen.rows, 1])
        counted, waiting = self.counted_rows(frame.time, screen)
        if intensity is not None:
            intensity = np.where(counted, intensity, np.nan)
        threading.Thread(target=self._draw,
                         args=(model, y, intensity, screen.whole_periods, waiting),
                         name="web-screen", daemon=True).start()

    def csv(self) -> str:
        """The screen now: each row's rest height y (m) and its time-averaged <u²> (m², nan
        where no wave has arrived yet, as the picture leaves it out)."""
        headings = [("y", "m"), ("time-averaged <u²>", "m²")]
        screen = self.screen
        intensity = None if screen is None else screen.intensity
        if intensity is None:
            return csv_text(headings, [])
        model = self.host.runner.simulation.model
        y = np.asarray(model.rest_positions[screen.rows, 1])
        counted, _ = self.counted_rows(self._last_time, screen)
        return csv_text(headings, zip(y, np.where(counted, intensity, np.nan), strict=True))

    def counted_rows(self, time: float, screen: IntensityScreen) -> tuple[np.ndarray, str]:
        """(rows whose average is counted, what the picture says while none is): a row counts
        once the sources' full wave had reached it before the averaged periods began (one period
        of margin), so the screen never shows <u²> of a wave that has not arrived."""
        rows = np.ones(screen.rows.size, bool)
        arrivals = self._arrivals
        if arrivals is None or arrivals.size != rows.size:
            return rows, "waiting for a whole period ..."
        began = time - (screen.whole_periods + 1) * screen.period
        counted = arrivals <= began
        first, last = float(arrivals.min()), float(arrivals.max())
        if time < first:
            waiting = (f"the wave front has not reached the screen yet:\nit arrives at "
                       f"t ≈ {first:.0f} s (its ends at {last:.0f} s);\n<u²> counts from then on")
        else:
            waiting = (f"the wave front reached the screen at t ≈ {first:.0f} s;\n"
                       "averaging over whole periods since ...")
        return counted, waiting

    def _draw(self, model: sim.Model, y: np.ndarray, intensity: np.ndarray | None,
              periods: int, waiting: str) -> None:
        with self._working:
            try:
                theory, text = self._theory
                whole = intensity is not None and bool(np.all(np.isfinite(intensity)))
                fringes = (compare(y, intensity, theory, model) if whole
                           else [{"order": f.order, "kind": f.kind, "theory_y": f.y,
                                  "measured_y": None, "difference": None} for f in theory])
                self.shown_fringes = fringes
                rows = "" if whole or intensity is None else ", rows reached"
                title = f"screen at column {self._watching[-1] if self._watching else '-'}: " \
                        f"<u²> over {periods} whole period{'s' if periods != 1 else ''}{rows}"
                self.picture.image = render_screen(y, intensity, fringes, title, waiting)
                if self.about.content != as_html(text):
                    self.about.content = as_html(text)
            except Exception as error:  # a failed picture must not stop the page
                self.message.content = as_html(f"no screen picture: {error}")
