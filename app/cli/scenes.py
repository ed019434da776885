"""``oscillators scenes``: list the presets with their parameters, default integrator and dt, and
the energy-balance error those defaults give over the scene's duration (predicted from the normal
modes); ``--measure`` also runs the defaults and asks ``app.study.choose`` (the code of
`oscillators choose`) for the cheapest verified setting meeting ``--tolerance``."""

from __future__ import annotations

import argparse

from app.cli.arguments import positive_float
from app.cli.commands import summary


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``scenes`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "scenes", help=summary("scenes"),
        description="The presets, their parameters, default integrator and dt, and the energy-"
        "balance error those defaults give over the scene's duration.",
    )
    parser.add_argument("names", nargs="*", metavar="PRESET",
                        help="only these presets (default: all)")
    parser.add_argument("--measure", action="store_true",
                        help="also run each preset's defaults for its duration (measured energy "
                        "error) and choose the cheapest verified setting meeting --tolerance, as "
                        "`oscillators choose` does (a minute or two for the 682x383 lattice)")
    parser.add_argument("--tolerance", type=positive_float, default=0.01, metavar="TOL",
                        help="tolerance of the choice with --measure (default 0.01)")
    parser.set_defaults(handler=command_scenes, reads_cached_kernels=True)


def command_scenes(arguments: argparse.Namespace) -> int:
    from sim import ModelError
    from sim.scenes import building as scenes
    from sim.theory.prediction import predictor_for_scene

    names = arguments.names or scenes.names()
    unknown = [name for name in names if name not in scenes.names()]
    if unknown:
        raise ValueError(f"unknown preset {unknown[0]!r}; choose from: {', '.join(scenes.names())}")
    if arguments.measure:
        from app.cli.choose import format_choice
        from app.study.choose import choose
        from app.study.choose_runs import RunTask, run_setting
    for name in names:
        scene = scenes.build(name)
        steps = int(round(scene.duration / scene.dt))
        try:
            predictor = predictor_for_scene(scene.model, scene.initial_positions,
                                            scene.initial_velocities, compiled=False)
            prediction = predictor.predict(scene.integrator, scene.dt, scene.duration)
            accuracy = f"predicted energy-balance error {100 * prediction.energy_error:+.2g} %"
            steps = prediction.steps
        except ModelError:  # driven, absorbing or coupled x and y: no free-mode prediction
            accuracy = "driven, absorbing or with diagonal springs (no prediction)"
        if arguments.measure:
            outcome = run_setting(RunTask(scene, scene.integrator, scene.dt, steps, "measure"))
            accuracy += (f", measured: blew up ({outcome.blew_up})" if outcome.blew_up else
                         f", measured energy error {100 * outcome.energy_error:.2g} %")
        print(f"{name:13s} {scene.description}")
        print(f"{'':13s} {scene.model.describe()}; default {scene.integrator}, dt={scene.dt:g} s, "
              f"{scene.duration:g} s worth watching; {accuracy} over that time")
        if arguments.measure:
            choice = choose(scene, arguments.tolerance)
            lines = format_choice(choice).splitlines()
            print("\n".join(f"{'':13s} {line}" for line in lines))
    print("\nthe predicted error comes from the linearised lattice's normal modes (exact for "
          "linear scenes); --measure runs each preset to check it and chooses the cheapest "
          "verified setting (the code of `oscillators choose SCENE --tolerance TOL`).")
    print("override any parameter with --set key=value; see `oscillators run --help`.")
    return 0
