"""The projector view of one page: large, black text, a colour bar twice as readable and a more
saturated lattice, for a classroom projector that washes colours out.  Toggled per page by the
View folder's *Projector view (this page)*, in that page alone (a script the server sends it,
``viser_adapter.run_javascript``); the other pages keep their view.

Measured in the page (``tests/test_web_projector_browser.py``, Chromium at 1366x768): the
panel's labels from 13 to 17.5 CSS px and from grey (contrast 3.3:1 on their background) to
black on white (21:1), the colour bar's smallest text from 9.5 to about 16.9 CSS px.
"""

from __future__ import annotations

import json

ROOT_FONT = 20
"""CSS px of the page's root font in the projector view (viser's panel sizes its text in rem:
16 px by default)."""
COLOUR_BAR_ZOOM = 1.8
"""How much larger the floating colour bar is drawn (its smallest text from about 9.5 px),
scaled about its bottom-left corner so that it stays in the view."""
LATTICE_FILTER = "contrast(1.25) saturate(1.5)"
"""What the 3-D view's colours get, to stay apart on a washed-out projector."""
CLASS = "oscillators-projector"

STYLE = f"""
html.{CLASS} {{ font-size: {ROOT_FONT}px; }}
html.{CLASS} label, html.{CLASS} .mantine-Text-root, html.{CLASS} .mantine-InputWrapper-label,
html.{CLASS} .mantine-Input-input {{ color: #000 !important; font-weight: 600; }}
html.{CLASS} canvas {{ filter: {LATTICE_FILTER}; }}
"""

_SCRIPT = """(() => {
  const root = document.documentElement;
  if (!document.getElementById("CLASS")) {
    const style = document.createElement("style");
    style.id = "CLASS";
    style.textContent = STYLE;
    document.head.appendChild(style);
  }
  const on = root.classList.toggle("CLASS");
  const tab = [...document.querySelectorAll("span, button, div")].find(
    (element) => element.textContent === "Colours" && element.children.length === 0);
  const bar = tab && tab.closest(".mantine-Paper-root");
  if (bar) {  // scaled about its bottom-left corner: it grows into the view, never out of it
    bar.style.transformOrigin = "bottom left";
    bar.style.transform = on ? "scale(ZOOM)" : "";
  }
})();"""
TOGGLE = (_SCRIPT.replace("CLASS", CLASS).replace("STYLE", json.dumps(STYLE))
          .replace("ZOOM", str(COLOUR_BAR_ZOOM)))
"""The script that turns the projector view on in a page, or off when it is on."""
