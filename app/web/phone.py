"""A phone's page starts with its panel folded, so the lattice takes the screen.

viser shows its control panel on a narrow view as a floating panel over the lower part of the
view, expanded, and has no setting for its first state; clicking its title bar (the connection
status, "Connected") folds and unfolds it.  ``FOLD`` is the script the server sends each page when
it connects (``app.web.page_views``): on a view narrower than ``app.web.view.NARROW`` it clicks that
title bar once, the first time the page connects (not again when it reconnects, which would unfold
a panel the student opened), so the panel waits behind that one bar and the lattice and its colour
bar fill the view above it (``app.web.view.PHONE_PANEL_SHARE``).
"""

from __future__ import annotations

from app.web.view import NARROW

FOLD = """(() => {
  if (window.innerWidth >= NARROW || window.oscillatorsPanelFolded) return;
  window.oscillatorsPanelFolded = true;
  let tries = 0;
  const fold = () => {
    const bar = [...document.querySelectorAll("p, span, div")].find(
      (element) => element.children.length === 0 && element.textContent.trim() === "Connected");
    const play = [...document.querySelectorAll("button")].find(
      (element) => element.textContent.trim() === "Play");
    if (bar && play && play.offsetParent !== null) { bar.click(); return; }
    if (++tries < 100) setTimeout(fold, 100);
  };
  fold();
})();""".replace("NARROW", str(NARROW))
"""The script that folds a narrow page's panel the first time it connects."""
