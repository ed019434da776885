"""``oscillators choose``: the cheapest (integrator, dt) that meets an error tolerance over a
scene's duration, verified by running exactly that setting (``app.study.choose``), with its
measured error and wall time and the runner-ups.

Exit codes: 0 a setting met the tolerance, 1 none did (the best reached is shown), 2 bad input.
With ``--json`` stdout is one JSON document; files are written only when named: ``-o PATH``
(the JSON) and ``--plot PATH.png`` (every run, error against wall time).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

from app.cli.arguments import positive_float, positive_int, scene_from_arguments
from app.cli.cluster import add_cluster_arguments, executor_from
from app.cli.commands import summary

DESCRIPTION = """\
The cheapest integrator and time step that meet an error tolerance over the scene's whole
duration.  The answer is verified before it is shown: exactly that setting is run from the
scene's initial state to the end and both of its errors measured over the whole run, at
{samples} evenly spaced times t_k = k T/{samples} (the last at the end T):

  field error   max_k ||u(t_k) - u_ref(t_k)||_2 / max_k ||u_ref(t_k)||_2, u every particle's
                displacement from rest (it sees phase: a wave in the wrong place is an
                error); the reference is the exact normal-mode solution of a linear scene,
                else RK4 halved until halving changes the sampled field by less than a tenth
                of the tolerance (made when planned to cost under {budget:g} s).
  energy error  max_k |energy-balance error at t_k| (blind to phase).

A setting meets the tolerance only when both errors do; --error field or --error energy
checks that one alone (the other is still measured and shown).  Where the field reference is
not affordable the energy error alone is used, and the output says so.

Candidates: the step each integrator needs is predicted from the scene's normal modes (or
probed at half its stability limit), run, and retried from the measured error and the
integrator's order.
"""

EPILOG = """\
examples:
  oscillators choose grid --tolerance 0.01
  oscillators choose catenary --tolerance 0.01                  # field and energy error
  oscillators choose chain --tolerance 1e-3 --set linear=true          # exact reference
  oscillators choose catenary --tolerance 0.01 --error energy --integrators verlet,rk4
  oscillators choose interference --tolerance 0.05 --json -o choice.json
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``choose`` command to ``oscillators``."""
    from app.study.choose import REFERENCE_BUDGET_SECONDS
    from sim.runtime.errors import MEASURES, SAMPLES

    parser = subparsers.add_parser(
        "choose", help=summary("choose"),
        description=DESCRIPTION.format(samples=SAMPLES, budget=REFERENCE_BUDGET_SECONDS),
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "scene", help="preset name (see `oscillators scenes`) or a .toml or .zip scene file"
    )
    parser.add_argument("--tolerance", type=positive_float, required=True, metavar="TOL",
                        help="largest acceptable relative error over the whole run")
    parser.add_argument("--error", choices=MEASURES, default=None,
                        help="check this error alone against the tolerance, the other still "
                        "shown (default: both; the energy error alone where no field reference "
                        "is affordable)")
    parser.add_argument("--integrators", type=_names, default=None, metavar="A,B",
                        help="integrators to consider, comma-separated (default: all that apply)")
    parser.add_argument(
        "--set", dest="overrides", action="append", metavar="KEY=VALUE",
        help="override a scene parameter (as for `run`); repeatable",
    )
    parser.add_argument("--threads", type=positive_int, default=1,
                        help="threads each run's compiled sweeps use, as row blocks (default: 1)")
    parser.add_argument("--json", action="store_true", help="print the result as one JSON document")
    parser.add_argument("-o", "--output", metavar="PATH.json",
                        help="also write the result as JSON to this file")
    parser.add_argument("--plot", metavar="PATH.png",
                        help="also save the picture of every run (error against wall time)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_cluster_arguments(parser)
    parser.set_defaults(handler=command_choose, reads_cached_kernels=True)


def _names(text: str) -> list[str]:
    from sim.integrators.registry import IntegratorError, check_integrator_name

    names = [name.strip() for name in text.split(",") if name.strip()]
    if not names:
        raise argparse.ArgumentTypeError("give at least one integrator name")
    try:
        return [check_integrator_name(name) for name in names]
    except IntegratorError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


class Bar:
    """The tqdm bar on stderr, counting planned seconds of computing (so its ETA is a time).

    Between two finished runs a ticker thread advances it by the wall time passed (never past
    the work planned so far), so it moves, and its ETA holds, during a long run."""

    TICK = 1.0

    def __init__(self, quiet: bool) -> None:
        import threading
        import time

        from tqdm import tqdm

        self._time = time.monotonic
        self.bar = tqdm(total=0.0, unit="s", disable=quiet, dynamic_ncols=True, file=sys.stderr,
                        bar_format="{l_bar}{bar}| {elapsed}<{remaining} {postfix}")
        self.done = 0.0
        self.since = self._time()
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.ticker = None
        if not quiet:
            self.ticker = threading.Thread(target=self._tick, name="choose-bar", daemon=True)
            self.ticker.start()

    def _tick(self) -> None:
        while not self.stop.wait(self.TICK):
            with self.lock:
                shown = min(self.done + self._time() - self.since, self.bar.total)
                if shown > self.bar.n:
                    self.bar.n = shown
                    self.bar.refresh()

    def planned(self, seconds: float) -> None:
        with self.lock:
            self.bar.total = max(self.done, self.bar.total + seconds)
            self.bar.refresh()

    def finished(self, seconds: float, label: str) -> None:
        with self.lock:
            self.done += seconds
            self.since = self._time()
            self.bar.n = min(self.done, self.bar.total)
            self.bar.set_postfix_str(label, refresh=True)

    def close(self) -> None:
        self.stop.set()
        if self.ticker is not None:
            self.ticker.join()
        self.bar.close()


def command_choose(arguments: argparse.Namespace) -> int:
    from app.cli.study_output import check_plot_path
    from app.study.choose import choose

    scene = scene_from_arguments(arguments)
    check_plot_path(arguments)
    if arguments.output:
        _check_output(arguments.output)
    bar = Bar(arguments.quiet)
    try:
        with executor_from(arguments) as executor:
            choice = choose(scene, arguments.tolerance, measure=arguments.error,
                            integrators=arguments.integrators, progress=bar,
                            threads=arguments.threads,
                            map_runs=lambda function, tasks: executor.map(function, tasks))
    finally:
        bar.close()
    data = choice.as_dict()
    if arguments.plot:
        from app.study.choose_report import plot_choice

        plot_choice(data, arguments.plot)
    if arguments.output:
        _write_json(arguments.output, data)
    if arguments.json:
        print(json.dumps(data, indent=2))
    else:
        print(format_choice(choice))
        for written in (arguments.output, arguments.plot):
            if written:
                print(f"written to {Path(written).resolve()}")
    return 0 if choice.answer is not None else 1


def format_choice(choice: Any) -> str:
    """The choice as text: the answer (or that none met the tolerance) and the runner-ups."""
    from sim.runtime.errors import SAMPLES

    lines = [f"{choice.scene}: {choice.duration:g} s, {choice.measure} error, tolerance "
             f"{choice.tolerance:g} (errors: the largest over {SAMPLES} times of the run)"]
    if choice.reference is not None:
        lines.append(f"reference: {choice.reference.describe()}")
    if choice.note:
        lines.append(choice.note)
    answer = choice.answer
    if answer is not None:
        # six significant figures: the dt lands the run on its duration (1/48 s, ...), and a
        # command with 0.0208333 runs the same setting to 1e-6 of the step (--json has it exact)
        lines.append(f"choose: --integrator {answer.integrator} --dt {answer.dt:.6g}")
        lines.append(f"  verified: {answer.describe()}")
    else:
        best = choice.best_reached
        lines.append(f"nothing met the tolerance {choice.tolerance:g}"
                     + (f"; the best reached: {best.describe()}" if best else ""))
    if choice.runner_ups:
        lines.append("runner-ups (verified):")
        lines += [f"  {run.describe()}" for run in choice.runner_ups]
    for name, reason in choice.skipped.items():
        lines.append(f"not run: {name}, {reason}")
    lines.append(f"{len(choice.runs)} runs in all")
    return "\n".join(lines)


def _check_output(path: str) -> None:
    target = Path(path)
    if target.is_dir():
        raise ValueError(f"-o {path} is a directory; give a file name")
    if not target.parent.is_dir():
        raise ValueError(f"-o {path}: the directory {target.parent} does not exist")
    if target.is_symlink():
        raise ValueError(f"-o {path} is a symbolic link; give a plain file name")


def _write_json(path: str, data: dict[str, Any]) -> None:
    """Write atomically: an exclusive temporary file beside the target, renamed when complete."""
    target = Path(path)
    _check_output(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
    try:
        with os.fdopen(handle, "w") as stream:
            json.dump(data, stream, indent=2)
        os.replace(temporary, target)
    except BaseException:
        os.unlink(temporary)
        raise
