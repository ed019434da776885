"""The ``oscillators`` command: one entry point with subcommands.

    oscillators scenes                      list the presets and their parameters
    oscillators run SCENE --steps N         headless run with progress and an energy summary
    oscillators bench                       kernel speed against plain numpy (interference scene)
    oscillators serve [SCENE]               the web app (viser)
    oscillators record SCENE                a rerun .rrd recording
    oscillators accuracy / stability        the speed/accuracy study and stability map
    oscillators response / reflection       a driven scene's resonance curve; the absorbing
                                            walls' reflection against wavelength

Parameters of any scene can be overridden with ``--set key=value`` (repeatable), e.g.
``--set nx=40 --set gravity=9.81 --set damping=0.5``; a driver with
``--set driver=column=0,frequency=0.6,kind=force`` and absorbing walls with
``--set boundary=absorbing``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

import numpy as np

from sim.integrators import estimated_seconds

EPILOG = """examples:
  oscillators scenes
  oscillators run chain --integrator verlet --dt 0.01 --steps 2000
  oscillators run grid --set nx=40 --set ny=30 --duration 20
  oscillators run catenary --duration 30            # watch it settle under gravity
  oscillators run resonance --probe 0,0             # driven at its 3rd mode: the probe finds it
  oscillators run chain --set driver=column=0,frequency=0.6,amplitude=0.02,kind=force
  oscillators run grid --set nx=120 --set ny=1 --set boundary=absorbing --set sponge_width=20
  oscillators serve grid                            # the web app on http://127.0.0.1:8080
  oscillators bench --seconds 1                     # steps per second of every integrator

units are SI: metres, kilograms, seconds; stiffness in N/m, damping and drag in N s/m.

a driver (--set driver=...) takes column, row, direction (x, y, z), amplitude A (m), frequency
f (Hz), kind (force: A k sin 2 pi f t; displacement: A sin 2 pi f t), start and ramp (s);
boundary=absorbing adds a sponge sponge_width particles deep (sponge_sides=left,right,... or
auto) that takes waves out instead of reflecting them (docs/instruments.md).
"""


MAX_STEPS = 10**8
"""Most steps one command may plan (about 100 s of Verlet on the 5-particle chain)."""

MAX_ESTIMATED_SECONDS = 6 * 3600.0
"""Longest estimated wall time of a planned run; longer ones are refused before they start."""

class OneLineErrorParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr (exit code 2), not the usage
    block followed by the message."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (a time step, a duration, a scale)."""
    value = _number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive, finite number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1 (a count of steps, frames, particles)."""
    return bounded_int(1, None)(text)


def bounded_int(smallest: int, largest: int | None) -> Callable[[str], int]:
    """argparse type factory: a whole number in [smallest, largest] (largest None: no bound)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < smallest or (largest is not None and value > largest):
            span = f"at least {smallest}" if largest is None else f"from {smallest} to {largest}"
            raise argparse.ArgumentTypeError(f"must be {span}, got {text!r}")
        return value

    return parse


def describe_seconds(seconds: float) -> str:
    """``5400`` -> ``"1.5 hours"``: a wall time a person can read."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600),
                       ("minutes", 60)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def planned_steps(
    simulation: Any, steps: int | None = None, duration: float | None = None,
    runs: int = 1,
) -> int:
    """The number of steps a command will run: ``steps``, or ``duration / dt``, or the scene's
    duration.  Raises ValueError, naming the estimated run time, when the plan exceeds
    ``MAX_STEPS`` or ``MAX_ESTIMATED_SECONDS`` (``runs`` simulations are advanced together)."""
    dt = simulation.dt
    if steps is not None:
        count = float(steps)
        what = f"{steps} steps"
    else:
        seconds = duration if duration is not None else simulation.scene.duration
        count = max(1.0, round(seconds / dt))
        what = f"{seconds:g} s at dt = {dt:g} s is {count:.3g} steps"
    model = simulation.model
    wall = runs * estimated_seconds(count, model.n_particles, simulation.integrator)
    if count > MAX_STEPS or wall > MAX_ESTIMATED_SECONDS:
        raise ValueError(
            f"{what}: about {describe_seconds(wall)} of computing on {model.n_particles} "
            f"particles, over the limit of {MAX_STEPS:.0e} steps or "
            f"{describe_seconds(MAX_ESTIMATED_SECONDS)}; shorten the run or use a larger --dt"
        )
    return int(count)


def parse_overrides(pairs: Sequence[str] | None) -> dict[str, Any]:
    """``["nx=40", "gravity=9.81", "linear=true", "gravity=0,-9.81"]`` -> keyword arguments."""
    overrides: dict[str, Any] = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise ValueError(f"--set takes key=value, got {pair!r}")
        key, text = (part.strip() for part in pair.split("=", 1))
        if key == "driver":  # its own key=value list, read by sim.forcing.Driver
            overrides[key] = None if text.lower() in ("none", "off", "") else text
        elif key in ("boundary", "sponge_sides"):
            overrides[key] = text
        else:
            overrides[key] = _parse_value(text)
    return overrides


def _parse_value(text: str) -> Any:
    lowered = text.lower()
    if lowered in ("true", "yes", "on"):
        return True
    if lowered in ("false", "no", "off"):
        return False
    if "," in text:
        return tuple(float(part) for part in text.split(","))
    try:
        number = float(text)
    except ValueError:
        return text
    return int(number) if number.is_integer() and "." not in text and "e" not in lowered else number


class IntegratorChoices:
    """The registered integrators' names (``sim.integrators.ALL_INTEGRATORS``), read when
    argparse checks or lists them, so the CLI never keeps its own list."""

    def _names(self) -> Sequence[str]:
        from sim.integrators import ALL_INTEGRATORS

        return ALL_INTEGRATORS

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __iter__(self):
        return iter(tuple(self._names()))

    def __len__(self) -> int:
        return len(self._names())


def add_scene_arguments(parser: argparse.ArgumentParser, default_scene: str | None = None) -> None:
    """SCENE (preset name or scene file), --integrator, --dt, --precision, --threads,
    --set key=value."""
    if default_scene is None:
        parser.add_argument(
            "scene", help="preset name (see `oscillators scenes`) or a .toml or .zip scene file"
        )
    else:
        parser.add_argument(
            "scene", nargs="?", default=default_scene,
            help=f"preset name or a .toml or .zip scene file (default: {default_scene})",
        )
    parser.add_argument(
        "--integrator", choices=IntegratorChoices(),
        help="time integrator (default: the scene's)",
    )
    parser.add_argument("--dt", type=positive_float,
                        help="time step in seconds (default: the scene's)")
    parser.add_argument(
        "--precision", choices=("float64", "float32"),
        help="floating-point precision of the state and the kernels (default: the scene's, "
        "float64); float32 is faster, energies are still summed in float64",
    )
    parser.add_argument(
        "--threads", type=positive_int, default=1,
        help="threads the compiled sweeps run on, as row blocks (default: 1)",
    )
    parser.add_argument(
        "--set", dest="overrides", action="append", metavar="KEY=VALUE",
        help="override a scene parameter: nx, ny, spacing, mass, stiffness, rest_length, damping, "
        "drag, gravity (g or gx,gy[,gz]), linear, dim; repeatable",
    )


def scene_from_arguments(arguments: argparse.Namespace):
    """Build the Scene named by the parsed arguments (preset + overrides, or a file)."""
    from sim import scenes

    overrides = parse_overrides(arguments.overrides)
    if arguments.scene.endswith((".toml", ".zip")):
        scene = scenes.load_file(arguments.scene)
        if overrides:
            raise ValueError("--set applies to presets; edit the scene file instead")
    else:
        scene = scenes.build(arguments.scene, **overrides)
    return scene


def simulation_from_arguments(arguments: argparse.Namespace):
    from sim import Simulation

    scene = scene_from_arguments(arguments)
    return Simulation(
        scene, integrator=arguments.integrator, dt=arguments.dt,
        precision=getattr(arguments, "precision", None), threads=getattr(arguments, "threads", 1),
    )


# --- subcommands -----------------------------------------------------------------------------------


def command_scenes(arguments: argparse.Namespace) -> int:
    from sim import ModelError, Simulation, scenes
    from sim.prediction import predictor_for

    for name in scenes.names():
        scene = scenes.build(name)
        simulation = Simulation(scene)
        steps = int(round(scene.duration / scene.dt))
        try:
            prediction = predictor_for(simulation).predict(scene.integrator, scene.dt,
                                                           scene.duration)
            accuracy = f"predicted energy-balance error {100 * prediction.energy_error:+.2g} %"
            steps = prediction.steps
        except ModelError:  # driven or absorbing: no free-mode prediction
            accuracy = "driven or absorbing (no prediction)"
        if arguments.measure:
            simulation.step(steps)
            accuracy += f", measured {100 * simulation.energy_balance_error():+.2g} %"
        print(f"{name:13s} {scene.description}")
        print(f"{'':13s} {scene.model.describe()}; default {scene.integrator}, dt={scene.dt:g} s, "
              f"{scene.duration:g} s worth watching; {accuracy} over that time")
    print("\nthe predicted error comes from the linearised lattice's normal modes (exact for "
          "linear scenes); --measure runs each preset to check it.")
    print("override any parameter with --set key=value; see `oscillators run --help`.")
    return 0


def command_run(arguments: argparse.Namespace) -> int:
    from tqdm import tqdm

    from sim import BlowUpError

    simulation = simulation_from_arguments(arguments)
    steps = planned_steps(simulation, steps=arguments.steps, duration=arguments.duration)
    limit = simulation.stability()
    print(f"{simulation.scene.summary()}")
    print(f"integrator {simulation.integrator}, dt = {simulation.dt:g} s, {steps} steps; {limit}")
    start_energy = simulation.energy()
    chunk = max(1, steps // 200)
    probes = None
    if arguments.probe:
        from app.recording.instruments import check_probes, parse_probe
        from sim.observables import highest_frequency
        from sim.probes import ProbeSeries

        model = simulation.model
        try:
            pairs = check_probes([parse_probe(text) for text in arguments.probe], model)
        except ValueError as error:
            raise ValueError(f"--probe: {error}") from None
        particles = [row * model.nx + column for column, row in pairs]
        probes = ProbeSeries(model, particles, limit=steps + 1)
        probes.add(simulation.time, simulation.state.particle_positions())
        # sample four times per period of the fastest mode (twice the Nyquist rate)
        chunk = max(1, int(math.pi / (2 * highest_frequency(model) * simulation.dt)))
    started = time.perf_counter()
    status = 0
    with tqdm(total=steps, unit="step", disable=arguments.quiet, dynamic_ncols=True) as bar:
        done = 0
        try:
            while done < steps:
                n = min(chunk, steps - done)
                simulation.step(n)
                done += n
                bar.update(n)
                if probes is not None:
                    probes.add(simulation.time, simulation.state.particle_positions())
        except BlowUpError as error:
            bar.close()
            print(f"\nstopped: {error}", file=sys.stderr)
            status = 3
    elapsed = time.perf_counter() - started
    end_energy = simulation.energy()
    summary = {
        "scene": simulation.scene.name, "integrator": simulation.integrator, "dt": simulation.dt,
        "steps": simulation.step_count, "time": simulation.time, "wall_seconds": elapsed,
        "steps_per_second": simulation.step_count / elapsed if elapsed > 0 else None,
        "energy_start": start_energy.as_dict(), "energy_end": end_energy.as_dict(),
        "energy_balance_error": simulation.energy_balance_error(),
        "energy_scale": simulation.energy_scale(),
    }
    if probes is not None:
        summary["probes"] = _probe_report(probes)
    if arguments.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"ran {simulation.step_count} steps to t = {simulation.time:.4g} s in {elapsed:.2f} s "
              f"({summary['steps_per_second'] or 0:.0f} steps/s)")
        print(f"{'energy (J)':12s} {'start':>12s} {'end':>12s}")
        driven = simulation.model.driver is not None
        terms = ("kinetic", "spring", "gravity", "potential", "dissipated")
        for key in terms + (("driven",) if driven else ()) + ("total",):
            label = "driver work" if key == "driven" else key
            print(f"{label:12s} {start_energy[key]:12.6g} {end_energy[key]:12.6g}")
        balance_error = end_energy.balance - start_energy.balance
        kept = "kinetic + potential + dissipated" + (" - driver work" if driven else "")
        print(f"energy balance error: {summary['energy_balance_error']:+.3%} of the energy in play "
              f"({balance_error:+.3g} J of {summary['energy_scale']:.4g} J; {kept} should stay "
              "constant)")
        if driven:
            print(f"driver: {simulation.model.driver.describe()}")
        for probe in summary.get("probes", []):
            peaks = "; ".join(
                f"{peak['frequency']:.4g} Hz" + (f" ({peak['nearest_mode']})"
                                                 if peak["nearest_mode"] else "")
                for peak in probe["peaks"]
            ) or "no motion"
            print(f"probe particle {probe['particle']} (column {probe['column']}, row "
                  f"{probe['row']}), {probe['component']} motion: {peaks}")
    return status


def command_bench(arguments: argparse.Namespace) -> int:
    from app.bench import main as bench_main

    return bench_main(arguments)


def _probe_report(probes: Any) -> list[dict[str, Any]]:
    """Each probe's strongest motion component and its dominant frequencies, with the nearest
    normal mode (equal masses)."""
    from sim.modes import POLARISATION_NAMES
    from sim.probes import nearest_modes

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


# Subcommands implemented in other modules register themselves through `register(subparsers)`.
_PLUGIN_MODULES = ("app.web.serve", "app.recording.cli", "app.study.cli", "app.movie.cli")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineErrorParser(
        prog="oscillators",
        description="Coupled oscillators: watch waves emerge from a lattice of masses and springs.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")

    scenes_parser = subparsers.add_parser(
        "scenes", help="list the preset scenes",
        description="The presets, their parameters, default integrator and dt, and the energy-"
        "balance error those defaults give over the scene's duration.",
    )
    scenes_parser.add_argument("--measure", action="store_true",
                               help="also run every preset for its duration and print the "
                               "measured error (about 15 s, the 682x383 lattice included)")
    scenes_parser.set_defaults(handler=command_scenes)

    run_parser = subparsers.add_parser(
        "run", help="run a scene headless and print an energy summary",
        description="Run a scene without a viewer; prints progress and the energy account.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(run_parser)
    length = run_parser.add_mutually_exclusive_group()
    length.add_argument("--steps", type=positive_int,
                        help="number of steps (default: the scene's duration, see `scenes`)")
    length.add_argument("--duration", type=positive_float,
                        help="simulated seconds instead of --steps")
    run_parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    run_parser.add_argument(
        "--probe", action="append", metavar="I,J",
        help="record the displacement of the particle in column I, row J (from 0) and print the "
        "dominant frequencies of its motion with the nearest normal modes; repeatable",
    )
    run_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    run_parser.set_defaults(handler=command_run)

    bench_parser = subparsers.add_parser(
        "bench", help="steps per second of each integrator against plain numpy and C",
        description="Benchmark the numba kernels against the same step in vectorised numpy and "
        "against hand-written C kernels (built with gcc into a cache directory; skipped with a "
        "note when there is no compiler), on the interference scene (682x383) by default: "
        "every integrator in float64 on one thread, Verlet and RK4 in float64/float32 on 1 and "
        "N threads with the ratio to C, and what each specialisation buys. Prints the host and "
        "its vector width.",
    )
    bench_parser.add_argument("--scene", default="interference")
    bench_parser.add_argument("--seconds", type=positive_float, default=2.0,
                              help="time to spend on each measurement (default 2 s)")
    bench_parser.add_argument("--set", dest="overrides", action="append", metavar="KEY=VALUE")
    bench_parser.add_argument("--threads", type=positive_int,
                              help="most threads to measure (default: 2, or 1 on one core)")
    bench_parser.add_argument("--no-c", action="store_true", help="skip the C reference")
    bench_parser.add_argument("--json", action="store_true")
    bench_parser.set_defaults(handler=command_bench)

    for module_name in _PLUGIN_MODULES:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name and module_name.startswith(error.name):
                continue  # that part of the app is not installed yet
            raise
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    arguments = parser.parse_args(argv)
    if not getattr(arguments, "handler", None):
        parser.print_help()
        return 0
    from sim import ModelError, SceneError

    try:
        return int(arguments.handler(arguments) or 0)
    except (ModelError, SceneError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # unwritable output, missing directory, disk full
        print(f"error: {error.strerror or error}: {error.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return 2
    except MemoryError:
        print("error: not enough memory for this lattice; try a smaller nx/ny", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
