"""Facts kept in one place: the parameter table holds a scene parameter's facts (every parameter of
a model has a row, the checks refuse a number outside the row's bounds, the recording's read-me and
the page's controls show the row's symbol and unit), and each energy term has one colour on the
page and in recordings."""

from __future__ import annotations

import pytest

import sim
from app.recording.explain import parameter_lines
from sim.model import parameters, schema


def test_every_parameter_of_a_model_has_a_row():
    for name in ("grid", "catenary", "double-slit", "resonance"):
        model = sim.scenes.build(name).model
        missing = set(model.parameters()) - set(parameters.names())
        assert not missing, f"{name}: {missing}"


@pytest.mark.parametrize("row", [row for row in parameters.rows() if row.bounds],
                         ids=lambda row: row.name)
def test_the_checks_hold_each_rows_bounds(row):
    low, high = row.bounds
    assert schema.parameter(high, row.name) == high
    with pytest.raises(schema.Refused, match=row.name):
        schema.parameter(high * 10 + 1, row.name)
    with pytest.raises(schema.Refused, match=row.name):
        schema.parameter(low - 1 - abs(low), row.name)


def test_a_scene_override_outside_the_bounds_is_refused():
    with pytest.raises(ValueError, match="stiffness"):
        sim.scenes.build("grid", stiffness=1e12)


def test_the_read_me_shows_each_rows_symbol_and_unit():
    scene = sim.scenes.build("grid")
    text = "\n".join(parameter_lines(scene.model))
    for name in [*scene.model.parameters(), "mass"]:
        row = parameters.get(name)
        assert f"| {name} | {row.symbol} |" in text
        assert row.help in text


def test_a_control_caption_carries_symbol_and_unit():
    assert parameters.get("stiffness").caption() == "Stiffness k (N/m)"
    assert parameters.get("damping").caption() == "Dashpot c (N s/m)"


def test_each_energy_term_has_one_colour_on_the_page_and_in_recordings():
    from app.colours import ENERGY_COLOURS, hex_colour
    from app.recording.style import TERM_COLOURS
    from app.web.folders.energy import LINES

    for term, line in LINES.items():
        assert line["stroke"] == hex_colour(ENERGY_COLOURS[term])
    for term, colour in TERM_COLOURS.items():
        assert colour == ENERGY_COLOURS[term]
    assert LINES["kinetic"]["stroke"] == hex_colour(TERM_COLOURS["kinetic"])
