"""A setup as a link: the page's preset, the parameters it changed, the integrator and dt, and
the view's settings the page chose (colour, springs, particle size), in the address a teacher
pastes into a worksheet; opening it runs that setup and shows it so.

The link is the page's own address whose ``websocket`` query (viser's) names the path
``/setup/`` and the query ``scene=grid&stiffness=50&integrator=verlet&dt=0.02`` in URL-safe
base64: the page connects there, and the server reads the path of its connection
(``setup_from_path``; in the path and encoded, because viser's page keeps a websocket address's
path but neither its query nor, across its own reload, an ``&`` in it).  Every value in it is checked as a
value a page sends is: known keys only, ASCII numbers within the parameter table's bounds (the
preset's ``sim.scenes.build`` checks them), a known integrator, a dt up to ``MAX_DT``, at most
``MAX_PAGE_PARTICLES`` particles.  Only presets are shared: nothing in a link names a file.
"""

from __future__ import annotations

import base64
import dataclasses
import math
from typing import Any
from urllib.parse import parse_qsl, quote, urlencode, urlsplit

import numpy as np

import sim
from app.web.scene_files import MAX_PAGE_PARTICLES
from app.web.view import COLOR_MODES, ViewSettings
from sim.integrators.registry import ALL_INTEGRATORS

SETUP_PATH = "/setup"
"""The websocket path a shared link connects to."""
SHARED = ("nx", "ny", "spacing", "mass", "stiffness", "rest_length", "diagonal_stiffness",
          "damping", "drag", "gravity", "spring_alpha", "spring_beta", "linear", "dim",
          "boundary", "sponge_width", "sponge_strength")
"""The scene parameters a link carries (the driver, sources and barriers stay the preset's)."""
WHOLE = ("nx", "ny", "dim", "sponge_width")
VIEW = {"view_colour": "color_by", "view_springs": "show_springs", "view_size": "particle_scale"}
"""The view's settings a link carries, each the ``app.web.view.ViewSettings`` field it sets, when
the page chose one (a field away from its default)."""
MAX_DT = 10.0
"""Largest dt a link may ask for (s), as the page's dt box."""
MAX_LINK = 2000
"""Longest path a link may have (characters)."""


class LinkRefused(ValueError):
    """A shared link's setup that cannot be opened, and why."""


@dataclasses.dataclass(frozen=True)
class Setup:
    """What a link opens: ``scene`` a preset with ``overrides``, run by ``integrator`` at ``dt``."""

    scene: str
    overrides: dict[str, Any]
    integrator: str
    dt: float
    view: dict[str, Any] = dataclasses.field(default_factory=dict)
    """``VIEW`` settings: colour (a ``COLOR_MODES`` name), springs (bool), size (0.2 to 3)."""

    def show(self, settings: Any) -> None:
        """Put the link's view settings into ``settings`` (an ``app.web.view.ViewSettings``)."""
        for key, field in VIEW.items():
            if key in self.view:
                setattr(settings, field, self.view[key])

    def build(self) -> sim.Scene:
        """The scene (``sim.scenes.build``: every value checked there too)."""
        preset = sim.scenes.presets.PRESETS[self.scene].parameters
        nx, ny = (int(self.overrides.get(side, preset.get(side, 1))) for side in ("nx", "ny"))
        if nx * ny > MAX_PAGE_PARTICLES:
            raise LinkRefused(f"{nx}x{ny} particles; the page builds up to {MAX_PAGE_PARTICLES:,}")
        return sim.scenes.build(self.scene, integrator=self.integrator, dt=self.dt,
                                **self.overrides)


def _text(value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (tuple, list, np.ndarray)):
        return ",".join(_text(part) for part in value)
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return f"{float(value):.12g}"


def _model_values(model: sim.Model) -> dict[str, Any]:
    values = {name: getattr(model, name) for name in SHARED if name not in ("mass", "boundary")}
    masses = np.asarray(model.masses)
    values["mass"] = float(masses.flat[0]) if np.all(masses == masses.flat[0]) else None
    values["boundary"] = model.boundary
    values["gravity"] = tuple(float(g) for g in model.gravity[: model.dim])
    return values


def setup_query(simulation: sim.Simulation, view: Any = None) -> str:
    """The setup of ``simulation`` as a query (``scene=...&...``); LinkRefused when its scene is
    not a preset, or its masses are not one value (a link carries no arrays)."""
    name = simulation.scene.name
    if name not in sim.scenes.names():
        raise LinkRefused(f"{name!r} is not a preset: a link names presets only (download the "
                          "scene file to share it)")
    values = _model_values(simulation.model)
    if values["mass"] is None:
        raise LinkRefused("the masses differ from particle to particle: a link carries one mass")
    preset = _model_values(sim.scenes.build(name).model)
    pairs = [("scene", name)]
    pairs += [(key, _text(value)) for key, value in values.items()
              if _text(value) != _text(preset[key])]
    pairs += [("integrator", simulation.integrator), ("dt", _text(simulation.dt))]
    if view is not None:  # the page's choices, not its automatic ones
        default = ViewSettings()
        pairs += [(key, _text(getattr(view, field))) for key, field in VIEW.items()
                  if getattr(view, field) != getattr(default, field)]
    return urlencode(pairs)


def share_link(page_url: str, simulation: sim.Simulation, view: Any = None) -> str:
    """The page's address ``page_url`` (``http://host:port``) opening ``simulation``'s setup
    shown with ``view`` (``app.web.view.ViewSettings``, None: the automatic view)."""
    parts = urlsplit(page_url)
    scheme = "wss" if parts.scheme == "https" else "ws"
    encoded = base64.urlsafe_b64encode(setup_query(simulation, view).encode()).decode().rstrip(
        "=")
    socket = f"{scheme}://{parts.netloc}{SETUP_PATH}/{encoded}"
    return f"{page_url.rstrip('/')}/?websocket={quote(socket, safe='')}"


def _value(key: str, text: str) -> Any:
    if not text.isascii() or len(text) > 100:
        raise LinkRefused(f"{key}: {text[:20]!r} is not a number written in ASCII")
    if key in ("linear", "view_springs"):
        if text not in ("true", "false"):
            raise LinkRefused(f"{key}: {text!r} is neither true nor false")
        return text == "true"
    if key == "boundary":
        return text
    if key == "view_colour":
        if text not in COLOR_MODES:
            raise LinkRefused(f"view_colour: {text[:30]!r} is not one of {', '.join(COLOR_MODES)}")
        return text
    try:
        numbers = [float(part) for part in text.split(",")]
    except ValueError:
        raise LinkRefused(f"{key}: {text!r} is not a number") from None
    if not all(math.isfinite(number) for number in numbers):
        raise LinkRefused(f"{key}: {text!r} is not a finite number")
    if key == "gravity":
        return tuple(numbers) if len(numbers) > 1 else numbers[0]
    if len(numbers) != 1:
        raise LinkRefused(f"{key}: {text!r} is not one number")
    if key in WHOLE:
        if not numbers[0].is_integer():
            raise LinkRefused(f"{key}: {text!r} is not a whole number")
        return int(numbers[0])
    return numbers[0]


def setup_from_path(path: str) -> Setup | None:
    """The setup a page's connection path asks for (None: it asks for none); LinkRefused with
    the reason when a value is not one the page would take."""
    if not path.startswith(SETUP_PATH):
        return None
    if len(path) > MAX_LINK:
        raise LinkRefused(f"the link is over {MAX_LINK} characters")
    encoded = path[len(SETUP_PATH):].lstrip("/").split("?")[0]
    try:
        query = base64.urlsafe_b64decode(encoded + "=" * (-len(encoded) % 4)).decode("ascii")
    except (ValueError, UnicodeDecodeError):
        raise LinkRefused("the link's setup is not one this page made") from None
    pairs = parse_qsl(query, keep_blank_values=True, max_num_fields=len(SHARED) + len(VIEW) + 3)
    seen: dict[str, str] = {}
    for key, text in pairs:
        if key in seen:
            raise LinkRefused(f"{key} is given twice")
        if key not in (*SHARED, *VIEW, "scene", "integrator", "dt"):
            raise LinkRefused(f"the link names {key[:30]!r}, not a parameter of a scene")
        seen[key] = text
    scene = seen.pop("scene", "")
    if scene not in sim.scenes.names():
        raise LinkRefused(f"{scene[:30]!r} is not a preset")
    integrator = seen.pop("integrator", sim.scenes.presets.PRESETS[scene].integrator)
    if integrator not in ALL_INTEGRATORS:
        raise LinkRefused(f"{integrator[:30]!r} is not an integrator")
    dt = _value("dt", seen.pop("dt", _text(sim.scenes.presets.PRESETS[scene].dt)))
    if not 0.0 < dt <= MAX_DT:
        raise LinkRefused(f"dt = {dt:g} s; a link may ask for 0 < dt <= {MAX_DT:g} s")
    view = {key: _value(key, seen.pop(key)) for key in VIEW if key in seen}
    if "view_size" in view and not 0.2 <= view["view_size"] <= 3.0:
        raise LinkRefused(f"view_size: {view['view_size']:g}; the page's sizes are 0.2 to 3")
    return Setup(scene, {key: _value(key, text) for key, text in seen.items()}, integrator, dt,
                 view)
