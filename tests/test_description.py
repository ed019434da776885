"""The lattice in words: the sentences name the time, where the largest motion is, the share of
the energy in motion, and what the followed particle does, from a frame of a known state."""

from __future__ import annotations

import sim
from app.web.description import describe
from app.web.folders.description import live_html
from sim.runtime.runner import Frame


def _frame(simulation: sim.Simulation, playing: bool = True) -> Frame:
    return Frame(step=simulation.step_count, time=simulation.time,
                 integrator=simulation.integrator, dt=simulation.dt, model=simulation.model,
                 positions=simulation.positions.copy(), energy=simulation.energy(),
                 playing=playing, energy_balance_error=simulation.energy_balance_error())


def test_the_words_say_where_the_motion_and_the_energy_are():
    simulation = sim.Simulation(sim.scenes.build("grid", nx=9, ny=6), integrator="verlet",
                                dt=0.01)
    simulation.positions[:] = simulation.model.rest_positions
    index = 4 * 9 + 7  # column 7, row 4: the top right of a 9 x 6 lattice
    simulation.positions[index] += (-0.003, 0.0)
    text = describe(_frame(simulation, playing=False), followed=index)
    assert "t = 0 s, step 0, paused" in text
    assert "A lattice of 9 × 6 particles" in text
    assert "largest motion is 3 mm, at particle (column 7, row 4), in the top right" in text
    assert "0 % in motion, 100 % stored in the springs" in text
    assert "You follow particle (column 7, row 4): 3 mm left of its place." in text
    simulation.step(20)
    later = describe(_frame(simulation), followed=None)
    assert "t = 0.2 s, step 20, playing" in later and "You follow" not in later
    assert "% in motion" in later and "0 % in motion" not in later


def test_the_words_are_a_live_region_shown_as_text():
    region = live_html("<b>t = 1 s</b>")
    assert 'aria-live="polite"' in region and 'role="status"' in region
    assert "&lt;b&gt;" in region and "<b>" not in region



def test_a_new_lattice_is_said_at_once(web_app):
    folder = web_app.panel.folders["description"]
    web_app.replace_scene(sim.scenes.build("chain"), source="test")
    assert "A new lattice: chain, 5 × 1 particles" in folder.words.content
