"""The absorbing layer's action, the drive tables and the spring sweeps are each compiled once per
real type.  numba types a constant argument (``True``, ``0``, ``-1``) as a Literal type of its
own: a kernel called with it from one place and with a value from another compiles (and caches)
its whole callee tree twice, seconds more to wait before a first Play.  These kernels are called
with values (``absorbing_kicks.TWICE``, ``drive_table.EVERY_KIND``, ``np.intp(0)``).

Checked in a fresh process on an empty cache: a kernel read from the cache compiles no callee,
so only a compiling process shows every variant."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

CHECKED = (
    "sim.forces.absorbing_layer.act_rows", "sim.forces.absorbing_layer.act_part",
    "sim.forces.absorbing_layer._line", "sim.forces.absorbing_layer._across",
    "sim.forces.drive_table.drive_rows", "sim.forces.drive_table.drive_row",
    "sim.forces.drive_table._drive_one", "sim.forces.springs.vertical_springs",
)

CHILD = """
import json, sys
import sim
from numba.core import types
from numba.core.registry import CPUDispatcher

for name, integrator, overrides in [
        ("bandgap", "verlet", {}), ("bandgap", "rk4", {}), ("double-slit", "verlet", {}),
        ("interference-open", "verlet", {"nx": 40, "ny": 30})]:
    simulation = sim.Simulation(sim.scenes.build(name, **overrides), integrator=integrator)
    simulation.step(65)
found = {}
for module_name, module in list(sys.modules.items()):
    if module is None or not module_name.startswith("sim."):
        continue
    for value in list(vars(module).values()):
        if isinstance(value, CPUDispatcher):
            key = f"{value.py_func.__module__}.{value.py_func.__qualname__}"
            found[key] = [[str(argument) for argument in signature]
                          for signature in value.signatures]
            found[key + "/plain"] = [[str(types.unliteral(argument)) for argument in signature]
                                     for signature in value.signatures]
print(json.dumps(found))
"""


@pytest.fixture(scope="module")
def signatures(tmp_path_factory) -> dict[str, list[list[str]]]:
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path_factory.mktemp("cache")),
                       PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                          env=environment, timeout=900, check=True)
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("name", CHECKED)
def test_a_kernel_is_not_compiled_again_for_a_constant(signatures, name):
    compiled, plain = signatures[name], signatures[name + "/plain"]
    assert compiled, f"{name} was not compiled by these runs"
    duplicates = [signature for signature, unliteral in zip(compiled, plain, strict=True)
                  if plain.count(unliteral) > 1]
    assert not duplicates, duplicates


def test_the_layers_action_is_one_kernel_for_the_loop_and_the_half_steps(signatures):
    """Velocity Verlet runs the layer's action inside its loop (both halves between two steps)
    and on its own before and after the loop (one half): the halves are a value, so one
    variant serves both (a constant True and a None once made two, each the whole layer)."""
    act_rows = signatures["sim.forces.absorbing_layer.act_rows"]
    assert {signature[7] for signature in act_rows} == {"bool"}, act_rows
