"""The page's "Speed vs accuracy" folder: measure the integrators on the scene as it is now.

*Measure on this scene* runs the study of ``oscillators accuracy`` (``app.study.accuracy``) in
viser's thread pool: every integrator at several dt against a reference solution, timed from the
scene's current state.  The folder shows the work-precision picture (full size in a modal) and the
recommendation, which *Apply the recommendation* sets as ordinary commands.  Lattices above
``STUDY_PARTICLE_LIMIT`` particles are left to the command line.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import viser

import sim
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, from_user, number, ok_html
from app.web.widgets import ERRORS, MATPLOTLIB_LOCK, say

STUDY_PARTICLE_LIMIT = 2_500
"""Largest lattice the page measures speed against accuracy on (bigger: use the CLI)."""


class StudyFolder(Folder):
    name = "study"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._picture: np.ndarray | None = None
        self._recommendation: tuple[str, float] | None = None
        gui = host.server.gui
        with gui.add_folder("Speed vs accuracy", expand_by_default=False):
            self.tolerance = gui.add_number(
                "Target error", initial_value=1e-3, min=1e-10, max=0.5, step=1e-4,
                hint="relative position error at the end of the run that the recommendation must meet",
            )
            self.button = gui.add_button(
                "Measure on this scene", icon=viser.Icon.CHART_LINE,
                hint="time every integrator at several dt against a reference solution "
                "(the same study as `oscillators accuracy`)",
            )
            self.text = gui.add_html("")
            self.image = gui.add_image(np.full((8, 8, 3), 255, np.uint8), visible=False)
            self.full_size = gui.add_button(
                "Open the picture full size", icon=viser.Icon.ARROWS_MAXIMIZE, visible=False)
            self.apply = gui.add_button(
                "Apply the recommendation", icon=viser.Icon.CHECK, visible=False,
                hint="switch to the recommended integrator and dt")

        @self.full_size.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            picture = self._picture
            if picture is None or event.client is None:
                return
            with event.client.gui.add_modal("Speed against accuracy on this scene") as modal:
                event.client.gui.add_image(picture, label="error against wall time")
                event.client.gui.add_button("Close").on_click(lambda _: modal.close())

        @self.apply.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            if self._recommendation is None:
                return
            integrator, dt = self._recommendation
            try:
                host.control.set_integrator(integrator).result(timeout=30)
                host.control.set_dt(dt).result(timeout=30)
            except ERRORS as error:
                say(self.text, error, "could not apply")
                return
            self.text.content = ok_html(f"now running {integrator} at dt = {dt:.4g} s")

        @self.button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # runs in viser's thread pool: it may take a while
            if self.button.disabled:
                return
            try:
                tolerance = number(self.tolerance.value, "target error", 1e-10, 0.5)
            except InputRefused as error:
                say(self.text, error)
                return
            self.button.disabled = True
            try:
                self.measure(tolerance)
            except Exception as error:  # a failed study must not take the page down
                say(self.text, error, "could not measure")
            finally:
                self.button.disabled = False

    def measure(self, tolerance: float) -> None:
        """Run the study on the scene's current state and show its picture and recommendation
        (``tolerance``: the relative position error the recommendation must meet)."""
        import imageio.v3 as imageio

        from app.study.accuracy import accuracy_study
        from app.study.accuracy_report import plot_work_precision

        scene = self.host.runner.post(sim.scenes.scene_from_simulation).result(timeout=30)
        if scene.model.n_particles > STUDY_PARTICLE_LIMIT:
            self.text.content = as_html(
                f"This lattice has {scene.model.n_particles:,} particles; the page measures up to "
                f"{STUDY_PARTICLE_LIMIT:,}. Run `oscillators accuracy` with this scene's file "
                "(Scene → Files → Download this scene) from the command line instead."
            )
            return
        total = [0]

        def progress(label: str) -> None:
            total[0] += 1
            self.text.content = as_html(f"measuring… run {total[0]}: {label}")

        study = accuracy_study(scene, tolerance=tolerance, progress=progress,
                               precisions=tuple(dict.fromkeys(("float64", scene.precision))))
        with tempfile.TemporaryDirectory() as folder:
            picture = Path(folder) / "work_precision.png"
            with MATPLOTLIB_LOCK:  # the Modes folder draws in another thread
                plot_work_precision(study, str(picture))
            image = imageio.imread(picture)
        self._picture = np.ascontiguousarray(image[..., :3])
        self.image.image = self._picture
        self.image.visible = True
        self.full_size.visible = True
        recommendation = study.recommendation
        if recommendation.integrator is not None and recommendation.dt is not None:
            self._recommendation = (recommendation.integrator, float(recommendation.dt))
            self.apply.visible = True
        else:
            self._recommendation = None
            self.apply.visible = False
        self.text.content = as_html(
            f"Recommendation: {recommendation.reason}. Wall times are of one whole run of each "
            f"configuration from the scene's state to T = {study.until:.4g} s of simulated time "
            "(compilation excluded).", bold=True)
