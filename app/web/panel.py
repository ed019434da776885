"""The GUI panel of the web app: the page's folders, built from one list.

``FOLDERS`` lists the folder classes in page order; each is one module of ``app.web.folders``
(adding a folder to the page is one new module and one entry here).  The panel builds them with
the app as their ``PanelHost`` and passes the app's news on to each: ``show_scene`` after a new
lattice, ``update(frame)`` for every frame drawn, ``selection_changed`` for a new selection.
A folder is reached as an attribute named after it (``panel.drive``).

The panel is a view of the app, and two rules keep every folder honest:

* viser runs a widget's ``on_update`` callbacks also when the server assigns ``.value``; every
  callback acts only on events a browser sent (``app.web.inputs.from_user``), so refreshing the
  panel never posts a command (showing a scene never changes it);
* the browser's min/max are hints: every value a page sends is checked on the server
  (``app.web.inputs``) and a bad one is refused with a red message, never clamped.

A folder that fails (while being built or while following the app) is reported in an amber line
at the top of the panel and on the server's standard error; the other folders and the simulation
go on.  The panel does not import the app.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import sim
from app.web.folders.accuracy import AccuracyFolder
from app.web.folders.barrier import BarrierFolder
from app.web.folders.description import DescriptionFolder
from app.web.folders.dispersion import DispersionFolder
from app.web.folders.drive import DriveFolder
from app.web.folders.energy import EnergyFolder
from app.web.folders.integrator import IntegratorFolder
from app.web.folders.lessons import LessonsFolder
from app.web.folders.measure import MeasureFolder
from app.web.folders.physics import PhysicsFolder
from app.web.folders.probes import ProbesFolder
from app.web.folders.recording import RecordingFolder
from app.web.folders.run import RunFolder
from app.web.folders.scene import SceneFolder
from app.web.folders.screen import ScreenFolder
from app.web.folders.selection import SelectionFolder
from app.web.folders.sources import SourcesFolder
from app.web.folders.spectrum import SpectrumFolder
from app.web.folders.study import StudyFolder
from app.web.folders.view_settings import ViewSettingsFolder
from app.web.host import Folder, PanelHost
from app.web.inputs import amber_html
from sim.runtime.runner import Frame

FOLDERS: tuple[type[Folder], ...] = (
    RunFolder,
    DescriptionFolder,
    LessonsFolder,
    SourcesFolder,
    BarrierFolder,
    ScreenFolder,
    MeasureFolder,
    SceneFolder,
    IntegratorFolder,
    AccuracyFolder,
    PhysicsFolder,
    SelectionFolder,
    SpectrumFolder,
    DispersionFolder,
    ProbesFolder,
    DriveFolder,
    ViewSettingsFolder,
    RecordingFolder,
    StudyFolder,
    EnergyFolder,
)
"""The page's folders, top to bottom."""


class ControlPanel:
    """Builds the folders of ``FOLDERS`` in ``host``'s GUI and keeps them in step with the app."""

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self.folders: dict[str, Folder] = {}
        self._failures: dict[str, str] = {}
        self.failures = host.server.gui.add_html("", visible=False)
        """The amber line naming the folders that failed."""
        for kind in FOLDERS:
            try:
                self.folders[kind.name] = kind(host)
            except Exception as error:  # the page goes on without this folder
                self._failed(kind.name, "could not be built", error)
        if "run" in self.folders and "probes" in self.folders:  # probing keeps the run going
            self.folders["run"].keep_going = self.folders["probes"].time_still_needed
        self.show_scene(host.runner.simulation)

    def __getattr__(self, name: str) -> Any:
        folders = self.__dict__.get("folders", {})
        if name in folders:
            return folders[name]
        raise AttributeError(f"the panel has no folder or attribute {name!r}")

    def _each(self, action: str, call: Callable[[Folder], None]) -> None:
        """``call`` every folder; one that raises is reported and the others go on."""
        for name, folder in self.folders.items():
            try:
                call(folder)
            except Exception as error:  # a failing folder must not take the page down
                self._failed(name, f"failed to {action}", error)

    def _failed(self, name: str, what: str, error: Exception) -> None:
        text = f"the {name} folder {what}: {error!r}"
        if self._failures.get(name) == text:
            return
        self._failures[name] = text
        print(f"web page: {text}", file=sys.stderr)
        self.failures.visible = True  # first: a reader who sees the text sees it shown
        self.failures.content = amber_html(
            "A part of the page stopped (the simulation goes on): "
            + "; ".join(self._failures.values()))

    def show_scene(self, simulation: sim.Simulation) -> None:
        """Show a (new) simulation's scene and parameters.  Assigning widget values posts no
        command (``from_user``), so the scene runs exactly as it was built or loaded."""
        self._each("show the scene", lambda folder: folder.show_scene(simulation))

    def update(self, frame: Frame) -> None:
        """Pass a frame that was just drawn to every folder; a frame of a run that waits for its
        kernels (``frame.preparing``) only to the Run folder, which says so (the plots and
        read-outs keep the last true values)."""
        now = time.perf_counter()
        if frame.preparing is not None:
            run = self.folders.get("run")
            try:
                if run is not None:
                    run.update(frame, now)
            except Exception as error:  # a failing folder must not take the page down
                self._failed("run", "failed to follow the run", error)
            return
        self._each("follow the run", lambda folder: folder.update(frame, now))

    def selection_changed(self, selection: np.ndarray) -> None:
        model = self.host.runner.simulation.model
        self._each("show the selection",
                   lambda folder: folder.selection_changed(selection, model))
