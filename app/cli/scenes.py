"""``oscillators scenes``: list the presets with their parameters, default integrator and dt, and
the energy-balance error those defaults give over the scene's duration (predicted from the normal
modes, measured with ``--measure``)."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``scenes`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "scenes", help="list the preset scenes",
        description="The presets, their parameters, default integrator and dt, and the energy-"
        "balance error those defaults give over the scene's duration.",
    )
    parser.add_argument("--measure", action="store_true",
                        help="also run every preset for its duration and print the "
                        "measured error (about 15 s, the 682x383 lattice included)")
    parser.set_defaults(handler=command_scenes)


def command_scenes(arguments: argparse.Namespace) -> int:
    from app.study.choose_runs import RunTask, run_setting
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
            outcome = run_setting(RunTask(scene, scene.integrator, scene.dt, steps, "measure"))
            accuracy += (f", measured: blew up ({outcome.blew_up})" if outcome.blew_up else
                         f", measured energy error {100 * outcome.energy_error:.2g} %")
        print(f"{name:13s} {scene.description}")
        print(f"{'':13s} {scene.model.describe()}; default {scene.integrator}, dt={scene.dt:g} s, "
              f"{scene.duration:g} s worth watching; {accuracy} over that time")
    print("\nthe predicted error comes from the linearised lattice's normal modes (exact for "
          "linear scenes); --measure runs each preset to check it (the run and the energy error "
          "of `oscillators choose`; `choose SCENE --tolerance TOL` finds the cheapest setting).")
    print("override any parameter with --set key=value; see `oscillators run --help`.")
    return 0
