"""Each private name of a library we borrow is read in one adapter module; these tests fail when
an installed version moves what the adapter reads (numba's cache locators are checked in
``tests/test_kernel_cache.py``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from app.cli import argparse_adapter, build_parser
from app.cli.arguments import command_from_arguments


def test_argparse_adapter_reads_a_parsers_actions():
    parser = argparse.ArgumentParser(prog="oscillators run")
    parser.add_argument("scene")
    parser.add_argument("--dt", type=float, default=0.01)
    parser.add_argument("--set", dest="overrides", action="append")
    found = argparse_adapter.actions(parser)
    assert [action.dest for action in found] == ["help", "scene", "dt", "overrides"]
    assert argparse_adapter.is_help(found[0]) and not argparse_adapter.is_help(found[2])
    assert [action.dest for action in argparse_adapter.options(parser)] == ["dt", "overrides"]
    arguments = parser.parse_args(["grid", "--dt", "0.02", "--set", "nx=4", "--set", "ny=3"])
    assert command_from_arguments(parser, arguments) == (
        "oscillators run grid --dt 0.02 --set nx=4 --set ny=3")


def test_argparse_adapter_finds_the_subcommands():
    commands = argparse_adapter.subcommands(build_parser())
    assert {"run", "serve", "record", "movie"} <= set(commands)
    assert argparse_adapter.subcommands(commands["run"]) == {}


def test_viser_adapter_reaches_every_internal_it_reads():
    """Each private name of viser the page reads (``app/web/viser_adapter.py``) is where the
    adapter looks for it on the installed viser."""
    import numpy as np
    import viser

    from app.web import viser_adapter
    from tests.helpers import free_port

    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        socket_server = viser_adapter.websocket_server(server)
        assert callable(socket_server.register_handler) and callable(socket_server.on_client_connect)
        assert viser_adapter.live_connections(server) == {}
        assert viser_adapter.live_connection(server, 12345) is None
        buffer = viser_adapter.broadcast_buffer(server)
        assert isinstance(buffer.message_counter, int) and isinstance(buffer.generator_cursors, dict)
        assert viser_adapter.event_loop(server) is not None
        assert callable(viser_adapter.incoming_dispatch(server))
        slider = server.gui.add_slider("x", 0.0, 1.0, 0.1, 0.5)
        state = viser_adapter.control_state(slider)
        assert (state.value, state.removed, state.is_button) == (0.5, False, False)
        assert hasattr(state.props, "disabled")
        assert viser_adapter.gui_input(server.gui, state.uuid) is slider
        assert state.uuid in viser_adapter.gui_inputs(server.gui)
        assert callable(viser_adapter.gui_queue(server.gui).queue_message)
        assert all(callable(handler) for handler in viser_adapter.gui_handlers(server.gui).values())
        assert isinstance(viser_adapter.upload_states(server.gui), dict)
        handler = Path(viser.__file__).parent / "client" / "src" / "MessageHandler.tsx"
        assert f'LOCAL_STORAGE_PREFIX = "{viser_adapter.LOCAL_STORAGE_PREFIX}"' in (
            handler.read_text())
        image = server.scene.add_image("/picture", np.zeros((2, 2, 3), np.uint8), 1.0, 1.0,
                                       format="jpeg")
        viser_adapter.set_image_bytes(image, b"\xff\xd8 picture")
        assert image._data == b"\xff\xd8 picture"
        for name in ("GuiUpdateMessage", "ScenePointerMessage", "ViewerCameraMessage",
                     "FileTransferStartUpload", "FileTransferPart", "ShareUrlRequest",
                     "ShareUrlDisconnect", "LocalStorageGetItemRequestMessage",
                     "LocalStorageGetItemResponseMessage", "GetRenderResponseMessage"):
            assert isinstance(getattr(viser_adapter.messages, name), type), name
    finally:
        server.stop()


def test_the_adapters_wire_functions_make_and_recognise_visers_messages():
    """The page's modules speak viser's protocol only through these functions."""
    from viser import _messages

    from app.web import viser_adapter

    update = _messages.GuiUpdateMessage("id", {"value": 1})
    assert viser_adapter.control_update(update) == ("id", {"value": 1})
    assert viser_adapter.message_name(update) == "GuiUpdateMessage"
    assert not viser_adapter.is_reply_or_camera(update)
    click = _messages.ScenePointerMessage(event_type="click", ray_origin=(0.0, 0.0, 1.0),
                                          ray_direction=(0.0, 0.0, -1.0), screen_pos=(),
                                          modifier=None)
    assert viser_adapter.is_pointer(click)
    assert viser_adapter.pointer_click(click) == ((0.0, 0.0, 1.0), (0.0, 0.0, -1.0))

    class Queue:
        sent: list = []

        def queue_message(self, message):
            self.sent.append(message)

    viser_adapter.show_control(Queue(), "id", {"disabled": True})
    assert Queue.sent[0].updates == {"disabled": True}
