"""What a page may send over its websocket, read before viser decodes a message.

``PAGE_MESSAGES`` names the viser message types the app handles; ``message_type`` reads only
the ``type`` field of a raw message (msgpack, as viser sends it); ``MessageBudget`` is the
per-page rate (a token bucket).  ``app.web.security.PageGate`` applies them to every message a
page sends.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import msgspec

PAGE_MESSAGES = frozenset({
    "ViewerCameraMessage",  # a page's camera (viser registers a client at its first one)
    "GuiUpdateMessage",  # a control's value
    "FileTransferStartUpload", "FileTransferPart",  # an upload
    "ScenePointerMessage",  # a click on the lattice
    "TransformControlsUpdateMessage", "TransformControlsDragStartMessage",
    "TransformControlsDragEndMessage",  # a drag of the gizmo
    "LocalStorageGetItemResponseMessage",  # a page's reply: it has drawn its picture
    "CommandTriggerMessage",  # a keyboard command the server registered (viser checks its id)
})
"""The viser message types the app handles; every other type a page sends is dropped unread."""
MESSAGE_RATE = 200.0
"""Messages a second one page may send (a browser sends its camera and a dragged control at
most about 60 times a second)."""
MESSAGE_BURST = 400.0
REFUSED_RATE = 10.0
"""Messages a second a page may send that its role refuses (a student's click on a control):
enough for a person, whose control is then set back on the page; more are dropped unread."""
FLOOD_SECONDS = 5.0
"""A page still over the rate this long after it first went over is disconnected."""


class _Head(msgspec.Struct):
    """The only field of a viser message read before it is let through."""

    type: str


_HEAD = msgspec.msgpack.Decoder(_Head)


def message_type(raw: Any) -> str | None:
    """The ``type`` of a raw viser message, or None when it is not one."""
    if not isinstance(raw, bytes):
        return None
    try:
        return _HEAD.decode(raw).type
    except (msgspec.DecodeError, msgspec.ValidationError):
        return None


@dataclass
class MessageBudget:
    """A token bucket: ``take(now)`` says whether one more message fits in the rate."""

    rate: float = MESSAGE_RATE
    burst: float = MESSAGE_BURST
    tokens: float = MESSAGE_BURST
    last: float = 0.0
    over_since: float | None = None
    """When the page went over the rate (None while it keeps to it)."""

    def take(self, now: float) -> bool:
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate)
        self.last = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            if self.tokens >= 0.5 * self.burst:
                self.over_since = None
            return True
        if self.over_since is None:
            self.over_since = now
        return False

    def flooding(self, now: float, seconds: float = FLOOD_SECONDS) -> bool:
        return self.over_since is not None and now - self.over_since > seconds
