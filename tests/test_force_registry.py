"""The force terms are one registration each, and every face reads it: the parameter table, the
model's stored values, the kernels' records, the kernel key, scene files and the model's words."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from sim.forces import registry
from sim.model import parameters
from sim.runtime.warming import kernel_key


class Stand:
    """What ``kernel_key`` reads of a simulation, without compiling anything."""

    def __init__(self, model: sim.Model) -> None:
        self.model = model
        self.integrator, self.precision, self.threads, self.chunk_steps = "verlet", "float64", 1, 64


def test_every_registered_kernel_field_changes_the_kernel_key():
    base = sim.scenes.build("grid").model
    key = kernel_key(Stand(base))
    checked = 0
    for term in registry.TERMS:
        for field in term.fields:
            name = next(row.name for row in term.parameters)
            values = {row.name: term.example[row.name] for row in term.parameters
                      if row.name in term.example}
            model = base.replace(**values)
            assert field.value(model) is not None, (term.name, field.name)
            assert kernel_key(Stand(model)) != key, (term.name, field.name, name)
            checked += 1
    assert checked == len(registry.fields("springs")) + len(registry.fields("terms")) >= 4
    # the diagonal springs, missing from a hand-written key, are in the derived one
    diagonal = base.replace(diagonal_stiffness=17.5)
    assert kernel_key(Stand(diagonal)) != key


def test_every_term_parameter_is_a_table_row_a_model_value_and_a_scene_file_key():
    base = sim.scenes.build("grid")
    for term in registry.TERMS:
        for row in term.parameters:
            assert parameters.get(row.name) is row
            assert row.name in sim.scenes.building.OVERRIDES
        if not term.example:
            continue
        model = base.model.replace(**term.example)
        assert term.present(model) and not term.present(base.model)
        if term.describe is not None:
            assert term.describe(model) in model.describe()
        scene = sim.scenes.scene_files.from_bytes(
            sim.scenes.scene_files.to_bytes(
                sim.scenes.build("grid", **term.example))[1], "x.toml")
        for name in term.example:
            assert getattr(scene.model, name) == getattr(model, name), name


def test_a_terms_parameter_is_checked_like_every_value_from_outside():
    with pytest.raises(sim.model.ModelError, match="damping must be zero or positive"):
        sim.Model.create(3, 1, damping=-1.0)
    with pytest.raises(sim.model.ModelError, match="unknown lattice parameter 'dampnig'"):
        sim.Model.create(3, 1, dampnig=1.0)
    with pytest.raises(sim.model.ModelError, match="gravity"):
        sim.Model.create(3, 1, gravity="down")
    model = sim.Model.create(3, 1, gravity=9.81)
    assert model.gravity == (0.0, -9.81, 0.0) and model.damping == 0.0


def test_gravity_is_a_value_in_damped_kernels_and_compiled_out_in_undamped_ones():
    """Toggling Gravity in a damped scene needs no new kernel (a zero pull costs those kernels
    less than 3 %); in an undamped one it is compiled out.  The zero pull changes nothing."""
    from sim.runtime.warming import kernel_key

    def key(**changes):
        return kernel_key(sim.Simulation(sim.scenes.build("grid", **changes)), 64)

    assert key(damping=0.3) == key(damping=0.3, gravity=9.81)
    assert key(drag=0.1) == key(drag=0.1, gravity=9.81)
    assert key() != key(gravity=9.81)
    damped = sim.Simulation(sim.scenes.build("grid", damping=0.3))
    assert damped._integrator.kernel.terms.gravity is not None
    assert not damped._integrator.kernel.terms.gravity.any()
    assert sim.Simulation(sim.scenes.build("grid"))._integrator.kernel.terms.gravity is None
    # the zero pull adds nothing: the kernel's accelerations are numpy's independent ones
    from sim.integrators import reference

    rng = np.random.default_rng(4)
    damped.positions += 0.1 * rng.standard_normal(damped.positions.shape)
    damped.velocities = rng.standard_normal(damped.velocities.shape)
    damped.integrator = "verlet"
    state = damped.state
    damped._integrator._accelerations(state)
    expected = reference.accelerations(damped.model, state.positions, state.velocities)
    assert np.abs(expected).max() > 1.0
    assert np.allclose(damped._integrator.work[0], expected, rtol=1e-12, atol=1e-12)
