"""What a folder of the page receives, and what it gives back.

The page's panel (``app.web.panel``) is a list of folders.  Each folder gets the app as a
``PanelHost``: the viser server whose GUI it builds in, the runner and the commands it may post,
the 3-D view (for the selection) and the app's few actions (select, redraw, replace the scene).
The panel then calls three methods of each folder, the ``Folder`` base class, and nothing else:

* ``show_scene(simulation)`` after a new lattice: show its values (assigning widget values posts
  nothing: callbacks act only on events a browser sent, ``app.web.inputs.from_user``);
* ``update(frame, now)`` for every frame drawn (``now``: ``time.perf_counter()`` seconds);
* ``selection_changed(selection, model)`` when the selected particles change.

A folder never imports the panel or the app: it talks to the app through ``PanelHost`` only.
"""

from __future__ import annotations

from typing import ClassVar, Protocol

import numpy as np
import viser

import sim
from app.web.control import LatticeRunner, SimulationControl
from app.web.recording import WebRecordings
from app.web.scene_files import SceneDirectory
from app.web.view import LatticeView
from sim.runtime.runner import Frame


class PanelHost(Protocol):
    """What the folders need of the web app (``app.web.app.WebApp`` provides it)."""

    server: viser.ViserServer
    runner: LatticeRunner
    control: SimulationControl
    view: LatticeView
    scene_files: SceneDirectory
    recordings: WebRecordings
    scene_source: str
    hold_while_dragging: bool

    def set_selection(self, indices: np.ndarray) -> None: ...

    def refresh(self) -> None: ...

    def replace_scene(self, scene: sim.Scene, source: str,
                      timeout: float = 120.0) -> sim.Simulation: ...


class Folder:
    """One folder of the page.  A subclass builds its widgets in ``__init__(host)`` and overrides
    the methods it needs; ``name`` is the panel's attribute for it (``panel.drive``)."""

    name: ClassVar[str]

    def show_scene(self, simulation: sim.Simulation) -> None:
        """Show a (new) simulation's values."""

    def update(self, frame: Frame, now: float) -> None:
        """Follow a frame that was just drawn."""

    def selection_changed(self, selection: np.ndarray, model: sim.Model) -> None:
        """Follow a new selection (particle indices row * nx + column)."""
