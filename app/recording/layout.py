"""Entity paths of a recording and the default blueprint (what the viewer shows on opening).

One *tree* per simulation: the root ``/`` for a single run, ``/<integrator>`` for each run of a
comparison.  ``docs/recording.md`` lists every entity; the paths are built here only.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import overload

from app.recording.rerun_lazy import rrb

SCENE_ENTITY = "/scene"
LEGEND_ENTITY = "/legend"
"""Colour-bar images: ``/legend/strain``, ``/legend/field``, ``/legend/height``."""
DEFAULT_TIMELINE = "sim_time"
"""The timeline the viewer opens on: simulated time in seconds (``step`` is the other one)."""
ENERGY_TERMS = ("kinetic", "potential", "total", "dissipated")
DRIVEN_TERM = "driven"
"""The driver's work (J), plotted with the energy terms when the scene has a driver."""
COMPONENT_NAMES = ("x", "y", "z")


def energy_terms(driven: bool) -> tuple[str, ...]:
    """The energy plot's lines: ``ENERGY_TERMS``, plus the driver's work when there is one."""
    return (*ENERGY_TERMS, DRIVEN_TERM) if driven else ENERGY_TERMS


def probe_label(column: int, row: int) -> str:
    """The entity name of the probe on particle (column, row): ``<column>_<row>``."""
    return f"{column}_{row}"


class _Entity:
    """A path below a tree's root: ``TreePaths(root).<name>`` is ``f"{root}/{tail}"``."""

    def __init__(self, tail: str, doc: str | None = None) -> None:
        self.tail = tail
        self.__doc__ = doc or f"``<root>/{tail}``"

    @overload
    def __get__(self, tree: None, owner: type) -> _Entity: ...

    @overload
    def __get__(self, tree: TreePaths, owner: type) -> str: ...

    def __get__(self, tree: TreePaths | None, owner: type) -> str | _Entity:
        return self if tree is None else tree.below(self.tail)


@dataclasses.dataclass(frozen=True)
class TreePaths:
    """Entity paths of one simulation's tree (``root`` is "" for a single run)."""

    root: str = ""

    def below(self, tail: str) -> str:
        return f"{self.root}/{tail}"

    lattice = _Entity("lattice")
    rest = _Entity("lattice/rest")
    anchors = _Entity("lattice/anchors")
    particles = _Entity("lattice/particles")
    springs = _Entity("lattice/springs")
    surface = _Entity("lattice/surface")
    sponge = _Entity("lattice/sponge", "The absorbing layer's inner edge, drawn in the lattice view.")
    driver = _Entity("lattice/driver", "The driven particle's rest position, marked in the lattice view.")
    field = _Entity("field")
    field_sponge = _Entity("field/sponge", "The absorbing layer's inner edge over the field image "
                           "(pixel coordinates).")
    drift = _Entity("drift")
    balance_error = _Entity("drift/energy_balance_error")
    log_balance_error = _Entity("drift/log10_abs_error")
    probes = _Entity("probes")
    spectra = _Entity("spectra")
    modes = _Entity("modes")
    energy = _Entity("energy")
    settings = _Entity("settings")
    dt = _Entity("settings/dt")
    integrator = _Entity("settings/integrator")
    model = _Entity("settings/model")
    field_scale = _Entity("colour_scale/field", "The field's colour-scale limit in use (m or m/s), "
                          "one value a frame.")
    log = _Entity("log")

    def probe(self, label: str, component: str) -> str:
        """Displacement component (x, y or z) of the probe ``label`` (``<column>_<row>``)."""
        return self.below(f"probes/{label}/{component}")

    def spectrum(self, label: str, component: str) -> str:
        """Amplitude spectrum of one probe's displacement component (logged at the end)."""
        return self.below(f"spectra/{label}/{component}")

    def mode_energy(self, polarisation: str) -> str:
        """Energy per normal mode of one polarisation, a tensor (J)."""
        return self.below(f"modes/{polarisation}/energy")

    def mode_share(self, mode: int) -> str:
        """Share of the harmonic energy in mode ``mode`` of a chain (``returns``: mode 1 back)."""
        return self.below(f"modes/shares/{mode}")

    @property
    def mode_shares(self) -> str:
        return self.below("modes/shares")

    def mode_image(self, polarisation: str) -> str:
        """The same energies as a log-colour heat map."""
        return self.below(f"modes/{polarisation}/image")

    def energy_term(self, term: str) -> str:
        return self.below(f"energy/{term}")


def whole_run() -> object:
    """A time series' x axis over the whole recording (a long run's lines whole, not a window)."""
    return rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(),
                                                 end=rrb.TimeRangeBoundary.infinite()))


def tree_paths(name: str | None) -> TreePaths:
    return TreePaths("" if not name else f"/{name}")


def instrument_views(
    trees: Sequence[str | None], *, probes: bool, modes: Sequence[str], shares: bool = False,
) -> list[rrb.View | rrb.Container]:
    """Views of the probes (displacement time series; their spectra, logged at the end) and of
    the mode energies (one log-colour heat map per polarisation; with ``shares``, a chain's
    lines of the shares of modes 1-4, mode 1's returns marked), per tree."""
    views: list[rrb.View | rrb.Container] = []
    for name in trees:
        paths = tree_paths(name)
        label = f"{name} " if name else ""
        if probes:
            views.append(rrb.Tabs(
                rrb.TimeSeriesView(origin=paths.probes, name=f"{label}probe displacement (m)"),
                rrb.BarChartView(origin=paths.spectra,
                                 name=f"{label}probe spectra (m against Hz, at the end)"),
            ))
        if shares:
            views.append(rrb.TimeSeriesView(
                origin=paths.mode_shares, name=f"{label}share of energy in modes 1-4",
                axis_y=rrb.ScalarAxis(range=(0.0, 1.0)), axis_x=whole_run()))
        for polarisation in modes:
            views.append(rrb.Spatial2DView(
                origin=paths.mode_image(polarisation),
                name=f"{label}energy per mode, {polarisation} (log colour)",
            ))
    return views


def blueprint(
    trees: Sequence[str | None], *, dim: int, show_lattice: bool, show_field: bool,
    legends: int = 1, probes: bool = False, modes: Sequence[str] = (), shares: bool = False,
) -> rrb.Blueprint:
    """Lattice (or field image) views beside the energy and energy-balance-error plots, the scene
    document, colour legend and event log; the time panel on ``DEFAULT_TIMELINE`` (seconds).
    With ``probes`` or ``modes`` (polarisation names) a row of instrument views goes under the
    lattice."""
    spatial = rrb.Spatial3DView if dim == 3 else rrb.Spatial2DView
    pictures: list[rrb.View] = []
    for name in trees:
        paths = tree_paths(name)
        label = f"{name} " if name else ""
        if show_field:
            pictures.append(rrb.Spatial2DView(origin=paths.field, name=f"{label}field"))
        if show_lattice:
            # Origin at the tree's root so the transform logged on `lattice` applies.
            pictures.append(
                spatial(origin=paths.root or "/", contents=[f"+ {paths.lattice}/**"],
                        name=f"{label}{'membrane' if dim == 3 else 'lattice'}")
            )
    if len(pictures) == 1:
        main: rrb.Container | rrb.View = pictures[0]
    else:
        main = rrb.Grid(*pictures)
    instruments = instrument_views(trees, probes=probes, modes=modes, shares=shares)
    if instruments:
        # a chain's share lines (first) get room to show a long run
        columns = [2.0 if shares and index == 0 else 1.0 for index in range(len(instruments))]
        main = rrb.Vertical(main, rrb.Horizontal(*instruments, column_shares=columns),
                            row_shares=[3, 2])

    if len(trees) == 1:
        paths = tree_paths(trees[0])
        energy: rrb.View | rrb.Container = rrb.TimeSeriesView(
            origin=paths.energy, name="energy (J)", axis_x=whole_run()
        )
        drift: rrb.View | rrb.Container = rrb.TimeSeriesView(
            origin=paths.drift, name="energy-balance error (%)", axis_x=whole_run())
        settings_plot = rrb.TimeSeriesView(origin=paths.settings, name="dt (s)")
        logs = rrb.TextLogView(origin=paths.log, name="events")
    else:
        energy = rrb.Tabs(
            *[
                rrb.TimeSeriesView(origin=tree_paths(name).energy, name=f"{name} energy (J)")
                for name in trees
            ],
        )
        # Euler's error grows by orders of magnitude: on a linear axis the others look flat, so
        # the first tab shows log10 |error in %| (-2 is 0.01 %), the second the signed error.
        drift = rrb.Tabs(
            rrb.TimeSeriesView(
                origin="/", name="log10 |energy-balance error (%)|",
                contents=[f"+ {tree_paths(name).log_balance_error}" for name in trees],
            ),
            rrb.TimeSeriesView(
                origin="/", name="energy-balance error (%)",
                contents=[f"+ {tree_paths(name).balance_error}" for name in trees],
            ),
        )
        settings_plot = rrb.TimeSeriesView(
            origin="/", name="dt (s)", contents=[f"+ {tree_paths(name).dt}" for name in trees]
        )
        logs = rrb.TextLogView(
            origin="/", name="events", contents=[f"+ {tree_paths(name).log}" for name in trees]
        )
    tabs: list[rrb.View] = [rrb.TextDocumentView(origin=SCENE_ENTITY, name="read me")]
    if legends:
        tabs.append(rrb.Spatial2DView(origin=LEGEND_ENTITY, name="colour legend"))
    side = rrb.Vertical(energy, drift, rrb.Tabs(*tabs, logs, settings_plot), row_shares=[3, 2, 3])
    return rrb.Blueprint(
        rrb.Horizontal(main, side, column_shares=[3, 2]),
        rrb.TimePanel(timeline=DEFAULT_TIMELINE, expanded=True),
        collapse_panels=False,
    )
