"""numba's optimisation level (``sim.runtime.optimisation``): ``import sim`` asks for ``max`` (the
cheap pass at level 3, so a kernel compiled in the running process vectorises), a level the user
set is kept, and the commands that read their kernels from the cache go back to numba's default
before compiling anything.  Each case is a fresh process (the level is read as numba starts);
the code generator's internals this module switches are checked to be where it expects them."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from app.cli import build_parser

PROBE = """
import json, os, sys
{before}
import sim
from numba import njit
from numba.core import config
from numba.core.registry import cpu_target
{after}
njit(lambda x: x + 1)(1)  # numba makes its code generator
codegen = cpu_target.target_context.codegen()
print(json.dumps({{"max": bool(config.OPT.is_opt_max), "env": os.environ.get("NUMBA_OPT"),
                  "cheap_pass": codegen._opt_level, "vectorise": codegen._loopvect}}))
"""


def _probe(environment: dict, before: str = "", after: str = "") -> dict:
    env = {key: value for key, value in os.environ.items()
           if key not in ("NUMBA_OPT", "OSCILLATORS_NUMBA_OPT", "_OSCILLATORS_SET_NUMBA_OPT")}
    env.update(environment)
    result = subprocess.run([sys.executable, "-c", PROBE.format(before=before, after=after)],
                            capture_output=True, text=True, env=env, check=True, timeout=120)
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_import_sim_asks_for_max_and_numbas_code_generator_follows():
    assert _probe({}) == {"max": True, "env": "max", "cheap_pass": 3, "vectorise": True}


def test_a_level_the_user_set_is_kept():
    assert _probe({"NUMBA_OPT": "1"}) == {"max": False, "env": "1", "cheap_pass": 0,
                                          "vectorise": False}
    assert _probe({"OSCILLATORS_NUMBA_OPT": "0"})["max"] is False


def test_a_code_generator_made_before_import_sim_is_switched_too():
    made_first = "from numba import njit as _n; _n(lambda x: x)(1)"
    assert _probe({}, before=made_first)["cheap_pass"] == 3


def test_going_back_to_numbas_default_before_compiling():
    back = "from sim.runtime.optimisation import use_numba_default; use_numba_default()"
    assert _probe({}, after=back) == {"max": False, "env": None, "cheap_pass": 0,
                                      "vectorise": False}
    assert _probe({"NUMBA_OPT": "1"}, after=back)["env"] == "1"  # the user's level stays


@pytest.mark.parametrize("command, reads", [
    (["run", "grid"], True), (["record", "grid"], True), (["serve"], True), (["bench"], True),
    (["warm"], True), (["choose", "grid", "--tolerance", "0.01"], True), (["accuracy", "grid"], True),
    (["stability"], False), (["dispersion"], False), (["movie", "grid", "-o", "x.mp4"], False),
])
def test_the_commands_that_read_cached_kernels_say_so(command, reads):
    arguments = build_parser().parse_args(command)
    assert getattr(arguments, "reads_cached_kernels", False) is reads


RUN = """
import json, sys
import sim
simulation = sim.Simulation(sim.scenes.build("grid"), integrator=sys.argv[1], dt=0.02)
simulation.step(300)
print(json.dumps(simulation.positions.ravel().tolist()))
"""


# each case compiles the grid's kernels at three levels in children: about 30 s on an empty cache;
# velocity Verlet (the fused leapfrog, the kernels most users run) in the default suite
@pytest.mark.parametrize("integrator", [
    "verlet", pytest.param("rk4", marks=pytest.mark.slow),
    pytest.param("yoshida4", marks=pytest.mark.slow)])
def test_every_level_steps_to_the_same_positions(integrator):
    """The suite runs at LLVM's level 1 (``make test``), users at numba's default level (the
    command line) or ``max`` (``import sim``): the grid after 300 steps is the same to round-off
    at all three, so the suite tests the results users get."""
    import numpy as np

    runs = {}
    for name, level in (("suite", {"NUMBA_OPT": "1"}), ("command line",
                                                          {"OSCILLATORS_NUMBA_OPT": "0"}),
                        ("import sim", {})):
        env = {key: value for key, value in os.environ.items()
               if key not in ("NUMBA_OPT", "OSCILLATORS_NUMBA_OPT", "_OSCILLATORS_SET_NUMBA_OPT")}
        env.update(level)
        result = subprocess.run([sys.executable, "-c", RUN, integrator], capture_output=True,
                                text=True, env=env, check=True, timeout=600)
        runs[name] = np.array(json.loads(result.stdout.strip().splitlines()[-1]))
    reference = runs["command line"]
    for name, positions in runs.items():
        assert np.allclose(positions, reference, rtol=1e-12, atol=1e-13), name


FOLDERS = """
import json
import sim
from sim.loops import row_sweep
from sim.runtime.optimisation import use_numba_default
before = row_sweep.accelerations._cache._cache_path
use_numba_default()
print(json.dumps([before, row_sweep.accelerations._cache._cache_path]))
"""


def test_going_back_to_numbas_default_moves_the_kernels_cache_folder_too():
    """The kernels made at ``import sim`` (level max) look in the default level's folder once
    a command goes back to numba's default: there a child process wrote them."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("NUMBA_OPT", "OSCILLATORS_NUMBA_OPT", "_OSCILLATORS_SET_NUMBA_OPT")}
    result = subprocess.run([sys.executable, "-c", FOLDERS], capture_output=True, text=True,
                            env=env, check=True, timeout=120)
    before, after = json.loads(result.stdout.strip().splitlines()[-1])
    assert os.path.basename(before) == "opt-max"
    assert os.path.normpath(after) == os.path.dirname(before)


READ_AFTER_CHILD = """
import json
from sim.runtime.optimisation import use_numba_default
use_numba_default()
import sim
from sim.runtime import warming
warming.compiles_started()  # watch from here
scene = sim.scenes.build("chain")
warming.call_in_child(warming.rehearse, scene, "verlet", scene.dt, "float64", 1, 65)
warming.rehearse(scene, "verlet", scene.dt, "float64", 1, 65)
print(json.dumps(warming.compiles_started()))
"""


def test_a_command_reads_the_kernels_its_child_compiled(tmp_path):
    """A command (numba's default level) has a child compile a scene's kernels on an empty
    cache, then runs the scene itself: it reads every kernel from the cache and compiles none
    (compiled here, they would run the slower code of kernels compiled apart)."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("NUMBA_OPT", "OSCILLATORS_NUMBA_OPT", "_OSCILLATORS_SET_NUMBA_OPT")}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba")
    result = subprocess.run([sys.executable, "-c", READ_AFTER_CHILD], capture_output=True,
                            text=True, env=env, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    assert json.loads(result.stdout.strip().splitlines()[-1]) == 0
