"""Rehearsals: a copy of a simulation run as a run would run it, to compile (or read from numba's
cache) every kernel the run calls, exactly as it calls them; the running simulation is not
touched.  ``rehearse`` runs the whole of it; on two cores or more ``rehearse_loop`` takes a share
in a second child beside it (the absorbing layer's action and the loops not made of the first
force pass), the two ordered by the signals of ``sim.runtime.children.call_in_child`` so that
neither compiles what the other does (``sim.runtime.warming.rehearse_reading``)."""

from __future__ import annotations

from typing import Any

from sim.runtime.children import signal_ready, wait_for_end


def rehearse(scene: Any, integrator: str, dt: float, precision: str, threads: int,
             steps: int, loop_done: int | None = None, layer_ready: int | None = None) -> None:
    """Run a copy of a simulation of ``scene`` as a run would: energy, ``steps`` steps, the
    energy balance and the strains.  A blow-up of the copy is no error here (the kernels were
    compiled on the way).

    Beside ``rehearse_loop`` (``rehearse_reading``, two children, the signals of
    ``sim.runtime.children.call_in_child``): first the stepper's first force pass, without and
    with the drive; then, once the other child has compiled the absorbing layer's action
    (``layer_ready``), the step loops made of that force pass (``Stepper.loop_shares_force_pass``:
    compiled here, they reuse its parts); then the energy, the blow-up rule's measures and the
    strains; then this waits for the other child to end (``loop_done``) and runs as above,
    reading everything from the cache."""
    from sim.runtime.simulation import BlowUpError, Simulation

    copy = Simulation(scene, integrator=integrator, dt=dt, precision=precision, threads=threads)
    if loop_done is not None:
        copy._integrator.first_forces(copy.state)
        _first_forces_driven(copy)
        if layer_ready is not None:
            wait_for_end(layer_ready)
        _loops(copy, steps, made_of_the_force_pass=True)
        copy.step(0)  # the energy and the balance's reference
        copy._problem()  # the blow-up rule's measures
        copy.strains()
        wait_for_end(loop_done)
    copy.energy()
    try:
        copy.step(max(1, int(steps)))
    except BlowUpError:
        pass
    copy.energy_balance_error()
    copy.strains()


def _loops(simulation: Any, steps: int, made_of_the_force_pass: bool) -> None:
    """The stepper's loops for each chunk a run of ``steps`` steps advances at a time, those
    made of the first force pass or the others, each started as if after that pass
    (``Stepper.assume_forces_of``)."""
    from sim.runtime.simulation import BlowUpError

    stepper = simulation._integrator
    for size in sorted(chunk_sizes(steps, simulation.chunk_steps), reverse=True):
        if stepper.loop_shares_force_pass(size) != made_of_the_force_pass:
            continue
        stepper.assume_forces_of(simulation.state)
        try:
            simulation._advance(size)
        except BlowUpError:
            return


def _first_forces_driven(simulation: Any) -> None:
    """The stepper's first force pass as ``Simulation._advance`` runs it before the loop, with
    the drive table armed (``Stepper.first_forces``)."""
    forcing, stepper = simulation._forcing, simulation._integrator
    if forcing is not None and forcing.drives and "drive" in stepper.in_step:
        stepper.drive = forcing.drive_table()
        stepper.first_forces(simulation.state)


def _layer(simulation: Any) -> None:
    """The absorbing layer's action as the stepper's loop calls it (with the loop's springs'
    parameters), so that the loop finds it compiled."""
    forcing, stepper = simulation._forcing, simulation._integrator
    if forcing is not None and forcing.has_sponge and "sponge" in stepper.in_step:
        layer = forcing.sponge_arrays(simulation.dt, stepper.dtype)
        layer.act(simulation.state, 0.0, stepper.kernel.parameters)


def _place(simulation: Any) -> None:
    """A prescribed particle placed, as ``Simulation._advance`` places it before the loop."""
    if simulation._forcing is not None:
        simulation._forcing.place(simulation.state)


def rehearse_loop(scene: Any, integrator: str, dt: float, precision: str, threads: int,
                  steps: int, layer_ready: int | None = None) -> None:
    """The other half of ``rehearse`` for a stepper with a first force pass of its own
    (``Stepper.assume_forces_of``), in a second child beside it: a prescribed particle's
    placing, the absorbing layer's action (the loops call the same kernel between steps), then
    ``layer_ready`` is signalled; then the energy and the step loops not made of the force pass
    (the leapfrog's fused sweep).  Nothing where the stepper has no such pass."""
    from sim.runtime.simulation import Simulation

    copy = Simulation(scene, integrator=integrator, dt=dt, precision=precision, threads=threads)
    if not copy._integrator.assume_forces_of(copy.state):
        return
    _place(copy)
    _layer(copy)
    if layer_ready is not None:
        signal_ready(layer_ready)
    copy.energy()
    _loops(copy, steps, made_of_the_force_pass=False)


def chunk_sizes(steps: int, chunk: int) -> set[int]:
    """The numbers of steps ``Simulation.step(steps)`` advances at a time (``step_shapes``)."""
    steps, chunk = max(1, int(steps)), max(1, int(chunk))
    return ({chunk} if steps >= chunk else set()) | ({steps % chunk} if steps % chunk else set())


