"""A run as one HTML file: `oscillators movie SCENE -o NAME.html` writes a page that Chromium opens
from file:// with every network request blocked; its 3-D view shows the lattice and plays (two
screenshots seconds apart differ), its overlay's time follows viser's player (this notices when
viser's player changes: ``app.movie.viser_page``), and its read-me panel says what the run is."""

from __future__ import annotations

import io
import time
from pathlib import Path

import numpy as np
import pytest

import sim
from app.cli import main


def open_offline(browser, path: Path, size: dict | None = None):
    """A page at ``size`` that loads ``path`` from disk with every other request aborted;
    returns (page, the list of aborted URLs)."""
    page = browser.new_page(viewport=size or {"width": 1366, "height": 768})
    aborted: list[str] = []

    def route(request_route):
        url = request_route.request.url
        if url.startswith("file://"):
            request_route.continue_()
        else:
            aborted.append(url)
            request_route.abort()

    page.route("**/*", route)
    page.goto(path.as_uri())
    page.wait_for_selector("canvas", timeout=60_000)
    return page, aborted


def canvas_picture(page) -> np.ndarray:
    from PIL import Image

    png = page.locator("canvas").first.screenshot(timeout=60_000)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def check_plays(browser, path: Path, shots: str) -> tuple[np.ndarray, np.ndarray]:
    page, aborted = open_offline(browser, path)
    time.sleep(3)
    early_time = page.locator("#co-time").text_content()
    early = canvas_picture(page)
    page.screenshot(path=f"{shots}-early.png")
    time.sleep(4)
    late_time = page.locator("#co-time").text_content()
    late = canvas_picture(page)
    page.screenshot(path=f"{shots}-late.png")
    assert aborted == []  # it asked for nothing beyond the file
    for picture in (early, late):  # the lattice, not one colour
        flat = picture.reshape(-1, 3)
        background = np.median(flat, axis=0)
        assert (np.abs(flat - background).max(axis=1) > 60).mean() > 0.01
    assert np.abs(early - late).max(axis=2).mean() > 0.5 or (
        np.abs(early - late).max(axis=2) > 40).mean() > 0.002  # it plays
    assert early_time != late_time and early_time.startswith("t = "), (early_time, late_time)
    page.get_by_text("About this run").click()
    readme = page.locator("#co-readme")
    assert readme.is_visible()
    text = readme.text_content()
    for words in ("stiffness", "N/m", "oscillators movie", "How to read the colours",
                  "Versions", "rerun-sdk"):
        assert words in text, words
    return early, late


@pytest.mark.slow  # a movie rendered, then played in Chromium (other browser tests run by default)
def test_the_grid_as_one_html_file_plays_offline(tmp_path, browser):
    path = tmp_path / "grid.html"
    assert main(["movie", "grid", "-o", str(path), "--duration", "10", "--quiet"]) == 0
    assert path.stat().st_size < 3e6
    document = path.read_text()
    assert "grid" in document and "rk4, dt = 0.01 s" in document
    check_plays(browser, path, str(tmp_path / "grid"))


def test_a_page_refuses_other_names_and_says_its_length(tmp_path, capsys):
    assert main(["movie", "grid", "-o", str(tmp_path / "grid.htm"), "--quiet"]) == 2
    path = tmp_path / "short.html"
    assert main(["movie", "grid", "-o", str(path), "--duration", "2", "--fps", "5"]) == 0
    said = capsys.readouterr().out
    assert "11 frames showing t = 0.00 s to 2.00 s" in said, said


@pytest.mark.slow
def test_a_short_flagship_run_as_one_html_file_plays_offline(tmp_path, browser):
    path = tmp_path / "interference.html"
    assert main(["movie", "interference", "-o", str(path), "--duration", "30", "--quiet"]) == 0
    check_plays(browser, path, str(tmp_path / "interference"))


def test_the_viser_adapter_still_finds_what_it_uses():
    """``app.movie.viser_page`` relies on viser's serializer, its page's head and body and its
    embedded-data hook; the browser test above checks the player's time slider."""
    from app.movie import viser_page

    server = viser_page.start_server()
    try:
        serializer = server.get_scene_serializer()
        server.scene.add_label("/probe", "probe")
        serializer.insert_sleep(0.5)
        document = viser_page.page(serializer, "<!--our head-->", "<!--our body-->")
    finally:
        viser_page.stop_server(server)
    assert document.index("<!--our head-->") < document.index("</head>")
    assert document.index("<!--our body-->") < document.rindex("</body>")
    assert "__VISER_EMBED_DATA__" in document
    assert viser_page.HIDDEN_NOTICES in document


def test_a_movie_too_large_for_memory_is_refused_before_it_runs(monkeypatch, tmp_path, capsys):
    """The movie's memory is estimated from the lattice (measured bytes per particle) and a
    movie over the limit, or over the memory available, is refused at once with the figures."""
    from app.movie import options as movie_options

    big = sim.Model.create(nx=2000, ny=2000)
    with pytest.raises(ValueError, match=r"2000x2000 lattice would take about 2\.9 GB.*limit of "
                                         r"a movie \(2\.0 GB\).*up to about 16\d\dx16\d\d fits"):
        movie_options.check_movie_memory(big)
    movie_options.check_movie_memory(sim.Model.create(nx=682, ny=383))  # the flagship fits
    with pytest.raises(ValueError, match="memory available now"):
        movie_options.check_movie_memory(sim.Model.create(nx=682, ny=383), available=0.4e9)
    monkeypatch.setattr(movie_options, "MOVIE_MEMORY_LIMIT", movie_options.movie_bytes(100 * 100))
    output = tmp_path / "big.html"
    assert main(["movie", "grid", "--set", "nx=200", "--set", "ny=200", "-o", str(output)]) == 2
    assert "200x200 lattice would take about" in capsys.readouterr().err
    assert not output.exists() and not list(tmp_path.iterdir())


@pytest.mark.slow  # a movie rendered, then opened at a phone's size in Chromium
def test_on_a_phone_the_caption_is_one_line_above_the_lattice(tmp_path, browser):
    """At 414x896 the title is the scene's name on one line (the description and the run line
    are under "About this run"), so it does not cover the lattice."""
    path = tmp_path / "grid.html"
    assert main(["movie", "grid", "-o", str(path), "--duration", "2", "--quiet"]) == 0
    page, _ = open_offline(browser, path, {"width": 414, "height": 896})
    time.sleep(2)
    page.screenshot(path=str(tmp_path / "phone.png"))
    title = page.locator("#co-title").bounding_box()
    assert title is not None and title["height"] < 30, title
    assert not page.locator("#co-title .co-run").is_visible()
    picture = canvas_picture(page)  # the overlay's boxes included: the lattice starts lower
    below = picture[int(title["y"] + title["height"]) + 40:]
    rows = np.flatnonzero((np.abs(below - np.median(picture.reshape(-1, 3), axis=0))
                           .max(axis=2) > 60).any(axis=1))
    assert rows.size and rows[0] > 20, rows[:3]  # a clear gap under the title, then the lattice
    page.get_by_text("About this run").click()
    assert "A 12x8 lattice" in page.locator("#co-readme").text_content()
