"""The "Files" part of the page's "Scene" folder: save and open scene files.

*Download this scene* sends the current state and parameters to the user's browser (``.toml``, or
``.zip`` with per-particle arrays); *Open a scene file…* takes one from the user's computer.  The
server's own scene directory is offered by name only (``app.web.scene_files``): the page picks one
of the listed names and never sends a path.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import viser

import sim
from app.web.host import PanelHost
from app.web.inputs import InputRefused, from_user, ok_html
from app.web.scene_files import MAX_PAGE_PARTICLES
from app.web.widgets import ERRORS, download_name, say

NONE_LISTED = "(none)"
"""Entry of the server's list when its directory has no scene file."""


class SceneFileControls:
    """Builds the Files subfolder in the current GUI folder; ``message`` is the folder's message
    area."""

    def __init__(self, host: PanelHost, message: Callable[[], Any]) -> None:
        self.host = host
        gui = host.server.gui
        directory = host.scene_files.root.name or str(host.scene_files.root)
        with gui.add_folder("Files"):
            self.download_button = gui.add_button(
                "Download this scene", icon=viser.Icon.DOWNLOAD,
                hint="save the current state and parameters to your computer "
                "(.toml, or .zip when it carries per-particle arrays)",
            )
            self.upload_button = gui.add_upload_button(
                "Open a scene file…", icon=viser.Icon.UPLOAD, mime_type=".toml,.zip",
                hint="a .toml or .zip scene file from your computer",
            )
            self.server_scenes = gui.add_dropdown(
                f"In {directory}/", [NONE_LISTED], initial_value=NONE_LISTED,
                hint=f"scene files in the server's {directory}/ directory "
                "(serve --scenes-dir)",
            )
            self.open_button = gui.add_button("Open", icon=viser.Icon.FOLDER_OPEN)
            self.list_button = gui.add_button("Refresh list", icon=viser.Icon.REFRESH)
        self.list_server_scenes()

        @self.download_button.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            try:
                scene = host.control.snapshot().result(timeout=30)
                suffix, content = sim.scenes.scene_files.to_bytes(scene)
            except Exception as error:  # a failed save must not take the page down
                say(message(), error, "could not save")
                return
            name = download_name(scene.name) + suffix
            event.client.send_file_download(name, content, save_immediately=True)
            message().content = ok_html(f"sent {name} ({len(content):,} bytes)")

        @self.upload_button.on_upload
        @from_user
        def _(event: viser.GuiEvent) -> None:
            upload = self.upload_button.value
            name = str(upload.name)[:200]
            try:
                limit = sim.scenes.scene_files.MAX_UPLOAD_BYTES
                if len(upload.content) > limit:
                    raise InputRefused(f"the file is larger than {limit / 1e6:g} MB")
                scene = sim.scenes.scene_files.from_bytes(bytes(upload.content), name,
                                                   max_particles=MAX_PAGE_PARTICLES)
                host.replace_scene(scene, source=f"upload {name}")
            except ERRORS as error:
                say(message(), error, f"could not open {name}")
                return
            message().content = ok_html(f"opened {name}")

        @self.open_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            chosen = self.server_scenes.value
            try:
                scene = host.scene_files.load(chosen)
                host.replace_scene(scene, source=f"file {chosen}")
            except ERRORS as error:
                say(message(), error, "could not open")
                return
            message().content = ok_html(f"opened {chosen}")

        @self.list_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self.list_server_scenes()

    def list_server_scenes(self) -> None:
        names = self.host.scene_files.names() or [NONE_LISTED]
        self.server_scenes.options = names
        if self.server_scenes.value not in names:
            self.server_scenes.value = names[0]
        self.open_button.disabled = names == [NONE_LISTED]
