"""The overlay of a run's HTML page (``app.movie.html``): the title (scene, integrator, dt),
the simulated time and the colour bar, whose numbers follow viser's player (its playback time,
``app.movie.viser_page.PLAYBACK_TIME_JS``, picks the frame and so the limit of the scale in use),
and the "About this run" button that opens the read-me panel.  Plain HTML, CSS and a few lines
of JavaScript: nothing is fetched."""

from __future__ import annotations

import html
import json
from typing import Any

import numpy as np

from app.colours import make_scale
from app.movie import viser_page


def overlay(scene: Any, integrator: str, dt: float, lattice: Any, label: str,
            times: list[float], limits: list[float], start: float, readme: str
            ) -> tuple[str, str]:
    """(style for <head>, elements and script for <body>): title, time, colour bar, read-me."""
    table = lattice.scheme.lines.table() if lattice.small else lattice.scheme.field.table()
    stops = ", ".join(f"rgb({r},{g},{b}) {100 * k / 16:.2f}%" for k, (r, g, b) in enumerate(
        table[np.linspace(0, 255, 17).round().astype(int)]))
    unit_scale = make_scale(lattice.scale.policy, 1.0, lattice.scale.signed)
    ticks = [[position, value] for position, value in unit_scale.ticks()]
    description = f": {scene.description}" if scene.description else ""
    data = json.dumps({"times": [round(t, 5) for t in times],
                       "limits": [float(f"{v:.4g}") for v in limits],
                       "ticks": ticks, "start": start})
    head = f"<style>{STYLE}</style>"
    heights = (f" · heights drawn {lattice.exaggeration:g} times larger"
               if lattice.exaggeration != 1.0 else "")
    body = f"""
<div id="co-title"><div class="co-name">{html.escape(scene.name)}<span class="co-description"
>{html.escape(description)}</span></div>
<div class="co-run">{html.escape(scene.name)} · {html.escape(integrator)}, dt = {dt:g} s ·
{html.escape(lattice.model.describe())}{heights}</div></div>
<div id="co-time">t = {start:.2f} s</div>
<button id="co-about" type="button">About this run</button>
<div id="co-readme" hidden><button id="co-close" type="button">Close</button>{readme}</div>
<div id="co-bar"><div class="co-label">{html.escape(label)}</div>
<div class="co-gradient" style="background: linear-gradient(to right, {stops})"></div>
<div class="co-ticks"></div><div class="co-caption">{html.escape(lattice.scale.describe())}</div>
</div>
<script>
const CO = {data};
{viser_page.PLAYBACK_TIME_JS}
function coNumber(v) {{ return v === 0 ? "0" : String(Number(v.toPrecision(2))); }}
function coShow(seconds) {{
  let low = 0, high = CO.times.length - 1;
  while (low < high) {{
    const mid = (low + high + 1) >> 1;
    if (CO.times[mid] <= seconds + 1e-6) low = mid; else high = mid - 1;
  }}
  document.getElementById("co-time").textContent = "t = " + (CO.start + seconds).toFixed(2) + " s";
  const limit = CO.limits[low];
  const ticks = document.querySelector("#co-bar .co-ticks");
  ticks.innerHTML = "";
  CO.ticks.forEach(([position, value], k) => {{
    const mark = document.createElement("span");
    mark.textContent = coNumber(value * limit);
    mark.style.left = (100 * position) + "%";
    mark.className = k === 0 ? "first" : k === CO.ticks.length - 1 ? "last" : "";
    ticks.appendChild(mark);
  }});
}}
coShow(0);
setInterval(() => {{ const s = playbackSeconds(); if (s !== null && isFinite(s)) coShow(s); }}, 100);
const coReadme = document.getElementById("co-readme");
document.getElementById("co-about").onclick = () => {{ coReadme.hidden = false; }};
document.getElementById("co-close").onclick = () => {{ coReadme.hidden = true; }};
</script>
"""
    return head, body


STYLE = """
#co-title { position: fixed; top: 8px; left: 12px; right: 190px; z-index: 20; font: 15px/1.3
  system-ui, sans-serif; color: #141414; background: rgba(255,255,255,0.85); padding: 4px 8px;
  border-radius: 4px; pointer-events: none; }
#co-title .co-name { font-weight: 600; }
#co-title .co-run { font-size: 13px; color: #333; }
#co-time { position: fixed; top: 8px; right: 12px; z-index: 20; font: 600 20px/1.3 ui-monospace,
  monospace; color: #141414; background: rgba(255,255,255,0.85); padding: 4px 8px;
  border-radius: 4px; }
#co-about { position: fixed; top: 48px; right: 12px; z-index: 20; font: 13px system-ui,
  sans-serif; padding: 4px 10px; border: 1px solid #888; border-radius: 4px; background: #fff;
  cursor: pointer; }
#co-readme { position: fixed; top: 84px; right: 12px; left: 12px; max-width: 760px;
  margin-left: auto; bottom: 60px; overflow: auto; z-index: 30; background: #fff; color: #141414;
  font: 14px/1.45 system-ui, sans-serif; padding: 10px 18px; border: 1px solid #aaa;
  border-radius: 6px; box-shadow: 0 4px 18px rgba(0,0,0,0.2); }
#co-readme table { border-collapse: collapse; font-size: 13px; }
#co-readme td, #co-readme th { border: 1px solid #ccc; padding: 2px 6px; text-align: left; }
#co-close { float: right; }
#co-bar { position: fixed; left: 12px; bottom: 58px; width: min(420px, calc(100vw - 24px));
  z-index: 20; background: rgba(255,255,255,0.9); padding: 6px 10px 4px; border-radius: 4px;
  font: 13px/1.3 system-ui, sans-serif; color: #141414; box-sizing: border-box; }
#co-bar .co-gradient { height: 14px; margin-top: 3px; }
#co-bar .co-ticks { position: relative; height: 18px; }
#co-bar .co-ticks span { position: absolute; top: 2px; transform: translateX(-50%);
  font-size: 12px; white-space: nowrap; }
#co-bar .co-ticks span.first { transform: none; }
#co-bar .co-ticks span.last { transform: translateX(-100%); }
#co-bar .co-caption { font-size: 11px; color: #555; }
@media (max-width: 600px) {  /* a phone: the title one line, the rest under "About this run" */
  #co-title { right: 118px; font-size: 14px; }
  #co-title .co-description, #co-title .co-run { display: none; }
  #co-time { font-size: 16px; }
  #co-about { top: 42px; font-size: 12px; }
  #co-readme { top: 76px; bottom: 12px; left: 8px; right: 8px; padding: 8px 12px; }
  #co-bar { bottom: 52px; left: 8px; width: calc(100vw - 16px); }
}
"""
