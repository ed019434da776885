"""``oscillators bench``: parse the benchmark's options, run ``app.benchmark.measure`` and print
its numbers (steps per second, ratios to numpy and C, what each specialisation and instrument
costs) as tables, or as JSON with ``--json``."""

from __future__ import annotations

import argparse
import json
import sys
import textwrap

from app.benchmark import PARTS, measure
from app.cli import kernels
from app.cli.arguments import parse_overrides, positive_float, positive_int
from app.cli.commands import summary
from app.cli.limits import check_measurement_seconds


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``bench`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "bench", help=summary("bench"),
        description=textwrap.fill(
            "Benchmark the numba kernels against the same step in vectorised numpy and against "
            "hand-written C kernels (built with gcc into a cache directory; skipped with a note "
            "when there is no compiler), on the interference scene (682x383) by default: every "
            "integrator in float64 on one thread, Verlet and RK4 in float64/float32 on 1 and N "
            "threads with the ratio to C, what each specialisation buys, and what periodic "
            "rows, absorbing walls and a force driver cost. Prints the host and its vector "
            "width. --only runs some of these parts (--only instruments takes seconds).", 95),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="parts (--only):\n" + "\n".join(f"  {name:15s} {what}" for name, what in PARTS.items())
        + "\n\nexamples:\n  oscillators bench                       # everything (a few minutes)"
        "\n  oscillators bench --only instruments    # the instruments' cost, side by side"
        "\n  oscillators bench --seconds 1.5 --json  # the numbers as JSON",
    )
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--seconds", type=positive_float, default=2.0,
                        help="time to spend on each measurement (default 2 s)")
    parser.add_argument("--set", dest="overrides", action="append", metavar="KEY=VALUE")
    parser.add_argument("--threads", type=positive_int,
                        help="most threads to measure (default: 2, or 1 on one core)")
    parser.add_argument("--no-c", action="store_true", help="skip the C reference")
    parser.add_argument("--only", type=_parts, default=tuple(PARTS), metavar="PART,...",
                        help="run only these parts: " + ", ".join(PARTS) + " (default: all)")
    parser.add_argument("--json", action="store_true")
    parser.set_defaults(handler=command_bench, reads_cached_kernels=True)


def _parts(text: str) -> tuple[str, ...]:
    """The benchmark parts named in a comma-separated list, in the order they run."""
    names = {name.strip().lower() for name in text.split(",") if name.strip()}
    if not names or names - set(PARTS):
        raise argparse.ArgumentTypeError(
            f"expected parts from {', '.join(PARTS)} (comma-separated), got {text!r}")
    return tuple(name for name in PARTS if name in names)


def command_bench(arguments: argparse.Namespace) -> int:
    check_measurement_seconds(arguments.seconds)
    talk = sys.stderr if arguments.json else sys.stdout
    results = kernels.reading(  # the compiling child measures briefly, without C
        measure, talk, child={"seconds": 0.05, "c_reference": False},
        scene_name=arguments.scene, overrides=parse_overrides(arguments.overrides),
        seconds=arguments.seconds, threads=arguments.threads, c_reference=not arguments.no_c,
        parts=arguments.only,
    )
    if arguments.json:
        print(json.dumps(results, indent=2))
    else:
        print_table(results)
        _print_instruments(results.get("instruments"))
        _print_gpu(results.get("gpu"))
    return 0


def print_table(results: dict) -> None:
    """The numbers of ``measure`` as tables: integrators, precision and threads, specialisation."""
    host = results["host"]
    print(f"scene {results['scene']} ({results['lattice']} = {results['particles']:,} particles)")
    print(f"host: {host['cpu']}, {host['machine']}, {host['cores']} cores, "
          f"{host['vector_width_bits']}-bit vectors, python {host['python']}, numba {host['numba']}, "
          f"load average {host['load_average']:.1f}")
    if "inverse_sqrt" in host:
        print(host["inverse_sqrt"])
    if "integrators" in results:
        _print_integrators(results["integrators"])
    if "configurations" in results:
        _print_configurations(results)
    if results["c_reference_note"]:
        print(f"note: {results['c_reference_note']}")
    if results.get("specialisation"):
        _print_specialisation(results["specialisation"])


def _print_integrators(integrators: dict) -> None:
    print("\nfloat64, one thread")
    header = f"{'integrator':10s} {'kernel steps/s':>15s} {'Simulation.step':>16s} " \
             f"{'numpy steps/s':>14s} {'kernel/numpy':>13s}"
    print(header)
    print("-" * len(header))
    for name, row in integrators.items():
        print(f"{name:10s} {row['kernel_steps_per_second']:15.1f} "
              f"{row['simulation_steps_per_second']:16.1f} {row['numpy_steps_per_second']:14.2f} "
              f"{row['speedup_over_numpy']:12.1f}x")


def _print_configurations(results: dict) -> None:
    print(f"\nprecision and threads (ratio to C = Simulation.step / C kernel; "
          f"threads measured: {', '.join(map(str, results['threads']))})")
    header = f"{'integrator':10s} {'precision':9s} {'threads':>7s} {'kernel steps/s':>15s} " \
             f"{'Simulation.step':>16s} {'vs 1 thread':>11s} {'C steps/s':>10s} " \
             f"{'ratio to C':>11s}  C kernel"
    print(header)
    print("-" * len(header))
    for row in results["configurations"]:
        c_rate = f"{row['c_steps_per_second']:10.1f}" if "c_steps_per_second" in row else f"{'-':>10s}"
        ratio = f"{row['ratio_to_c']:10.2f}x" if "ratio_to_c" in row else f"{'-':>11s}"
        print(f"{row['integrator']:10s} {row['precision']:9s} {row['threads']:7d} "
              f"{row['kernel_steps_per_second']:15.1f} {row['simulation_steps_per_second']:16.1f} "
              f"{row['speedup_over_one_thread']:10.2f}x "
              f"{c_rate} {ratio}  {row.get('c_reference', '')}")
    c_gains = [f"{row['integrator']} {row['precision']} {row['c_speedup_over_one_thread']:.2f}x"
               for row in results["configurations"] if "c_speedup_over_one_thread" in row]
    if c_gains:
        print(f"the C kernel's own speed-up on {results['threads'][-1]} threads (what the memory "
              f"and cores allow): {', '.join(c_gains)}")


SPECIALISATION_WORDS = {
    "zero_gravity": "no gravity term (against a zero pull)",
    "zero_drag": "no drag term (against zero drag)",
    "zero_dashpot": "no dashpot term (against zero dashpots)",
    "inverse_mass_array": "a scalar 1/m (against an array)",
    "three_dimensional": "a planar kernel (against 3-D with z = 0)",
    "damped_gravity_compiled_out": "damped kernels: no gravity term (against the zero pull they run)",
}


def _print_specialisation(specialisation: dict) -> None:
    if specialisation:
        print("\nwhat each compile-time flag buys, alone (the specialised kernel's steps/s over "
              "the variant's; a flag is kept as a type where it buys >= 3 %):")
        for integrator, row in specialisation.items():
            rates = row["steps_per_second"]
            print(f"  {integrator}: specialised {rates['specialised']:.1f} steps/s")
            for name, gain in row["gain"].items():
                print(f"    {SPECIALISATION_WORDS.get(name, name):62s} {gain:.3f}x")


def _print_instruments(instruments: dict | None) -> None:
    if not instruments:
        return
    rates, costs = instruments["steps_per_second"], instruments["cost"]
    labels = {"periodic": "periodic rows",
              "absorbing": f"absorbing walls ({instruments.get('layer_width')}-particle layer)",
              "driven": "a force driver"}
    parts = [f"{labels[name]} {rates[name]:.1f} ({costs[name]:.2f}x the time)" for name in costs]
    print(f"\ninstruments (Verlet, Simulation.step steps/s): as is {rates['as_is']:.1f}; "
          + "; ".join(parts))


def _print_gpu(gpu: dict | None) -> None:
    if gpu is None:
        return
    if not gpu["found"]:
        print(f"\nGPU: none measured: {gpu['reason']}")
        return
    print(f"\nvelocity Verlet on the GPU ({gpu['device']}), Simulation.step steps/s")
    for precision in ("float64", "float32"):
        row = gpu[precision]
        print(f"  {precision}: GPU {row['cuda']:,.0f}, one CPU thread {row['cpu']:,.0f}, "
              f"ratio {row['ratio']:.2f}")
