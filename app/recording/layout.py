"""Entity paths of a recording and the default blueprint (what the viewer shows on opening).

One *tree* per simulation: the root ``/`` for a single run, ``/<integrator>`` for each run of a
comparison.  ``docs/recording.md`` lists every entity; the paths are built here only.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import rerun.blueprint as rrb

SCENE_ENTITY = "/scene"
ENERGY_TERMS = ("kinetic", "potential", "total", "dissipated")
TERM_COLOURS = {  # RGB of each energy term's line
    "kinetic": (235, 100, 60),
    "potential": (70, 140, 235),
    "total": (235, 235, 235),
    "dissipated": (170, 150, 70),
}
INTEGRATOR_COLOURS = {  # RGB of each integrator's total-energy line in a comparison
    "euler": (230, 70, 70),
    "heun": (240, 170, 50),
    "verlet": (90, 200, 110),
    "rk4": (80, 150, 240),
}


@dataclasses.dataclass(frozen=True)
class TreePaths:
    """Entity paths of one simulation's tree (``root`` is "" for a single run)."""

    root: str = ""

    def _path(self, tail: str) -> str:
        return f"{self.root}/{tail}"

    @property
    def lattice(self) -> str:
        return self._path("lattice")

    @property
    def rest(self) -> str:
        return self._path("lattice/rest")

    @property
    def anchors(self) -> str:
        return self._path("lattice/anchors")

    @property
    def particles(self) -> str:
        return self._path("lattice/particles")

    @property
    def springs(self) -> str:
        return self._path("lattice/springs")

    @property
    def field(self) -> str:
        return self._path("field")

    @property
    def energy(self) -> str:
        return self._path("energy")

    def energy_term(self, term: str) -> str:
        return self._path(f"energy/{term}")

    @property
    def settings(self) -> str:
        return self._path("settings")

    @property
    def dt(self) -> str:
        return self._path("settings/dt")

    @property
    def integrator(self) -> str:
        return self._path("settings/integrator")

    @property
    def model(self) -> str:
        return self._path("settings/model")

    @property
    def field_scale(self) -> str:
        return self._path("settings/field_scale")

    @property
    def log(self) -> str:
        return self._path("log")


def tree_paths(name: str | None) -> TreePaths:
    return TreePaths("" if not name else f"/{name}")


def blueprint(
    trees: Sequence[str | None], *, dim: int, show_lattice: bool, show_field: bool
) -> rrb.Blueprint:
    """Lattice (or field image) views beside the energy plot, scene text and event log."""
    spatial = rrb.Spatial3DView if dim == 3 else rrb.Spatial2DView
    pictures: list[rrb.View] = []
    for name in trees:
        paths = tree_paths(name)
        label = f"{name} " if name else ""
        if show_field:
            pictures.append(rrb.Spatial2DView(origin=paths.field, name=f"{label}field"))
        if show_lattice:
            # Origin at the tree's root so the y flip logged on `lattice` (2-D) applies.
            pictures.append(
                spatial(origin=paths.root or "/", contents=[f"+ {paths.lattice}/**"],
                        name=f"{label}lattice")
            )
    if len(pictures) == 1:
        main: rrb.Container | rrb.View = pictures[0]
    else:
        main = rrb.Grid(*pictures)

    if len(trees) == 1:
        paths = tree_paths(trees[0])
        energy: rrb.View | rrb.Container = rrb.TimeSeriesView(
            origin=paths.energy, name="energy (J)"
        )
        settings_plot = rrb.TimeSeriesView(origin=paths.settings, name="dt, field scale")
        logs = rrb.TextLogView(origin=paths.log, name="events")
    else:
        energy = rrb.Tabs(
            rrb.TimeSeriesView(
                origin="/", name="total energy (J)",
                contents=[f"+ {tree_paths(name).energy_term('total')}" for name in trees],
            ),
            *[
                rrb.TimeSeriesView(origin=tree_paths(name).energy, name=f"{name} energy (J)")
                for name in trees
            ],
        )
        settings_plot = rrb.TimeSeriesView(
            origin="/", name="dt (s)", contents=[f"+ {tree_paths(name).dt}" for name in trees]
        )
        logs = rrb.TextLogView(
            origin="/", name="events", contents=[f"+ {tree_paths(name).log}" for name in trees]
        )
    side = rrb.Vertical(
        energy,
        rrb.Tabs(rrb.TextDocumentView(origin=SCENE_ENTITY, name="scene"), logs, settings_plot),
        row_shares=[3, 2],
    )
    return rrb.Blueprint(
        rrb.Horizontal(main, side, column_shares=[3, 2]),
        collapse_panels=False,
    )
