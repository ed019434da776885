"""A class's join address for the board: ``http://ADDRESS:PORT/join``, short to type, and the
same as a QR code a phone scans, printed in the terminal and shown on the teacher's page
(``app.web.roles.ClassRoles``).  ``/join`` answers with the student page
(``app.web.security.AccessPolicy.redirect``)."""

from __future__ import annotations

import base64
import html
import io
import socket

JOIN_PATH = "/join"
"""The short address students type or scan (``http://host:port/join``): it answers with the
student page (``app.web.security.AccessPolicy.redirect``)."""


def lan_address() -> str:
    """This machine's address on its network (the one its default route leaves by; no packet
    is sent), or its host name when it has none."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect(("192.0.2.1", 9))  # a documentation address: only routing is asked
            return probe.getsockname()[0]
    except OSError:
        return socket.gethostname()


def join_url(port: int, address: str | None = None) -> str:
    """The join address on ``address`` (default: ``lan_address()``) and ``port``."""
    return f"http://{address or lan_address()}:{port}{JOIN_PATH}"


def _code(url: str):
    import qrcode

    code = qrcode.QRCode(border=2, error_correction=qrcode.constants.ERROR_CORRECT_M)
    code.add_data(url)
    code.make(fit=True)
    return code


def qr_text(url: str) -> str:
    """``url`` as a QR code drawn with block characters, for a terminal."""
    out = io.StringIO()
    _code(url).print_ascii(out=out, invert=True)
    return out.getvalue()


def qr_png(url: str, box: int = 8) -> bytes:
    """``url`` as a QR code, a PNG with ``box`` pixels a module."""
    code = _code(url)
    code.box_size = box
    out = io.BytesIO()
    code.make_image(fill_color="black", back_color="white").save(out, format="PNG")
    return out.getvalue()


def join_html(url: str) -> str:
    """The teacher's panel: the join address large enough to read from the back of a room, and
    its QR code."""
    picture = base64.b64encode(qr_png(url)).decode()
    shown = html.escape(url)
    return ('<div style="padding:0 0.6em;text-align:center">'
            '<div style="font-size:0.85em">Students join at</div>'
            f'<div style="font-size:1.4em;font-weight:700;overflow-wrap:anywhere">{shown}</div>'
            f'<img alt="QR code of {shown}" src="data:image/png;base64,{picture}" '
            'style="width:60%;max-width:220px;image-rendering:pixelated"></div>')
