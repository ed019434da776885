"""``rr`` and ``rrb``: rerun and its blueprint module, imported at their first use.

The recording's options (what the command line's parsers read) live beside the code that logs
with rerun; importing rerun takes about 0.2 s, which ``oscillators record --help`` and
``movie --help`` need not wait for.  The modules on that path take ``rr`` / ``rrb`` from here;
each attribute (``rr.Scalars``, ``rrb.Horizontal``, ...) imports rerun the first time it is read.
"""

from __future__ import annotations

import importlib
from typing import Any


class _Module:
    """A module imported when one of its attributes is first read."""

    def __init__(self, name: str) -> None:
        self._name = name

    def __getattr__(self, attribute: str) -> Any:
        return getattr(importlib.import_module(self._name), attribute)


rr: Any = _Module("rerun")
"""``import rerun as rr``, at first use."""
rrb: Any = _Module("rerun.blueprint")
"""``import rerun.blueprint as rrb``, at first use."""
