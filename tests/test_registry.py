"""Adding an integrator touches ``sim/integrators/registry.py`` and nothing else: a throw-away method,
registered here and nowhere else, appears in the command line's ``--integrator`` choices, runs
from the command line, is offered by the web page's Method menu and is measured by the accuracy
sweep.  Its physics (bounded energy of a symplectic method) is checked in
``tests/test_precision_threads.py``.  A Runge-Kutta method is its Butcher table and one
registration: the accuracy sweep measures the order the table promises."""

from __future__ import annotations

import argparse

import pytest

import sim
from app.cli import argparse_adapter, build_parser, main
from sim.integrators import registry as integrators
from tests.helpers import free_port, wait_for
from tests.test_precision_threads import SymplecticEuler

NAME = "throwaway-euler"


@pytest.fixture
def throwaway():
    description = integrators.register(integrators.IntegratorDescription(
        name=NAME, label="throw-away symplectic Euler", short_label="throw-away", order=1,
        force_evaluations=1, stability_factor=2.0, stepper=SymplecticEuler, symplectic=True,
    ))
    try:
        yield description
    finally:
        integrators.unregister(NAME)
    assert NAME not in sim.INTEGRATORS


def _choices(parser: argparse.ArgumentParser, command: str, option: str) -> list[str]:
    sub = argparse_adapter.subcommands(parser)[command]
    action = next(a for a in argparse_adapter.options(sub) if option in a.option_strings)
    return list(action.choices)


def test_the_command_line_offers_and_runs_a_new_integrator(throwaway, capsys):
    parser = build_parser()
    assert NAME in _choices(parser, "run", "--integrator")
    assert NAME in _choices(parser, "accuracy", "--integrators")
    assert main(["run", "single", "--integrator", NAME, "--steps", "50", "--quiet"]) == 0
    capsys.readouterr()


def test_the_page_menu_offers_a_new_integrator(throwaway):
    from app.web.app import WebApp

    app = WebApp(sim.Simulation(sim.scenes.build("chain")), port=free_port())
    app.start()
    try:
        assert wait_for(lambda: app.view.last_positions is not None)
        assert NAME in app.panel.integrator.method.options
    finally:
        app.stop()


def test_the_accuracy_sweep_measures_a_new_integrator(throwaway):
    from app.study.accuracy import accuracy_study

    scene = sim.scenes.build("chain")
    study = accuracy_study(scene, dts=[0.02, 0.01], until=1.0, refine=False,
                           precisions=("float64",), minimum_seconds=0.0)
    measured = {run.integrator for run in study.runs}
    assert NAME in measured
    assert measured >= {"verlet", "rk4"}
    assert NAME in study.limits


def test_a_runge_kutta_method_is_one_table_and_one_registration():
    """The explicit midpoint method as a table, registered once: it runs from the command line
    and the accuracy sweep on the linearised chain (exact normal-mode reference) measures its
    order 2 (it shares Heun's compiled loops: two stages)."""
    from app.study.accuracy import accuracy_study
    from sim.integrators.butcher import ButcherTable

    name = "throwaway-midpoint"
    table = ButcherTable(label="throw-away midpoint", a=((0, 0), ("1/2", 0)), b=(0, 1),
                         c=(0, "1/2"))
    integrators.register(integrators.IntegratorDescription(
        name=name, label=table.label, short_label="midpoint", **integrators.runge_kutta(table),
    ))
    try:
        assert (sim.ORDERS[name], integrators.FORCE_EVALUATIONS[name]) == (2, 2)
        assert main(["run", "chain", "--integrator", name, "--steps", "20", "--quiet"]) == 0
        study = accuracy_study(sim.scenes.build("chain", linear=True), integrators=[name],
                               dts=[0.004, 0.002, 0.001], until=1.0, refine=False,
                               precisions=("float64",), minimum_seconds=0.0)
        assert study.reference.kind == "exact normal modes"
        assert study.orders[name] == pytest.approx(2.0, abs=0.1)
    finally:
        integrators.unregister(name)
