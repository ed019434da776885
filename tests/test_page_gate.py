"""The page gate, in front of every message a page sends: a button group's press is the name of
one of its buttons; an upload is its own page's."""

from __future__ import annotations

from typing import Any


def test_the_gate_lets_a_button_groups_names_through_and_nothing_else(web_app):
    """A button group's press arrives as the name of the button pressed; a plain button's as
    True.  Anything else is refused before a callback runs."""
    from types import SimpleNamespace

    gate, panel = web_app.gate, web_app.panel
    gate.connected.add(99)

    def verdict(handle: Any, value: Any) -> str | None:
        message = SimpleNamespace(uuid=handle._impl.uuid, updates={"value": value})
        return gate.accept_page_value(99, message)

    group = panel.selection.select_buttons
    for name in ("particle", "row", "column", "none"):
        assert verdict(group, name) is None
    for bad in (True, "rows", "", None, 3, ["row"]):
        assert "button group" in verdict(group, bad)
    button = panel.scene.build_button
    assert verdict(button, True) is None
    assert "only a press" in verdict(button, "particle")


def test_an_upload_is_its_pages_own(web_app):
    """Two pages using the same transfer id: the second's start and parts are refused, the
    first page's upload arrives whole."""
    from types import SimpleNamespace

    gate, files = web_app.gate, web_app.panel.scene.files
    gate.connected.update({7, 8})
    text = b'name = "mine"\n[model]\nnx = 3\nny = 2\n'

    def start(client: int, transfer: str) -> None:
        gate._upload_start(client, SimpleNamespace(
            transfer_uuid=transfer, source_component_uuid=files.upload_button._impl.uuid,
            filename="mine.toml", mime_type="text/plain", part_count=2, size_bytes=len(text)))

    def part(client: int, transfer: str, index: int, content: bytes) -> None:
        gate._upload_part(client, SimpleNamespace(
            transfer_uuid=transfer, source_component_uuid=files.upload_button._impl.uuid,
            part_index=index, content=content))

    from app.web import viser_adapter

    states = viser_adapter.upload_states(web_app.server.gui)
    refused = gate.refused
    start(7, "same")
    start(8, "same")  # another page, the same id
    part(8, "same", 0, text[:10])  # another page's part
    assert gate.refused == refused + 2
    assert states["same"]["client_id"] == 7 and states["same"]["transferred_bytes"] == 0
    part(7, "same", 0, text[:10])
    part(7, "same", 1, text[10:])
    assert "same" not in states and gate.refused == refused + 2  # arrived whole
