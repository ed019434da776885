"""Steps per second of the compiled integrators, against plain numpy and against hand-written C
kernels, with what each specialisation buys measured separately (``measure``; the ``oscillators
bench`` command prints it).

All figures come from one run on one host (the host, its vector width and the thread counts are
printed beside them and included in ``--json``):

* every kernel integrator, float64, one thread: the compiled loop alone
  (``Integrator.advance``), ``Simulation.step`` (the loop plus the blow-up check after each chunk)
  and the same step in plain vectorised numpy (``sim.integrators.reference``);
* the integrators the C reference implements (``app.c_reference.METHODS``: velocity Verlet and
  RK4) in float64 and float32 on 1 and N threads, each with its ratio to the C kernel (gcc -O3
  -march=native -ffast-math; the C leapfrog in the same precision and thread count for Verlet,
  the C fused RK4 in float64 on one thread for RK4).  The
  ratio uses ``Simulation.step``, which includes the blow-up checks.  Without a C compiler the
  ratios are skipped with a note.  Each row also gives its speed-up over the same integrator and
  precision on one thread, the thread counts timed side by side (rounds of one burst each);
* specialisation, one effect at a time, each against the kernel the scene actually runs: zero
  damping, drag and gravity terms compiled in; a (ny, nx) 1/m array instead of the scalar one;
  the 3-D kernel with z = 0 instead of the planar one;
* the teaching instruments: the scene with periodic rows, absorbing walls or a driver against
  the scene as it is (``Simulation.step``, Verlet).

Timing is the best of many short bursts, which keeps the numbers meaningful on a machine that is
busy with other work; the load average is printed beside them.
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable

import numpy as np

from app import c_reference as c_module
from sim.integrators.registry import PRECISIONS, describe


def _best_rate(
    run: Callable[[int], None], burst: int, seconds: float,
    prepare: Callable[[], None] | None = None,
) -> float:
    """Steps per second: the best of bursts of ``burst`` steps over about ``seconds``;
    ``prepare`` (not timed) runs before each burst."""
    run(1)  # compile / warm up
    best = float("inf")
    deadline = time.perf_counter() + seconds
    repetitions = 0
    while time.perf_counter() < deadline or repetitions < 3:
        if prepare is not None:
            prepare()
        started = time.perf_counter()
        run(burst)
        best = min(best, (time.perf_counter() - started) / burst)
        repetitions += 1
    return 1.0 / best


def _numpy_rate(model, integrator: str, positions, velocities, dt: float, seconds: float) -> float:
    from sim.integrators import reference

    state = {"x": positions.copy(), "v": velocities.copy()}

    def run(steps: int) -> None:
        state["x"], state["v"] = reference.run(model, integrator, state["x"], state["v"], dt, steps)

    return _best_rate(run, 1, seconds)


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def host_description() -> dict:
    """The machine the numbers belong to."""
    import numba

    from sim.loops import host_tuning
    from sim.runtime import vector_width as _vector_width

    return {
        "cpu": _cpu_name(),
        "machine": platform.machine(),
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "numba": numba.__version__,
        "vector_width_bits": _vector_width.vector_width_bits(),
        "load_average": os.getloadavg()[0],
        "inverse_sqrt": host_tuning.describe(),
    }


def _burst(integrator: str) -> int:
    return describe(integrator).bench_burst


def _integrator_table(scene, seconds: float) -> dict:
    """Every kernel integrator in float64 on one thread: loop, Simulation.step, numpy."""
    import sim
    from sim.integrators.registry import names

    simulation = sim.Simulation(scene)
    table = {}
    for integrator in names(scene.model, kernel_only=True):
        simulation.reset()
        simulation.integrator = integrator
        # explicit Euler and Heun gain energy at every dt: a smaller step keeps them finite while
        # timing, and each burst starts from the scene's initial state
        unstable = describe(integrator).stability_factor is None
        simulation.dt = scene.dt / 10 if unstable else scene.dt
        simulation.step(1)

        def kernel(steps: int, simulation=simulation) -> None:
            simulation._integrator.advance(simulation.state, steps, simulation.dt)

        def checked(steps: int, simulation=simulation) -> None:
            simulation.step(steps)

        prepare = simulation.reset if unstable else None
        kernel_rate = _best_rate(kernel, _burst(integrator), seconds, prepare=prepare)
        checked_rate = _best_rate(checked, _burst(integrator), seconds, prepare=prepare)
        numpy_rate = _numpy_rate(
            scene.model, integrator, simulation.state.positions.astype(float),
            simulation.state.velocities.astype(float), simulation.dt, seconds / 2,
        )
        table[integrator] = {
            "kernel_steps_per_second": kernel_rate,
            "simulation_steps_per_second": checked_rate,
            "numpy_steps_per_second": numpy_rate,
            "speedup_over_numpy": kernel_rate / numpy_rate,
        }
    return table


def _side_by_side(runs: dict[str, Callable[[int], None]], burst: int, seconds: float) -> dict:
    """Steps per second of each run, measured side by side: rounds of one burst of ``burst`` steps
    of each run (about ``seconds`` per run in all, at least three rounds), the best burst of each
    counted, so a machine that slows down for a while slows every run alike.  Each run is
    warmed up (compiled) first."""
    for run in runs.values():
        run(1)
    best = dict.fromkeys(runs, float("inf"))
    deadline = time.perf_counter() + seconds * len(runs)
    rounds = 0
    while time.perf_counter() < deadline or rounds < 3:
        for name, run in runs.items():
            started = time.perf_counter()
            run(burst)
            best[name] = min(best[name], (time.perf_counter() - started) / burst)
        rounds += 1
    return {name: 1.0 / seconds_per_step for name, seconds_per_step in best.items()}


def _configurations(scene, seconds: float, thread_counts: list[int], c_reference) -> list[dict]:
    """The integrators the C reference implements, in each precision on each thread count, with
    the ratio to the nearest C kernel (``CMethod.configuration``).  The thread counts of one
    integrator and precision are timed side by side (``_side_by_side``), so their ratio does not
    depend on what else the machine did between them."""
    import sim

    model = scene.model
    rows = []
    c_rates: dict[tuple, float] = {}
    for method in c_module.METHODS:
        integrator = method.integrator
        burst = _burst(integrator)
        for precision in PRECISIONS:
            runs = {}
            for threads in thread_counts:
                simulation = sim.Simulation(
                    scene, integrator=integrator, precision=precision, threads=threads
                )
                simulation.step(2)

                def kernel(steps: int, simulation=simulation) -> None:
                    simulation._integrator.advance(simulation.state, steps, simulation.dt)

                def checked(steps: int, simulation=simulation) -> None:
                    simulation.step(steps)

                runs[("kernel", threads)] = kernel
                runs[("checked", threads)] = checked
                if c_reference is not None:  # the C kernel side by side too, once per setting
                    key = method.configuration(precision, threads)
                    if key not in c_rates and ("C", key) not in runs:
                        runs[("C", key)] = c_reference.step_function(
                            key[0], model.nx, model.ny, np.dtype(key[1]).type, key[2]
                        )
            rates = _side_by_side(runs, burst, seconds / 2)
            c_rates.update({name[1]: rate for name, rate in rates.items() if name[0] == "C"})
            for threads in thread_counts:
                row = {
                    "integrator": integrator, "precision": precision, "threads": threads,
                    "kernel_steps_per_second": rates[("kernel", threads)],
                    "simulation_steps_per_second": rates[("checked", threads)],
                    "speedup_over_one_thread": (rates[("checked", threads)]
                                                / rates[("checked", thread_counts[0])]),
                }
                if c_reference is not None:
                    key = method.configuration(precision, threads)
                    single_key = method.configuration(precision, thread_counts[0])
                    row["c_reference"] = method.describe(key[1], key[2])
                    row["c_steps_per_second"] = c_rates[key]
                    row["ratio_to_c"] = row["simulation_steps_per_second"] / c_rates[key]
                    if key != single_key:  # the C kernel's own gain from the threads
                        row["c_speedup_over_one_thread"] = c_rates[key] / c_rates[single_key]
                rows.append(row)
    return rows


SPECIALISATION_INTEGRATORS = tuple(method.integrator for method in c_module.METHODS)
"""The integrators whose loops the specialisation part times: the ones the C reference has."""
SPECIALISATION_DAMPING = 0.3
"""Dashpots (N s/m) of the damped kernels the specialisation part measures gravity in."""


def _specialisation(scene, seconds: float) -> dict | None:
    """What each compile-time flag buys, each alone, on the loops the scene runs with RK4 and
    velocity Verlet: the scene's kernel against the same one with a term passed as a zero
    instead of compiled out (gravity, drag, dashpots), with an array of 1/m instead of a scalar,
    and in 3-D with z = 0; and in the damped kernels (dashpots), which pass gravity as a zero
    pull when a scene has none (``ForceTerm.compiled_out_when_damped``), that zero pull against
    gravity compiled out.  None where the scene is not the plain kernel."""
    import sim
    from sim.integrators.steppers import KernelArguments

    model = scene.model
    if model.is_damped or model.has_gravity or not model.uniform_mass or model.dim != 2:
        return None  # the scene already runs a general kernel
    damped = model.replace(damping=SPECIALISATION_DAMPING)
    cases = {  # name: (model, changes to the kernel's terms)
        "specialised": (model, {}),
        "zero_gravity": (model, {"gravity": np.zeros(3)}),
        "zero_drag": (model, {"drag": 0.0}),
        "zero_dashpot": (model, {"dashpot": 0.0}),
        "inverse_mass_array": (model, {"uniform_inverse_mass": None}),
        "three_dimensional": (model.replace(dim=3), {}),
        "damped_zero_gravity": (damped, {}),
        "damped_without_gravity": (damped, {"gravity": None}),
    }
    start = np.sin(np.arange(model.n_particles * 3)).reshape(model.n_particles, 3)
    results: dict = {}
    for integrator in SPECIALISATION_INTEGRATORS:
        runs = {}
        for name, (variant, changes) in cases.items():
            simulation = sim.Simulation(variant, integrator=integrator, dt=scene.dt)
            simulation.positions += 1e-3 * model.spacing * start[:, :variant.dim]
            stepper = simulation._integrator
            terms, parameters = stepper.kernel
            stepper.kernel = KernelArguments(terms._replace(**changes), parameters)

            def run(steps: int, stepper=stepper, state=simulation.state, dt=simulation.dt) -> None:
                stepper.invalidate()
                stepper.advance(state, steps, dt)

            runs[name] = run
        rates = _side_by_side(runs, _burst(integrator), seconds)
        base = rates["specialised"]
        gain = {name: base / rate for name, rate in rates.items() if not name.startswith(
            ("specialised", "damped"))}
        gain["damped_gravity_compiled_out"] = (rates["damped_without_gravity"]
                                               / rates["damped_zero_gravity"])
        results[integrator] = {"steps_per_second": rates, "gain": gain}
    return results


INSTRUMENTS_INTEGRATOR = "verlet"
"""The integrator the teaching instruments' cost is measured with."""


def _instruments(scene, seconds: float) -> dict:
    """What the teaching instruments cost: ``Simulation.step`` steps/s (velocity Verlet, float64,
    one thread) of the scene as it is, with periodic rows, with absorbing walls (the default
    layer, ``sim.model.boundaries.DEFAULT_LAYER_WIDTH`` particles deep, where the lattice is long
    enough) and with a force driver on one particle; each with its ratio to the scene as it is.
    A scene without them runs the plain compiled loop (the periodic choice is made at compile
    time)."""
    import dataclasses

    import sim

    model = scene.model
    variants = {"as_is": {}, "periodic": {"boundary": "periodic"},
                "driven": {"driver": dict(column=model.nx // 2, row=model.ny // 2,
                                          frequency=0.5, amplitude=0.01)}}
    width = min(sim.model.boundaries.DEFAULT_LAYER_WIDTH, max(1, min(model.nx, model.ny) // 4))
    try:
        model.replace(boundary="absorbing", sponge_width=width)
        variants["absorbing"] = {"boundary": "absorbing", "sponge_width": width}
    except sim.ModelError:
        pass  # too small a lattice for a layer
    runs = {}
    for name, changes in variants.items():
        variant = dataclasses.replace(scene, model=model.replace(**changes)) if changes else scene
        runs[name] = sim.Simulation(variant, integrator=INSTRUMENTS_INTEGRATOR).step
    rates = _side_by_side(runs, _burst(INSTRUMENTS_INTEGRATOR), seconds)
    base = rates["as_is"]
    return {"steps_per_second": rates, "layer_width": width,
            "cost": {name: base / rate for name, rate in rates.items() if name != "as_is"}}


def _gpu(scene, seconds: float) -> dict:
    """Velocity Verlet on the GPU (``Simulation(..., device="cuda")``) against one CPU thread, in
    float64 and float32, on a lattice of the scene's size with nearest springs and fixed walls
    only (what the GPU runs); ``{"found": False, "reason": ...}`` where no GPU is found."""
    import sim
    from sim.devices.cuda_stepper import cuda_device_problem, device_name

    problem = cuda_device_problem()
    if problem is None and device_name() == "simulator":
        problem = "NUMBA_ENABLE_CUDASIM is set: the simulator is not timed"
    if problem is not None:
        return {"found": False, "reason": problem}
    model = scene.model
    plain = sim.Model.create(nx=model.nx, ny=model.ny, spacing=model.spacing,
                             stiffness=model.stiffness, rest_length=model.rest_length)
    start = plain.rest_positions + 0.01 * model.spacing * np.sin(
        np.arange(plain.n_particles))[:, None]
    table = {"found": True, "device": device_name()}
    for precision in ("float64", "float32"):
        runs = {}
        for device in ("cpu", "cuda"):
            simulation = sim.Simulation(plain, integrator="verlet", precision=precision,
                                        device=device, dt=0.2 * plain.spacing / np.sqrt(
                                            plain.stiffness))
            simulation.positions = start
            runs[device] = simulation.step
        rates = _side_by_side(runs, sim.Simulation.chunk_steps, seconds)
        table[precision] = {**rates, "ratio": rates["cuda"] / rates["cpu"]}
    return table


PARTS = {
    "integrators": "every integrator in float64 on one thread, against plain numpy",
    "threads": "Verlet and RK4 in float64/float32 on 1 and N threads, against C",
    "specialisation": "what each of the scene's compile-time flags buys",
    "instruments": "what periodic rows, absorbing walls and a force driver cost",
    "gpu": "velocity Verlet on an NVIDIA GPU against one CPU thread (a line if none is found)",
}
"""The benchmark's parts, in the order they run (``measure(parts=...)``, ``bench --only``)."""


def measure(scene_name: str = "interference", overrides: dict | None = None,
            seconds: float = 2.0, threads: int | None = None, c_reference: bool = True,
            parts: tuple[str, ...] = tuple(PARTS)) -> dict:
    """Run the benchmark's ``parts`` (``PARTS``; all by default) and return the numbers (steps
    per second, ratios, host): the keys "integrators", "configurations" (the threads part),
    "specialisation" and "instruments" of the parts run."""
    import sim

    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        raise ValueError(f"unknown benchmark parts {unknown}; the parts are {list(PARTS)}")
    scene = sim.scenes.build(scene_name, **(overrides or {}))
    most = threads if threads is not None else min(2, os.cpu_count() or 1)
    thread_counts = sorted({1, most})
    results = {
        "scene": scene_name,
        "lattice": f"{scene.model.nx}x{scene.model.ny}",
        "particles": scene.model.n_particles,
        "host": host_description(),
        "threads": thread_counts,
        "c_reference_note": None,
    }
    if "integrators" in parts:
        results["integrators"] = _integrator_table(scene, seconds)
    if "threads" in parts:
        reference, note = c_module.load() if c_reference else (None, "C reference not requested")
        results["c_reference_note"] = note
        results["configurations"] = _configurations(scene, seconds, thread_counts, reference)
    if "specialisation" in parts:
        results["specialisation"] = _specialisation(scene, seconds)
    if "instruments" in parts:
        results["instruments"] = _instruments(scene, seconds)
    if "gpu" in parts:
        results["gpu"] = _gpu(scene, seconds)
    return results
