"""A folder's *Download CSV* button: the table its plot shows (``app.csv_table``: each column's
quantity and unit in the header), sent to the page that pressed it, named after the scene."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import viser

from app.web.inputs import from_user
from sim.storage.files import safe_name


def add_csv_button(gui: Any, label: str, what: str, scene: Callable[[], str],
                   table: Callable[[], str], suffix: str) -> Any:
    """A button ``label`` that downloads ``table()`` (CSV text) as ``SCENE-suffix.csv``
    (``scene()``: the running scene's name, made a plain file name); ``what`` for its hint."""
    button = gui.add_button(label, icon=viser.Icon.TABLE_EXPORT,
                            hint=f"{what} as a table, each column's quantity and unit in its "
                            "header (CSV)")

    @button.on_click
    @from_user
    def _(event: viser.GuiEvent) -> None:
        try:
            text = table()
        except ValueError as error:  # a refused choice the table depends on: said there
            logging.getLogger(__name__).info("no table to download: %s", error)
            return
        name = f"{safe_name(scene())}-{suffix}.csv"
        event.client.send_file_download(name, text.encode(), save_immediately=True)

    return button
