"""The page's "Speed vs accuracy" folder: measure the integrators on the scene as it is now.

*Measure on this scene* runs the code of ``oscillators choose`` (``app.study.choose``) in
viser's thread pool on the scene's current state: the cheapest integrator and dt whose field and
energy errors over the scene's duration are within the tolerance (in %, like the Accuracy
folder's), verified by running it.  While it measures the button reads *Cancel the
measurement*: pressed, the measurement stops within a second (``app.web.choosing``).  The
folder shows every run's error against its wall time (full size in a modal) and the verified
setting, which *Apply the recommendation* sets exactly, as ordinary commands
(``app.web.choosing``, shared with the Accuracy folder's *Choose for me*).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import viser

from app.web.choosing import ChoiceCancelled, apply_choice, cancel_choice, choose_on_page
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, from_user, number, ok_html
from app.web.widgets import ERRORS, MATPLOTLIB_LOCK, say


class StudyFolder(Folder):
    name = "study"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._picture: np.ndarray | None = None
        self._recommendation: Any = None
        self._measuring = False
        gui = host.server.gui
        with gui.add_folder("Speed vs accuracy", expand_by_default=False):
            self.tolerance = gui.add_number(
                "Tolerance (%)", initial_value=1.0, step=0.1,
                hint="largest error over the scene's duration the chosen setting must meet, in "
                "both the field error (distance of the displacement field from a reference) and "
                "the energy-balance error",
            )
            self.button = gui.add_button(
                "Measure on this scene", icon=viser.Icon.CHART_LINE,
                hint="find the cheapest integrator and dt meeting the tolerance, verified by "
                "running it over the scene's duration (the same code as `oscillators choose`)",
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
            try:
                integrator, dt = apply_choice(host, self._recommendation)
            except (*ERRORS, ValueError) as error:
                say(self.text, error, "could not apply")
                return
            self.text.content = ok_html(f"now running {integrator} at dt = {dt:.4g} s")

        @self.button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # runs in viser's thread pool: it may take a while
            if self._measuring:  # the button reads "Cancel the measurement"
                if cancel_choice(host):
                    self.text.content = as_html("cancelling…")
                return
            try:
                tolerance = number(self.tolerance.value, "tolerance (%)", 0.0, 100.0,
                                   low_open=True) / 100
            except InputRefused as error:
                say(self.text, error)
                return
            self._measuring = True
            self.button.label = "Cancel the measurement"
            self.button.icon = viser.Icon.PLAYER_STOP
            try:
                self.measure(tolerance)
            except ChoiceCancelled:
                self.text.content = as_html("measurement cancelled")
            except Exception as error:  # a failed study must not take the page down
                say(self.text, error, "could not measure")
            finally:
                self._measuring = False
                self.button.label = "Measure on this scene"
                self.button.icon = viser.Icon.CHART_LINE

    def measure(self, tolerance: float) -> None:
        """Choose on the scene's current state (``app.study.choose``, the code of `oscillators
        choose`) and show every run's picture and the verified setting (``tolerance``: the
        relative error it must meet, a fraction)."""
        import imageio.v3 as imageio

        from app.study.choose_report import plot_choice

        choice = choose_on_page(self.host, tolerance, self.text)
        data = choice.as_dict()
        with tempfile.TemporaryDirectory() as folder:
            picture = Path(folder) / "work_precision.png"
            with MATPLOTLIB_LOCK:  # the Modes folder draws in another thread
                plot_choice(data, str(picture))
            image = imageio.imread(picture)
        self._picture = np.ascontiguousarray(image[..., :3])
        self.image.image = self._picture
        self.image.visible = True
        self.full_size.visible = True
        answer = choice.answer
        if answer is not None:
            self._recommendation = answer
            self.apply.visible = True
            self.text.content = as_html(
                f"Recommendation (verified by running it over {choice.duration:.4g} s): "
                f"{answer.describe()}; {choice.measure} error within {tolerance:.3g}"
                + (f" ({choice.note})" if choice.note else "") + ". Apply sets "
                "exactly this integrator and dt.", bold=True)
        else:
            self._recommendation = None
            self.apply.visible = False
            best = choice.best_reached
            self.text.content = as_html(
                f"Nothing met {tolerance:.3g} ({choice.measure} error)"
                + (f"; the best reached: {best.describe()}" if best else "") + ".", bold=True)
