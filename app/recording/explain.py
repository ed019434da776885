"""The text document at the root of a recording (``/scene``): what a student is looking at.

It lists the scene (every parameter with its unit), the initial displacement and velocity (which
particles, how far), the run (integrator, dt, steps, frame interval, the command line), the
colour scales and how to read every view, and the versions of the software that wrote the file.
``RunInfo`` carries what the recorder cannot know by itself (the planned steps, the command).
"""

from __future__ import annotations

import dataclasses
import datetime
import platform
import shlex
import sys
from typing import Any

import numpy as np

import app.recording.instruments as instruments
from app.recording.scales import AXIS_NAMES, UNITS, ColourScales
from sim.model import boundaries

PARAMETER_UNITS: dict[str, tuple[str, str, str]] = {
    # parameter: (symbol, unit, meaning)
    "nx": ("n_x", "particles", "particles per row"),
    "ny": ("n_y", "particles", "particles per column (rows)"),
    "dim": ("d", "dimensions", "2: motion in the plane; 3: also out of the plane (z)"),
    "spacing": ("a", "m", "lattice spacing, also the distance to the wall anchors"),
    "stiffness": ("k", "N/m", "spring constant of every nearest-neighbour spring"),
    "diagonal_stiffness": ("k₂", "N/m", "spring constant of the diagonal springs (0: none); "
                           "k₂ = k/2 makes an isotropic elastic solid"),
    "rest_length": ("L", "m", "spring rest length; L < a pre-tensions the lattice"),
    "damping": ("c", "N s/m", "dashpot beside every spring (relative velocity along it)"),
    "drag": ("b", "N s/m", "drag on every particle's absolute velocity"),
    "gravity": ("g", "m/s²", "acceleration of gravity (x, y, z)"),
    "linear": ("-", "true/false (no unit)", "springs linearised about the rest lattice"),
    "driver": ("-", "see its fields (m, Hz)", "sinusoidal drive on one particle, or none"),
    "boundary": ("-", f"{'/'.join(boundaries.names())} (no unit)", "walls: fixed anchors, or a sponge layer "
                 "inside them that absorbs waves"),
    "sponge_width": ("w", "particles", "depth of the sponge layer (absorbing walls only)"),
    "sponge_strength": ("-", "ω0 = √(k/m)", "damping rate at the wall (absorbing walls only)"),
    "sponge_sides": ("-", "walls (no unit)", "walls that have a sponge layer"),
}
PROJECT = "coupled-oscillators"


@dataclasses.dataclass(frozen=True)
class RunInfo:
    """What a recording's document says about the run, beyond the scene.

    steps: planned steps (None: open-ended, e.g. the web app); every: steps between recorded
    frames (None: every published frame); command: the command line that made the recording
    (None: the Python API, e.g. the web app).
    """

    steps: int | None = None
    every: int | None = None
    command: str | None = None


def command_line() -> str:
    """This process's command line, as ``oscillators ...`` when run through the CLI."""
    arguments = sys.argv[1:]
    program = sys.argv[0] if sys.argv else "python"
    if program.endswith(("oscillators", "cli.py", "app.cli")) or "app/cli" in program:
        program = "oscillators"
    return shlex.join([program, *arguments])


def command_from_arguments(parser: Any, arguments: Any, program: str = "oscillators") -> str:
    """The command line that reproduces parsed ``arguments`` of a subcommand's ``parser``: its
    positionals and every option whose value differs from its default (whatever process parsed
    them: a shell, a test, the web app)."""
    import argparse

    words = [program, parser.prog.split()[-1]]
    options: list[str] = []
    for action in parser._actions:  # noqa: SLF001 - argparse has no public list of actions
        if isinstance(action, argparse._HelpAction) or action.dest in ("help", "handler"):  # noqa: SLF001
            continue
        value = getattr(arguments, action.dest, None)
        if not action.option_strings:
            words.append(str(value))
            continue
        if value is None or value == action.default or value is False:
            continue
        flag = action.option_strings[-1]
        if value is True:
            options.append(flag)
        elif isinstance(value, list):
            for item in value:
                options += [flag, str(item)]
        else:
            options += [flag, str(value)]
    return shlex.join(words + options)


def versions() -> dict[str, str]:
    """Versions of the project and of the libraries that shape a recording."""
    import importlib.metadata

    import numba
    import rerun as rr

    try:
        project = importlib.metadata.version(PROJECT)
    except importlib.metadata.PackageNotFoundError:
        project = "unknown (not installed)"
    return {
        PROJECT: project, "rerun-sdk": rr.__version__, "numpy": np.__version__,
        "numba": numba.__version__, "python": platform.python_version(),
    }


def _vector(values: np.ndarray, spacing: float) -> str:
    metres = ", ".join(f"{v:+.4g}" for v in values)
    lattice = ", ".join(f"{v / spacing:+.3g}" for v in values)
    return f"({metres}) m = ({lattice}) a"


def describe_initial(scene: Any) -> list[str]:
    """Markdown lines: which particles start displaced or moving, and by how much."""
    model = scene.model
    lines: list[str] = []
    for label, array, unit in (
        ("displacement from the rest lattice", np.asarray(scene.initial_positions)
         - model.rest_positions, "m"),
        ("velocity", np.asarray(scene.initial_velocities), "m/s"),
    ):
        size = np.linalg.norm(array, axis=1)
        moved = np.flatnonzero(size > 1e-12 * model.spacing)
        if moved.size == 0:
            where = "at its rest position" if unit == "m" else "at rest"
            lines.append(f"* Initial {label}: none (every particle {where}).")
            continue
        if moved.size <= 8:
            lines.append(f"* Initial {label} ({moved.size} particle{'s' if moved.size > 1 else ''}):")
            for p in moved:
                i, j = int(p % model.nx), int(p // model.nx)
                text = _vector(array[p], model.spacing) if unit == "m" else (
                    "(" + ", ".join(f"{v:+.4g}" for v in array[p]) + ") m/s")
                lines.append(f"  * particle {p} (column i = {i}, row j = {j}): {text}")
        else:
            top = int(np.argmax(size))
            i, j = top % model.nx, top // model.nx
            lines.append(
                f"* Initial {label}: {moved.size} particles; the largest is {size[top]:.4g} {unit}"
                + (f" ({size[top] / model.spacing:.3g} a)" if unit == "m" else "")
                + f" at particle {top} (column {i}, row {j}); mean over those moved "
                f"{size[moved].mean():.3g} {unit}."
            )
    return lines


def describe_forcing(model: Any) -> list[str]:
    """Markdown section on the driver and an absorbing boundary (none if the scene has neither)."""
    driver = getattr(model, "driver", None)
    sponge = instruments.describe_sponge(model)
    if driver is None and not sponge:
        return []
    lines = ["## Driver and walls", ""]
    if driver is not None:
        force = (f"a force A k sin(2π f t) of amplitude {driver.amplitude * model.stiffness:.3g} N"
                 if driver.kind == "force" else
                 "a prescribed displacement A sin(2π f t) from its rest position")
        lines.append(
            f"* **Driver**: {driver.describe()}: {force}, starting at t = {driver.start:g} s and "
            f"ramped up smoothly over {driver.ramp:g} s (period {1 / driver.frequency:.4g} s). "
            "The work it does on the lattice is plotted as `driven` (J) with the energies and "
            "taken out of the energy balance. Its particle is ringed in the lattice view."
        )
    if sponge:
        lines.append(f"* **Absorbing walls**: {sponge} The layer's inner edge is drawn as a "
                     "faint grey outline (lattice view and field image).")
    return lines + [""]


def table_rows(document: str) -> dict[str, list[str]]:
    """{first cell: cells} of every row of the markdown tables in ``document`` (how a reader
    finds a parameter in the document ``scene_document`` wrote)."""
    rows = {}
    for line in document.splitlines():
        if line.startswith("|") and not line.startswith("| ---"):
            cells = [cell.strip() for cell in line.strip("|").split("|")]
            rows[cells[0]] = cells
    return rows


def scene_document(
    scene: Any, model: Any, *, integrator: str, dt: float, plan: Any, scales: ColourScales,
    run: RunInfo, trees: tuple[str | None, ...], exaggeration: float = 1.0,
) -> str:
    """The markdown document logged statically at ``/scene``."""
    a = model.spacing
    lines = [f"# {scene.name}", "", scene.description, "", f"**{model.describe()}**", ""]
    lines += ["## Scene parameters (SI units)", "",
              "| parameter | symbol | value | unit | meaning |", "| --- | --- | --- | --- | --- |"]
    for key, value in model.parameters().items():
        symbol, unit, meaning = PARAMETER_UNITS.get(key, ("", "see docs/api.md", ""))
        if key == "gravity":
            value = "(" + ", ".join(f"{g + 0.0:g}" for g in value) + ")"
        elif key == "driver":
            value = value.describe() if value is not None else "none"
        elif key == "sponge_sides":
            value = ", ".join(value) if value else "none"
        elif isinstance(value, float):
            value = f"{value:g}"
        lines.append(f"| {key} | {symbol} | {value} | {unit} | {meaning} |")
    masses = model.masses
    mass_text = f"{masses.flat[0]:g}" if model.uniform_mass else (
        f"{masses.min():g} to {masses.max():g} (per particle: `lattice/particles:mass`)"
    )
    lines += [
        f"| mass | m | {mass_text} | kg | mass of each particle |",
        f"| tension | T = k (a - L) | {model.tension:g} | N | spring tension in the rest lattice |",
        f"| particles | | {model.n_particles} | particles | |",
        f"| springs | | {model.n_springs} | springs | incl. {model.n_anchors} to wall anchors |",
    ]
    if model.uniform_mass:
        speed = a * (model.stiffness / float(masses.flat[0])) ** 0.5
        lines.append(f"| wave speed | a √(k/m) | {speed:.4g} | m/s | long waves along the springs |")
    lines += ["", "## Initial condition", "", *describe_initial(scene), ""]
    lines += describe_forcing(model)
    several = "," in integrator
    lines += ["## Run", "", "| | value | unit |", "| --- | --- | --- |",
              f"| integrator{'s' if several else ''} | {integrator} | |",
              f"| time step dt | {dt:g} | s |"]
    if run.steps is not None:
        lines.append(f"| steps | {run.steps} | steps ({run.steps * dt:g} s simulated) |")
    if run.every is not None:
        lines.append(f"| frame interval | every {run.every} steps = {run.every * dt:g} | s |")
    else:
        lines.append("| frame interval | every frame the runner published | |")
    command = run.command or f"Python API (app.recording.Recorder) inside `{command_line()}`"
    lines += [f"| recorded by | `{command}` | |",
              f"| written | {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC | |", ""]
    lines += ["## How to read the views", ""]
    lines += _view_notes(model, plan, scales, trees, exaggeration)
    lines += ["", "## Versions", ""]
    lines += [f"* {name} {version}" for name, version in versions().items()]
    lines += [
        "", "Particle p = j * nx + i (column i, row j, row 0 at the bottom); springs in "
        "`sim.Model.springs` order (horizontal row by row, then vertical column by column). "
        "The file layout is described in the project's docs/recording.md.",
    ]
    return "\n".join(lines)


def _view_notes(
    model: Any, plan: Any, scales: ColourScales, trees: tuple[str | None, ...],
    exaggeration: float,
) -> list[str]:
    notes = [
        "* **Timeline**: `sim_time` is the simulated time in seconds (the default); `step` counts "
        "time steps.",
    ]
    if plan.surface:
        notes.append(
            f"* **membrane** (3-D view): the lattice drawn as a surface through the particles, "
            f"coloured by height z: blue below the plane, grey in it, red above, saturating at "
            f"±{scales.height:.3g} m (legend: `legend/height`). Heights are exaggerated "
            f"×{exaggeration:g} for display (the scale of the transform on `lattice`; select "
            f"that entity in the viewer to change it); the recorded positions are true metres."
        )
    elif plan.positions_every:
        notes.append(
            "* **lattice**: blue discs are the particles (size grows with mass), small grey dots "
            "their rest positions, large grey dots the wall anchors."
        )
    if plan.springs:
        notes.append(
            f"* **springs**: coloured by strain (length - L)/L minus the rest strain "
            f"{scales.rest_strain:.3g}: blue compressed, grey as in the rest lattice, red "
            f"stretched, saturating at ±{scales.strain:.3g} (legend: `legend/strain`)."
        )
    if plan.field:
        if plan.quantity == "displacement":
            what = (f"the displacement u_{AXIS_NAMES[scales.axis]} (m) of every particle, signed: "
                    f"blue negative, white zero, red positive, ±{scales.field:.3g} m")
        else:
            what = (f"the {plan.quantity} ({UNITS[plan.quantity]}) of every particle: black 0 to "
                    f"yellow {scales.field:.3g} {UNITS[plan.quantity]}")
        notes.append(
            f"* **field**: one pixel per particle, the lattice seen from the front (top row "
            f"first); colour = {what} (legend: `legend/field`). The scale is fixed for the whole "
            "recording, so frames are comparable."
        )
    names = [name for name in trees if name]
    driven = getattr(model, "driver", None) is not None
    notes.append(
        "* **energy (J)**: kinetic (orange), potential (blue: springs + gravity), total "
        "(purple) and dissipated by damping (olive"
        + (", the sponge layer's included" if boundaries.get(model.boundary).absorbing else "") + ")"
        + ("; driven (teal): the work the driver has done" if driven else "")
        + (f"; one tab per integrator ({', '.join(names)})." if names else ".")
    )
    notes.append(
        "* **energy-balance error (%)**: (kinetic + potential + dissipated"
        + (" - driven" if driven else "") + " - its starting value) "
        "divided by the energy in play"
        + (" (or by the driver's work, when larger)" if driven else "")
        + ", in percent. The exact motion keeps it at 0; an "
        "integrator that gains energy drifts up, one that loses it drifts down. Verlet "
        "oscillates about 0, explicit Euler grows"
        + (" (one line per integrator, coloured as in the energy tabs)." if names else ".")
    )
    notes += _instrument_notes(model, plan)
    notes.append("* **events**: integrator and dt changes, blow-ups, interruptions.")
    return notes


def _instrument_notes(model: Any, plan: Any) -> list[str]:
    """How to read the probe and mode-energy views (if the recording has them)."""
    notes = []
    probes = getattr(plan, "probes", ())
    if probes:
        where = ", ".join(f"({i}, {j})" for i, j in probes)
        components = ", ".join(f"u_{c}" for c in "xyz"[: model.dim])
        notes.append(
            f"* **probe displacement (m)**: the displacement from rest ({components}) of the "
            f"particle(s) at column, row {where}, every recorded frame "
            "(`probes/<column>_<row>/<component>`). **probe spectra**, logged when the "
            "recording ends: the amplitude of each series against frequency (Hz; Hann window, "
            "a sine of amplitude A reads A); the strongest peaks are listed at the end of this "
            "document with the nearest normal modes."
        )
    modes_every = getattr(plan, "modes_every", 0)
    if modes_every:
        rows, columns = instruments.mode_blocks(model)
        every = "every recorded frame" if modes_every == 1 else f"every {modes_every} recorded frames"
        layout = ("column m, row n (from the bottom) is mode (m, n): m half-waves along x, n "
                  "along y, the longest waves at the bottom left" if model.uniform_mass else
                  "unequal masses: the modes in rising frequency, row by row from the bottom")
        blocks = ("" if rows == columns == 1 else
                  f" Each cell sums a block of {columns} x {rows} modes (the image is at most "
                  f"{instruments.MODE_IMAGE_SIDE} modes wide and high).")
        notes.append(
            f"* **energy per mode** (one view per polarisation: {', '.join('xyz'[: model.dim])}): "
            f"the energy (J) of each normal mode of the lattice linearised about its "
            f"equilibrium, {every}; {layout}. Log colour: black 10^-{instruments.MODE_DECADES} "
            "of the look-ahead's largest energy or less, yellow that energy (legend: "
            "`legend/modes`). The values are in `modes/<polarisation>/energy` (tensor, J); "
            "for a linear scene they add up to kinetic + spring energy, and without damping or "
            "driver each stays constant." + blocks
        )
    return notes
