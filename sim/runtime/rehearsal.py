"""Rehearsals: a copy of a simulation run as a run would run it, to compile (or read from numba's
cache) every kernel the run calls, exactly as it calls them; the running simulation is not
touched.  ``rehearse`` runs the whole of it; ``rehearse_loop`` the step loop alone, in a second
child beside it, the two ordered by the signals of ``sim.runtime.children.call_in_child`` so that
neither compiles what the other does (``sim.runtime.warming.rehearse_reading``)."""

from __future__ import annotations

from typing import Any

from sim.runtime.children import signal_ready, wait_for_end


def rehearse(scene: Any, integrator: str, dt: float, precision: str, threads: int,
             steps: int, loop_done: int | None = None, forces_ready: int | None = None) -> None:
    """Run a copy of a simulation of ``scene`` as a run would: energy, ``steps`` steps, the
    energy balance and the strains.  A blow-up of the copy is no error here (the kernels were
    compiled on the way).

    Beside ``rehearse_loop`` (``rehearse_reading``, two children, the signals of
    ``sim.runtime.children.call_in_child``): first the stepper's first force pass (what the
    loop's own forces are made of), then ``forces_ready`` is signalled; then the same pass with
    the drive, the energy, the blow-up rule's measures and the strains; then this waits for
    ``loop_done`` (the loop's child has ended) and runs as above, reading the loop from the
    cache."""
    from sim.runtime.simulation import BlowUpError, Simulation

    copy = Simulation(scene, integrator=integrator, dt=dt, precision=precision, threads=threads)
    if loop_done is not None:
        copy._integrator.first_forces(copy.state)
        if forces_ready is not None:
            signal_ready(forces_ready)
        _first_forces_driven(copy)
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


def _first_forces_driven(simulation: Any) -> None:
    """The stepper's first force pass as ``Simulation._advance`` runs it before the loop, with
    the drive table armed (``Stepper.first_forces``)."""
    forcing, stepper = simulation._forcing, simulation._integrator
    if forcing is not None and forcing.drives and "drive" in stepper.in_step:
        stepper.drive = forcing.drive_table()
        stepper.first_forces(simulation.state)


def _place(simulation: Any) -> None:
    """A prescribed particle placed, as ``Simulation._advance`` places it before the loop."""
    if simulation._forcing is not None:
        simulation._forcing.place(simulation.state)


def rehearse_loop(scene: Any, integrator: str, dt: float, precision: str, threads: int,
                  steps: int, forces_ready: int | None = None) -> None:
    """What ``rehearse`` compiles of the step loop, without the stepper's first force pass
    (``Stepper.assume_forces_of``), in a second child beside it: first a prescribed particle's
    placing, the absorbing layer's action (the loop calls the same kernel between steps) and the
    energy, then the loop: a loop made of the force pass (``Stepper.loop_shares_force_pass``)
    once the first child has compiled that (``forces_ready``).  Nothing where the stepper has no
    such pass."""
    from sim.runtime.simulation import BlowUpError, Simulation

    copy = Simulation(scene, integrator=integrator, dt=dt, precision=precision, threads=threads)
    if not copy._integrator.assume_forces_of(copy.state):
        return
    _place(copy)
    if copy._forcing is not None:
        copy._forcing.sponge(copy.state, 0.0)
    copy.energy()
    for size in sorted(chunk_sizes(steps, copy.chunk_steps), reverse=True):
        if forces_ready is not None and copy._integrator.loop_shares_force_pass(size):
            wait_for_end(forces_ready)
            forces_ready = None
        copy._integrator.assume_forces_of(copy.state)
        try:
            copy._advance(size)
        except BlowUpError:
            return


def chunk_sizes(steps: int, chunk: int) -> set[int]:
    """The numbers of steps ``Simulation.step(steps)`` advances at a time (``step_shapes``)."""
    steps, chunk = max(1, int(steps)), max(1, int(chunk))
    return ({chunk} if steps >= chunk else set()) | ({steps % chunk} if steps % chunk else set())


