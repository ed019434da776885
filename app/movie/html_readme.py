"""The read-me of a run shared as one HTML file (``app.movie.html``): what a recording's
document says (``app.recording.explain``), as HTML for a panel of its own: the scene, its
parameters with symbols and units, the initial state, the run (integrator, dt, the time shown),
the command that made the file, the versions, and how to read the colours."""

from __future__ import annotations

import html
import re
from typing import Any

from app.recording.explain import describe_forcing, describe_initial, parameter_rows, versions


def _inline(text: str) -> str:
    """Escaped ``text`` with markdown's **bold** and `code` as HTML."""
    text = html.escape(text)
    text = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", text)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", text)


def _markdown_list(lines: list[str]) -> str:
    """Markdown bullet lines (``* ``, nested with two spaces) as HTML lists; other lines as
    paragraphs (headings ``##`` as <h3>)."""
    out: list[str] = []
    depth = 0
    for line in lines:
        stripped = line.lstrip()
        level = (len(line) - len(stripped)) // 2 + 1 if stripped.startswith("* ") else 0
        while depth > level:
            out.append("</ul>")
            depth -= 1
        while depth < level:
            out.append("<ul>")
            depth += 1
        if level:
            out.append(f"<li>{_inline(stripped[2:])}</li>")
        elif stripped.startswith("#"):
            out.append(f"<h3>{_inline(stripped.lstrip('#').strip())}</h3>")
        elif stripped:
            out.append(f"<p>{_inline(stripped)}</p>")
    out += ["</ul>"] * depth
    return "\n".join(out)


def readme_html(scene: Any, *, integrator: str, dt: float, start: float, end: float,
                frames: int, colours: str, command: str | None, source: str) -> str:
    """The read-me panel's HTML.  ``start``/``end``: the simulated seconds the file shows;
    ``colours``: how to read the colours (plain text); ``command``: the command line that made
    the file (None: made on the web page); ``source``: where the frames come from."""
    model = scene.model
    rows = ["<tr>" + "".join(f"<td>{html.escape(cell)}</td>" for cell in cells) + "</tr>"
            for cells in parameter_rows(model)]
    parts = [
        f"<h2>{html.escape(scene.name)}</h2>",
        f"<p>{_inline(scene.description or '')}</p>",
        f"<p><b>{html.escape(model.describe())}</b></p>",
        "<h3>Scene parameters (SI units)</h3>",
        "<table><tr><th>parameter</th><th>symbol</th><th>value</th><th>unit</th>"
        "<th>meaning</th></tr>" + "".join(rows) + "</table>",
        "<h3>Initial state</h3>",
        _markdown_list(describe_initial(scene)),
        _markdown_list(describe_forcing(model)),
        "<h3>The run</h3>",
        _markdown_list([
            f"* integrator **{integrator}**, time step dt = {dt:g} s",
            f"* shown: t = {start:.2f} s to {end:.2f} s of simulated time in {frames} frames; "
            "the player plays one simulated second per second (its menu: 0.5x to 8x)",
            f"* frames from: {source}",
            "* made by: " + (f"`{command}`" if command else "the web page (oscillators serve)"),
        ]),
        "<h3>How to read the colours</h3>",
        f"<p>{_inline(colours)}</p>",
        "<h3>In the page</h3>",
        "<p>Drag to turn the lattice, scroll to zoom, right-drag to pan; the bar at the bottom "
        "plays, pauses (space bar) and moves through the run. The time and the colour bar's "
        "numbers follow the player.</p>",
        "<h3>Versions</h3>",
        _markdown_list([f"* {name} {version}" for name, version in versions().items()]),
    ]
    return "\n".join(parts)
