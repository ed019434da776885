"""Checks for every value a page sends, and safe display of text.

A browser's min/max are hints, not limits: a page (or anything speaking viser's protocol) can send
any number, NaN or infinity included, and any string for a dropdown.  The panel passes every value
through these functions (the checks of ``sim.model.schema``, which scene files and ``--set`` pass too)
before it becomes a command (and ``from_user`` keeps callbacks from
acting on values the server assigned itself); a bad one raises ``InputRefused`` with a
message for the page, and nothing changes.  Text shown in the page goes through ``as_html`` so a
name or an error message is always shown as text, never as markup.
"""

from __future__ import annotations

import functools
import html
import inspect
from collections.abc import Callable, Sequence
from typing import Any

import viser

from sim.model import schema


class InputRefused(schema.Refused):
    """A value from the page was refused (the message says why, for the page)."""


def number(value: Any, name: str, low: float, high: float, *, low_open: bool = False) -> float:
    """``value`` as a finite float in [low, high] (or (low, high] with ``low_open``); a string
    or a boolean is refused (``sim.model.schema.number``, the check scene files and ``--set`` pass)."""
    return schema.number(value, name, low, high, low_open=low_open, error=InputRefused)


def whole_number(value: Any, name: str, low: int, high: int) -> int:
    """``value`` as an int in [low, high]; a fractional number is refused, not rounded."""
    return schema.whole_number(value, name, low, high, error=InputRefused)


def choice(value: Any, name: str, options: Sequence[str]) -> str:
    """``value`` if it is one of ``options``."""
    return schema.choice(value, name, options, error=InputRefused)


def from_user(function: Callable[[viser.GuiEvent], Any]) -> Callable[[viser.GuiEvent], Any]:
    """Run ``function`` only for events a browser sent (``event.client`` set); viser also calls
    ``on_update`` when the server itself assigns a value, and those must not post commands.
    Keeps ``function`` async (ordered on viser's event loop) or sync (its thread pool)."""
    if inspect.iscoroutinefunction(function):

        @functools.wraps(function)
        async def wrapper_async(event: viser.GuiEvent) -> Any:
            if event.client is None:
                return None
            return await function(event)

        return wrapper_async

    @functools.wraps(function)
    def wrapper(event: viser.GuiEvent) -> Any:
        if event.client is None:
            return None
        return function(event)

    return wrapper


def as_html(text: str, color: str | None = None, bold: bool = False) -> str:
    """``text`` escaped into a small ``<div>`` (line breaks kept), safe to show in the page."""
    style = "font-size:0.85em;padding:0 0.6em;white-space:pre-wrap;overflow-wrap:anywhere"
    if color:
        style += f";color:{color}"
    if bold:
        style += ";font-weight:600"
    return f'<div style="{style}">{html.escape(text)}</div>'


def ok_html(text: str) -> str:
    return as_html(text, color="#2b7a2b")


def warning_html(text: str) -> str:
    return as_html(text, color="#c0392b", bold=True)


def amber_html(text: str) -> str:
    return as_html(text, color="#b9770e")
