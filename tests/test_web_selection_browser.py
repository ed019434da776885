"""The Selection folder in a real (headless) Chromium: a teacher types a row and a column and
presses each of the Select buttons; the server selects that particle, row, column or nothing, and
the folder says what is selected."""

from __future__ import annotations

import pytest

from tests.helpers import open_page, wait_for

pytestmark = pytest.mark.browser


def test_each_select_button_selects_what_it_names(web_app, browser):
    model = web_app.runner.simulation.model  # 11 x 7
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    open_page(page, web_app.url)
    for label, value in (("Row", "2"), ("Column", "3")):
        field = page.get_by_label(label, exact=True)
        field.fill(value)
        field.press("Enter")
    folder = web_app.panel.folders["selection"]
    assert wait_for(lambda: (folder.row.value, folder.column.value) == (2, 3))

    def selected() -> list[int]:
        return sorted(int(i) for i in web_app.view.selection)

    expected = {
        "particle": [2 * model.nx + 3],
        "row": [2 * model.nx + c for c in range(model.nx)],
        "column": [r * model.nx + 3 for r in range(model.ny)],
        "none": [],
    }
    words = {"particle": "Selected particle 25 (row 2, column 3)",
             "row": f"Selected {model.nx} particles", "column": f"Selected {model.ny} particles",
             "none": "Nothing selected"}
    for name in ("particle", "row", "column", "none"):
        page.get_by_role("button", name=name, exact=True).click()
        assert wait_for(lambda want=expected[name]: selected() == want), (name, selected())
        page.get_by_text(words[name]).wait_for(timeout=10_000)
    assert web_app.gate.refused == 0
