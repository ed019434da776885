"""Frames of a fresh run of a scene: the movie's frames are evenly spaced states of a private
``sim.Simulation``, its colour scales come from a look-ahead run (``app.recording.scales``)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

from app.movie.frames import State
from app.movie.options import FRAMES_PER_SIMULATED_SECOND, MAX_FRAMES, MovieOptions
from app.recording.options import DETAIL_LIMIT
from app.recording.scales import ColourScales, look_ahead


class SimulationSource:
    """Frames of a fresh run of ``scene``: its initial state at ``start_time`` (s; a snapshot of
    a running simulation starts at that simulation's time, and its frames say so)."""

    def __init__(self, scene: Any, options: MovieOptions, start_time: float = 0.0) -> None:
        from sim import Simulation

        self.start_time = start_time
        self.scene = scene
        self.model = scene.model
        self.simulation = Simulation(scene, integrator=options.integrator, dt=options.dt)
        dt = self.simulation.dt
        duration = options.duration or scene.duration
        steps = max(1, math.ceil(duration / dt - 1e-9))
        frames = options.frames or min(
            options.max_frames or MAX_FRAMES, steps + 1,
            max(2, round(duration * FRAMES_PER_SIMULATED_SECOND) + 1),
        )
        self.frames = frames
        self.steps = steps
        """Steps of the whole movie: frame k shows step round(k * steps / (frames - 1)), so the
        last frame is at the movie's duration (whole steps per frame would overshoot it)."""
        self.summary = (f"{scene.name}: {self.model.describe()}; {self.simulation.integrator}, "
                        f"dt={dt:g} s" + (f"; from t = {start_time:.2f} s" if start_time else ""))

    def scales(self, colour: str, watch: Any = None) -> ColourScales:
        """The colour scales of a look-ahead run; ``watch(simulation)`` before it steps."""
        quantity = "speed" if colour == "speed" else colour
        return look_ahead(self.scene, integrator=self.simulation.integrator,
                          dt=self.simulation.dt, quantity=quantity,
                          strains=colour == "strain" and self.model.n_particles <= DETAIL_LIMIT,
                          watch=watch)

    def states(self, velocities: bool, strains: bool) -> Iterator[State]:
        from sim import BlowUpError

        simulation = self.simulation
        done = 0
        for index in range(self.frames):
            target = round(index * self.steps / max(1, self.frames - 1))
            if target > done:
                try:
                    simulation.step(target - done)
                except BlowUpError:
                    return
                done = target
            yield State(
                self.start_time + simulation.time, simulation.peek_positions().copy(),
                simulation.velocities.copy() if velocities else None,
                simulation.strains() if strains else None,
            )
