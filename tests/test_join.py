"""A class's join address: ``http://host:port/join`` answers a student with the student page on
the address the student used (a class only), and the address is drawn as a QR code for the
terminal and the teacher's page."""

from __future__ import annotations

import http.client

import pytest

import sim
from app.web.app import WebApp
from app.web.join import JOIN_PATH, join_html, join_url, qr_png, qr_text
from app.web.roles import STUDENT_PATH
from tests.helpers import free_port, wait_for


def _get(app: WebApp, path: str, host: str) -> http.client.HTTPResponse:
    connection = http.client.HTTPConnection("127.0.0.1", app.server.get_port(), timeout=10)
    connection.request("GET", path, headers={"Host": host})
    return connection.getresponse()


@pytest.mark.parametrize("class_mode", [True, False])
def test_join_sends_a_student_to_the_student_page(tmp_path, class_mode):
    app = WebApp(sim.Simulation(sim.scenes.build("single")), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings",
                 class_mode=class_mode)
    app.start()
    try:
        assert wait_for(lambda: app.view.last_positions is not None)
        host = f"192.168.1.20:{app.server.get_port()}"
        response = _get(app, JOIN_PATH, host)
        if class_mode:
            assert response.status == 302
            assert response.getheader("Location") == f"/?websocket=ws://{host}{STUDENT_PATH}"
        else:
            assert response.status != 302  # no class, no student page to send anyone to
        assert _get(app, "/", host).status == 200  # the page itself as before
    finally:
        app.stop()


def test_the_join_address_is_drawn_as_a_qr_code():
    url = join_url(8080, "192.168.1.20")
    assert url == "http://192.168.1.20:8080/join"
    png = qr_png(url)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 200
    text = qr_text(url)
    assert len(text.splitlines()) >= 11 and "█" in text  # two rows of modules a line
    page = join_html(url)
    assert url in page and "data:image/png;base64," in page and 'alt="QR code of' in page
