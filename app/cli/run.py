"""``oscillators run``: run a scene headless with a progress bar, then print its energy account
(J, start and end, and the balance error) and, with ``--probe I,J``, the dominant frequencies
(Hz) of probed particles with the nearest normal modes (with ``--sound PATH.wav`` their motion
as sound, ``sim.instruments.sound``), and with ``--packet QX,QY[,POL]`` a wave packet's measured
group and phase speeds against theory; ``--json`` prints the same as JSON.

Exit codes: 0 done, 2 bad input or nothing to hear for ``--sound`` (then the summary is still
printed, and no file written), 3 the run blew up (the summary is still printed).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import numpy as np

from app.cli import kernels
from app.cli.arguments import (
    EPILOG,
    add_length_arguments,
    add_scene_arguments,
    simulation_from_arguments,
)
from app.cli.commands import summary
from app.cli.limits import planned_steps
from app.cli.packets import PacketRun, add_packet_argument, print_packet
from app.cli.run_table import RunTable


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``run`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "run", help=summary("run"),
        description="Run a scene without a viewer; prints progress and the energy account.",
        epilog=EPILOG + SOUND_EXAMPLE, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser)
    add_length_arguments(parser, "number of steps (default: the scene's duration, see `scenes`)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument(
        "--probe", action="append", metavar="I,J",
        help="record the displacement of the particle in column I, row J (from 0) and print the "
        "dominant frequencies of its motion with the nearest normal modes; repeatable",
    )
    parser.add_argument(
        "--fields", metavar="PATH.npz",
        help="also save the displacement field of every particle at the run's sample times "
        "(those of `oscillators choose`'s errors: SAMPLES evenly spaced times, the last at the "
        "end) with the energy-balance error at each, as arrays times (s), fields (samples, dim, "
        "ny, nx) m and energy_balance_errors in a NumPy .npz file")
    add_packet_argument(parser)
    parser.add_argument(
        "--sound", metavar="PATH.wav",
        help="write the probes' motion as sound to this WAV file: the last seconds of the run "
        "sped up by a round factor that brings the dominant frequency to 190-475 Hz (one probe: "
        "mono; two: stereo, the first left); needs --probe")
    parser.add_argument(
        "--modes", type=int, metavar="K",
        help="measure the harmonic energy of the chain's modes 1..K over time and when the "
        "first mode's energy comes back (the FPU recurrence, docs/fput.md); a one-row chain of "
        "equal masses between walls only; default 8 on such a chain with the FPU spring law "
        "(the fput scene), 0 for none")
    parser.add_argument(
        "--csv", metavar="PATH.csv",
        help="write the energy account (J), the energy-balance error and the probes' "
        "displacements (m) at every sample time as a CSV table, each column's quantity and "
        "unit in its header")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing --sound or --csv file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=command_run, reads_cached_kernels=True)


SOUND_EXAMPLE = """
hearing a probe (docs/instruments.md, "Hearing a probe"):
  oscillators run chain --set linear=true --duration 600 --probe 2,0 --sound chain.wav
      # the chain's modes 1, 3 and 5 at x200 (1.332 Hz sounds as 266 Hz): the last 3 s
  oscillators run chain --set drag=0.01 --duration 600 --probe 2,0 --probe 0,0 --sound decay.wav
      # stereo, the middle particle left and the first right, dying away as exp(-0.005 t)
"""


def command_run(arguments: argparse.Namespace) -> int:
    from tqdm import tqdm

    from sim import BlowUpError
    from sim.runtime.blowup import CHECKS_PER_RUN

    sound = _check_sound(arguments)
    simulation = simulation_from_arguments(arguments)
    packet = PacketRun(simulation, arguments.packet) if arguments.packet else None
    duration = arguments.duration
    if packet is not None and arguments.steps is None and duration is None:
        duration = packet.duration()
    steps = planned_steps(simulation, steps=arguments.steps, duration=duration)
    fields = _Fields(arguments.fields, simulation, steps) if arguments.fields else None
    limit = simulation.stability()
    talk = sys.stderr if arguments.json else sys.stdout  # --json: stdout is the document alone
    print(f"{simulation.scene.summary()}", file=talk)
    print(f"integrator {simulation.integrator}, dt = {simulation.dt:g} s, {steps} steps; {limit}",
          file=talk)
    from sim.theory.hanging import hanging_problem

    hanging = hanging_problem(simulation.model)
    if hanging is not None:
        print(f"note: {hanging}", file=talk)
    start_energy = simulation.energy()
    chunk = max(1, steps // CHECKS_PER_RUN)
    probes = None
    table = RunTable(arguments.csv, arguments.force, simulation) \
        if arguments.csv and not arguments.probe else None
    if arguments.probe:
        from app.recording.instruments import check_probes, parse_probe
        from sim.instruments.probes import ProbeSeries
        from sim.theory.observables import highest_frequency

        model = simulation.model
        try:
            pairs = check_probes([parse_probe(text) for text in arguments.probe], model)
        except ValueError as error:
            raise ValueError(f"--probe: {error}") from None
        particles = [row * model.nx + column for column, row in pairs]
        probes = ProbeSeries(model, particles, limit=steps + 1)
        if arguments.csv:
            table = RunTable(arguments.csv, arguments.force, simulation, particles)
        probes.add(simulation.time, simulation.state.particle_positions())
        # sample four times per period of the fastest mode (twice the Nyquist rate)
        chunk = max(1, int(math.pi / (2 * highest_frequency(model) * simulation.dt)))
    if packet is not None:
        chunk = min(chunk, packet.chunk(simulation.dt))
    modes = _mode_shares(arguments.modes, simulation)
    if modes is not None:
        chunk = min(chunk, max(1, round(modes.period / modes.samples_per_period / simulation.dt)))
        _sample_modes(modes, simulation)
    kernels.prepare(simulation, chunk, talk)
    started = time.perf_counter()
    status = 0
    stopped = None
    with tqdm(total=steps, unit="step", disable=arguments.quiet, dynamic_ncols=True) as bar:
        done = 0
        try:
            while done < steps:
                n = min(chunk, steps - done, fields.next_step - done if fields else steps)
                simulation.step(n)
                done += n
                bar.update(n)
                if probes is not None:
                    probes.add(simulation.time, simulation.state.particle_positions())
                if table is not None:
                    table.add(simulation)
                if packet is not None:
                    packet.add(simulation)
                if modes is not None:
                    _sample_modes(modes, simulation)
                if fields is not None and done == fields.next_step:
                    fields.add(simulation, done)
                if done == steps and sound is not None and probes is not None:
                    # the run goes on while the probes' sound is shorter than it should be
                    steps += _sound_extension(arguments, simulation, probes, fields, packet,
                                              bar, talk)
        except BlowUpError as error:
            bar.close()
            stopped = str(error)
            print(f"stopped: {stopped}", file=sys.stderr)
            status = 3
    elapsed = time.perf_counter() - started
    end_energy = simulation.energy()
    summary = {
        "scene": simulation.scene.name, "integrator": simulation.integrator, "dt": simulation.dt,
        "steps": simulation.step_count, "time": simulation.time, "wall_seconds": elapsed,
        "steps_per_second": simulation.step_count / elapsed if elapsed > 0 else None,
        "energy_start": start_energy.as_dict(), "energy_end": end_energy.as_dict(),
        "energy_balance_error": simulation.energy_balance_error(),
        "energy_scale": simulation.energy_scale(), "blew_up": stopped,
    }
    if probes is not None:
        summary["probes"] = _probe_report(probes)
    refused = None
    if sound is not None:
        try:
            summary.update(_write_sound(probes, sound, arguments.force))
        except ValueError as error:  # nothing to hear: the run's summary is still printed
            refused = summary["sound_error"] = str(error)
    if fields is not None:
        summary["fields"] = fields.save()
    if table is not None:
        summary["csv"] = table.write()
    if packet is not None:
        summary.update(packet.report())
    if modes is not None:
        summary["modes"] = modes.report()
    if arguments.json:
        print(json.dumps(summary, indent=2))
    else:
        _print_summary(simulation, summary, start_energy, end_energy, elapsed)
    if refused is not None:
        print(f"error: {refused}", file=sys.stderr)
        status = status or 2
    return status


def _print_summary(simulation: Any, summary: dict[str, Any], start_energy: Any, end_energy: Any,
                   elapsed: float) -> None:
    """The run's summary as text: speed, the energy table, the balance error, the probes."""
    print(f"ran {simulation.step_count} steps to t = {simulation.time:.4g} s in {elapsed:.2f} s "
          f"({summary['steps_per_second'] or 0:.0f} steps/s)")
    print(f"{'energy (J)':12s} {'start':>12s} {'end':>12s}")
    driven = simulation.model.driven
    terms = ("kinetic", "spring", "gravity", "potential", "dissipated")
    for key in terms + (("driven",) if driven else ()) + ("total",):
        label = "driver work" if key == "driven" else key
        print(f"{label:12s} {start_energy[key]:12.6g} {end_energy[key]:12.6g}")
    balance_error = end_energy.balance - start_energy.balance
    kept = "kinetic + potential + dissipated" + (" - driver work" if driven else "")
    print(f"energy balance error: {summary['energy_balance_error']:+.3%} of the energy in play "
          f"({balance_error:+.3g} J of {summary['energy_scale']:.4g} J; {kept} should stay "
          "constant)")
    if simulation.model.driver is not None:
        print(f"driver: {simulation.model.driver.describe()}")
    for source in simulation.model.sources:
        print(f"source: {source.describe()}")
    for probe in summary.get("probes", []):
        peaks = "; ".join(
            f"{peak['frequency']:.4g} Hz" + (f" ({peak['nearest_mode']})"
                                             if peak["nearest_mode"] else "")
            for peak in probe["peaks"]
        ) or "no motion"
        print(f"probe particle {probe['particle']} (column {probe['column']}, row "
              f"{probe['row']}), {probe['component']} motion: {peaks}")
    if "packet" in summary:
        print_packet(summary)
    if "modes" in summary:
        _print_modes(summary["modes"])
    if "sound_file" in summary:
        print(f"sound: {summary['sound_file']}: {summary['sound_description']}")
    if "csv" in summary:
        print(f"table: {summary['csv']} ({len(summary.get('probes', []))} probe(s); the energy "
              "account and its balance error at every sample time)")


def _mode_shares(asked: int | None, simulation: Any) -> Any:
    """The ``ModeShares`` instrument ``--modes`` asks for (None: none; refused with one line
    where the lattice is not a chain it measures)."""
    from sim.forces import fpu
    from sim.instruments.mode_shares import ModeShares

    model = simulation.model
    if asked is None:
        chain = model.ny == 1 and model.uniform_mass and model.row_ends == "walls"
        asked = 8 if chain and fpu.TERM.present(model) else 0
    if asked < 0:
        raise ValueError(f"--modes must be 0 or more, got {asked}")
    if asked == 0:
        return None
    try:
        return ModeShares(model, asked)
    except ValueError as error:
        raise ValueError(f"--modes: {error}") from None


def _sample_modes(modes: Any, simulation: Any) -> None:
    state = simulation.state
    modes.add(simulation.time, state.particle_positions(), state.particle_velocities())


def _print_modes(report: dict[str, Any]) -> None:
    """Mode 1's lowest share and its returns, as lines."""
    from sim.instruments.mode_shares import AWAY_SHARE

    period = report["mode_period"]
    lowest = report["lowest_share"]
    if lowest["share"] >= AWAY_SHARE:
        print(f"mode 1 (period {period:.4g} s) kept at least {lowest['share']:.1%} of the "
              "harmonic energy throughout: it did not give its energy away")
        return
    print(f"mode 1 (period {period:.4g} s): its share of the harmonic energy fell to "
          f"{lowest['share']:.3f} at {lowest['periods']:.1f} periods")
    returns = report["recurrences"]
    if not returns:
        print("mode 1's energy has not come back yet (run longer: the first return of the fput "
              "chain is near 153 periods)")
    for number, back in enumerate(returns, 1):
        print(f"return {number}: {back['share']:.1%} of the energy back in mode 1 at "
              f"{back['periods']:.1f} periods (t = {back['time']:,.0f} s)")


def _probe_report(probes: Any) -> list[dict[str, Any]]:
    """Each probe's strongest motion component and its dominant frequencies, with the nearest
    normal mode (equal masses)."""
    from sim.instruments.probes import nearest_modes
    from sim.theory.modes import POLARISATION_NAMES

    model = probes.model
    displacements = probes.displacements
    report = []
    for index, particle in enumerate(probes.particles):
        component = int(np.argmax(displacements[:, index, :].std(axis=0)))
        peaks = []
        if len(probes.times) > 2:
            for frequency, amplitude in probes.dominant(index, component):
                near = nearest_modes(model, frequency)
                peaks.append({"frequency": frequency, "amplitude": amplitude,
                              "nearest_mode": near[0].describe() if near else None})
        row, column = divmod(particle, model.nx)
        report.append({"particle": particle, "column": column, "row": row,
                       "component": POLARISATION_NAMES[component], "peaks": peaks})
    return report


def _check_sound(arguments: argparse.Namespace) -> Any:
    """The --sound target, checked before anything runs (None without --sound)."""
    if not arguments.sound:
        return None
    from pathlib import Path

    from sim.instruments.sound import MAX_CHANNELS
    from sim.storage.files import check_target

    if not arguments.probe:
        raise ValueError("--sound needs --probe I,J (the particle to hear)")
    if len(arguments.probe) > MAX_CHANNELS:
        raise ValueError(f"--sound plays one or two probes (mono or stereo), got "
                         f"{len(arguments.probe)}: give at most two --probe")
    try:
        return check_target(Path(arguments.sound), arguments.force, suffix=".wav")
    except ValueError as error:
        raise ValueError(f"--sound: {error}") from None


def _sound_extension(arguments: argparse.Namespace, simulation: Any, probes: Any, fields: Any,
                     packet: Any, bar: Any, talk: Any) -> int:
    """Steps to run on so that the probes' sound lasts ``LEAST_SECONDS`` (0: it does); said in
    one line.  A run whose length the user gave (--duration, --steps, --fields, --packet) is
    not extended: a note says how long it would need, and its shorter sound is made."""
    from sim.instruments.sound import LEAST_SECONDS, needed_simulated_seconds

    times, values = _sound_series(probes)
    try:
        factor, frequency, needed = needed_simulated_seconds(times, values)
    except ValueError:
        return 0  # probe_sound says why there is nothing to hear
    have = float(times[-1] - times[0])
    if have >= needed * (1 - 1e-9):
        return 0
    start = simulation.time - have
    if (arguments.duration is not None or arguments.steps is not None or fields is not None
            or packet is not None):
        print(f"note: --sound: {LEAST_SECONDS:g} s of sound of the probes' {frequency:.4g} Hz "
              f"motion, played {factor:g} times faster, need {needed:.4g} s of simulated time; "
              f"this run has {have:.4g} s, which gives {have / factor:.2g} s (give --duration "
              f"{math.ceil(start + needed)} or more)", file=talk)
        return 0
    extra = max(1, math.ceil((needed - have) / simulation.dt - 1e-9))
    planned_steps(simulation, steps=simulation.step_count + extra)  # the same work limit
    probes.limit = max(probes.limit, simulation.step_count + extra + 1)
    bar.total += extra
    bar.refresh()
    print(f"--sound: {LEAST_SECONDS:g} s of sound of the probes' {frequency:.4g} Hz motion at "
          f"x{factor:g} need {needed:.4g} s of simulated time: running on to t = "
          f"{simulation.time + extra * simulation.dt:.4g} s", file=talk)
    return extra


def _sound_series(probes: Any) -> tuple[np.ndarray, np.ndarray]:
    """(times, the strongest component of each probe's displacement): what is heard."""
    displacements = probes.displacements
    strongest = displacements.std(axis=0).argmax(axis=1)  # (probes,) component of each
    return probes.times, displacements[:, np.arange(len(probes.particles)), strongest]


def _write_sound(probes: Any, path: Any, force: bool) -> dict[str, Any]:
    """Write the probes' sound (each probe's strongest component) to ``path`` atomically; the
    summary's sound entries."""
    from sim.instruments.sound import probe_sound
    from sim.storage.files import write_bytes

    times, values = _sound_series(probes)
    try:
        sound = probe_sound(times, values)
        written = write_bytes(path, sound.wav, overwrite=force)
    except ValueError as error:
        raise ValueError(f"--sound: {error}") from None
    return {"sound_file": str(written.resolve()), "sound_factor": sound.factor,
            "sound_seconds": sound.seconds, "sound_frequency": sound.frequency,
            "sound_description": sound.describe()}


class _Fields:
    """The displacement field and energy-balance error at the sample times of
    ``sim.runtime.errors.sample_steps``, saved to the ``--fields`` file (atomically) at the end."""

    def __init__(self, path: str, simulation: Any, steps: int) -> None:
        from pathlib import Path

        from sim.runtime.errors import sample_steps

        self.path = Path(path)
        if self.path.suffix != ".npz":
            raise ValueError(f"--fields {path}: give a file name ending in .npz")
        if not self.path.parent.is_dir():
            raise ValueError(f"--fields {path}: the directory {self.path.parent} does not exist")
        if self.path.is_dir() or self.path.is_symlink():
            raise ValueError(f"--fields {path}: give a plain file name")
        self.model = simulation.model
        self.steps = sample_steps(steps)
        self.next_step = self.steps[0]
        self.times: list[float] = []
        self.fields: list[np.ndarray] = []
        self.errors: list[float] = []

    def add(self, simulation: Any, done: int) -> None:
        from sim.runtime.errors import displacement

        self.times.append(simulation.time)
        self.fields.append(displacement(self.model, simulation.state.positions))
        self.errors.append(simulation.energy_balance_error())
        later = [step for step in self.steps if step > done]
        self.next_step = later[0] if later else -1

    def save(self) -> str:
        import os
        import tempfile

        handle, temporary = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".npz",
                                             dir=self.path.parent)
        try:
            with os.fdopen(handle, "wb") as stream:
                np.savez(stream, times=np.array(self.times), energy_balance_errors=np.array(
                    self.errors), fields=np.array(self.fields))
            os.replace(temporary, self.path)
        except BaseException:
            os.unlink(temporary)
            raise
        return str(self.path.resolve())
