"""The one place the page reads viser's private names (viser 1.1.1, pinned in ``pyproject.toml``).

viser has no public API for what the page's safety and pacing need: the websocket server's live
connections and its dispatch of what pages send, a connection's own message queue, the broadcast
buffer's cursors, a GUI control's state by its id, an image node's bytes, the file transfers
under way, the prefix of the page's local-storage keys. Every such read or write is a function
here, so a viser upgrade that moves one breaks this module alone, and ``tests/test_adapters.py``
fails at once on a version whose internals moved (before any page misbehaves).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

from viser import _messages

messages = _messages
"""viser's message classes (``GuiUpdateMessage``, ``ScenePointerMessage``, ...)."""

Dispatch = Callable[[int, Any], Awaitable[None]]

LOCAL_STORAGE_PREFIX = "viser-user:"
"""What viser's page puts before the key of a local-storage message (its
``client/src/MessageHandler.tsx``): a script on the page writes a value the server will ask for
under this prefix and the key."""


def websocket_server(server: Any) -> Any:
    """The ``viser.infra.WebsockServer`` behind a ``ViserServer``."""
    return server._websock_server


def live_connections(server: Any) -> dict[int, Any]:
    """A copy of the open websocket connections by client id."""
    return dict(websocket_server(server)._live_connections)


def live_connection(server: Any, client_id: int) -> Any | None:
    """The open websocket connection of page ``client_id``, or None."""
    return websocket_server(server)._live_connections.get(client_id)


def broadcast_buffer(server: Any) -> Any:
    """The buffer of messages sent to every page (``message_counter``, ``generator_cursors``)."""
    return websocket_server(server)._broadcast_buffer


def event_loop(server: Any) -> Any | None:
    """The event loop viser's server runs on (None before it starts)."""
    return websocket_server(server)._background_event_loop


def incoming_dispatch(server: Any) -> Dispatch:
    """viser's handler of every message a page sends."""
    return websocket_server(server)._handle_incoming_message


def replace_incoming_dispatch(server: Any, dispatch: Dispatch) -> None:
    """Put ``dispatch`` in place of viser's handler of what pages send (a gate in front of it)."""
    websocket_server(server)._handle_incoming_message = dispatch


def client_queue(client: Any) -> Any:
    """The message queue of one page (``queue_message``): what is sent to that page alone."""
    return client._websock_connection


def gui_inputs(gui: Any) -> dict[str, Any]:
    """The GUI controls by id (a live dict: copy before iterating from another thread)."""
    return gui._gui_input_handle_from_uuid


def gui_input(gui: Any, uuid: Any) -> Any | None:
    """The GUI control of id ``uuid``, or None."""
    return gui._gui_input_handle_from_uuid.get(uuid)


def control_state(handle: Any) -> Any:
    """A control's state record (``value``, ``removed``, ``is_button``, ``props``, ``uuid``)."""
    return handle._impl


def gui_queue(gui: Any) -> Any:
    """The GUI API's message queue to every page."""
    return gui._websock_interface


def gui_handlers(gui: Any) -> dict[str, Callable[..., Any]]:
    """viser's own handlers of a control update, a file upload's start and its parts."""
    return {"update": gui._handle_gui_updates, "start": gui._handle_file_transfer_start,
            "part": gui._handle_file_transfer_part}


def upload_states(gui: Any) -> dict[Any, Any]:
    """The file uploads under way by transfer id (a live dict)."""
    return gui._current_file_upload_states


def set_image_bytes(handle: Any, data: bytes) -> None:
    """Replace an image node's encoded picture without encoding it again."""
    handle._data = data


async def dispatch_from(connection: Any, message: Any) -> None:
    """Hand ``message`` to viser as if page ``connection`` had sent it."""
    await connection._handle_incoming_message(connection.client_id, message)


# --- viser's wire messages: made, recognised and handled here alone ---------------------------

_STUDENT_MESSAGES = (_messages.ViewerCameraMessage, _messages.GetRenderResponseMessage,
                     _messages.LocalStorageGetItemResponseMessage)
STUDENT_MESSAGE_NAMES = frozenset(message.__name__ for message in _STUDENT_MESSAGES)
"""The types of message a watching page may send (``is_reply_or_camera``)."""


def message_name(message: Any) -> str:
    """The name of a page's message type ("GuiUpdateMessage", ...), for logs."""
    return type(message).__name__


def is_reply_or_camera(message: Any) -> bool:
    """Whether a page's message is its own camera or a reply to the server's request (all a
    watching page may send)."""
    return isinstance(message, _STUDENT_MESSAGES)


def pointer_click(message: Any) -> tuple[Any, Any] | None:
    """(ray origin, ray direction) of a click in the 3-D view, or None for any other message."""
    if (isinstance(message, _messages.ScenePointerMessage) and message.event_type == "click"
            and message.ray_origin and message.ray_direction):
        return message.ray_origin, message.ray_direction
    return None


def is_pointer(message: Any) -> bool:
    """Whether a page's message is a pointer event in the 3-D view."""
    return isinstance(message, _messages.ScenePointerMessage)


def control_update(message: Any) -> tuple[Any, dict] | None:
    """(control id, updates) of a page's change to a control, or None for another message."""
    if isinstance(message, _messages.GuiUpdateMessage):
        return message.uuid, message.updates
    return None


def show_control(queue: Any, uuid: Any, updates: dict[str, Any]) -> None:
    """Queue, on one page's or every page's ``queue``, a control's ``updates`` (its value, or
    whether it is disabled)."""
    queue.queue_message(_messages.GuiUpdateMessage(uuid, updates))


def ask_local_storage(client: Any, key: str, request_uuid: str) -> None:
    """Ask page ``client`` for its local-storage value ``key``; the reply carries
    ``request_uuid`` (``on_local_storage_reply``)."""
    client_queue(client).queue_message(
        _messages.LocalStorageGetItemRequestMessage(key=key, request_uuid=request_uuid))


def run_javascript(client: Any, source: str) -> None:
    """Run ``source`` on page ``client``."""
    client_queue(client).queue_message(_messages.RunJavascriptMessage(source=source))


def on_local_storage_reply(server: Any, handler: Callable[[int, Any], Any]) -> None:
    """Call ``handler(client_id, reply)`` (``reply.request_uuid``, ``reply.value``) for every
    page's local-storage reply."""
    websocket_server(server).register_handler(_messages.LocalStorageGetItemResponseMessage,
                                              handler)


def off_local_storage_reply(server: Any, handler: Callable[[int, Any], Any]) -> None:
    """Stop calling ``handler`` (nothing if it was not registered)."""
    try:
        websocket_server(server).unregister_handler(
            _messages.LocalStorageGetItemResponseMessage, handler)
    except (AssertionError, ValueError):
        pass
