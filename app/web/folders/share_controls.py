"""The Scene folder's *Share this setup*: a link to the page that opens the running preset with
its parameters, integrator and dt (``app.web.share``), and the opening of such a link when a
page connects through one.

The link is made for the address the pressing page used (its connection's Host header), so it
works from the students' side of a class network as from this machine.  A page that connects
through a link runs its setup, unless it is a student's page of a class (students watch the
teacher's lattice); a link that asks for a value the page would refuse is refused with the
reason in the folder, and the running scene stays.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from typing import Any

import viser

from app.web import viser_adapter
from app.web.host import PanelHost
from app.web.inputs import from_user, ok_html
from app.web.share import LinkRefused, setup_from_path, share_link
from app.web.widgets import ERRORS, say


def _connection(host: PanelHost, client_id: int) -> Any:
    return viser_adapter.live_connection(host.server, client_id)


class ShareControls:
    """The button, the link it shows, and the opening of links (``message()``: the folder's
    message line)."""

    def __init__(self, host: PanelHost, message: Callable[[], Any]) -> None:
        self.host = host
        self.message = message
        gui = host.server.gui
        self.button = gui.add_button("Share this setup", icon=viser.Icon.LINK,
                                     hint="a link that opens this preset with its parameters, "
                                     "integrator and dt")
        self.link = gui.add_html("")

        @self.button.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            try:
                url = share_link(self._page_url(event.client_id), host.runner.simulation,
                                 host.view.settings)
            except ERRORS + (LinkRefused,) as error:
                say(self.message(), error, "cannot share")
                return
            shown = html.escape(url)
            self.link.content = (f'<div style="font-size:0.8em;padding:0 0.6em;overflow-wrap:'
                                 f'anywhere"><a href="{shown}">{shown}</a></div>')
            self.message().content = ok_html("the link above opens this setup")

        @host.server.on_client_connect
        def _(client: viser.ClientHandle) -> None:
            self.arrived(client.client_id)

    def _page_url(self, client_id: int) -> str:
        connection = _connection(self.host, client_id)
        headers = getattr(getattr(connection, "request", None), "headers", {}) or {}
        place = headers.get("Host") or self.host.server.get_host() + ":" + str(
            self.host.server.get_port())
        return f"http://{place}"

    def arrived(self, client_id: int) -> None:
        """Open the setup a page's link asks for, if it asks for one and may drive."""
        connection = _connection(self.host, client_id)
        path = getattr(getattr(connection, "request", None), "path", "") or ""
        roles = getattr(self.host, "roles", None)
        if roles is not None and client_id in roles.students:
            return  # a student's page watches the teacher's lattice
        try:
            setup = setup_from_path(path)
            if setup is None:
                return
            simulation = self.host.replace_scene(setup.build(), source="a shared link")
            setup.show(self.host.view.settings)  # after the new scene's automatic view
            view = getattr(self.host, "panel", None)
            if view is not None and "view" in view.folders:
                view.folders["view"].show_settings(simulation.model)
            self.host.refresh()
        except ERRORS + (LinkRefused,) as error:
            say(self.message(), error, "the shared link was refused")
            return
        self.message().content = ok_html(f"opened a shared link: {setup.scene}")
