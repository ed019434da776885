"""The projector view in a real (headless) Chromium, measured in the page: the panel's labels
at least 16 CSS px, black on white (contrast 21:1), the colour bar's smallest text at least 16
CSS px, in the page that asked for it alone; pressed again, the page is as it was."""

from __future__ import annotations

import pytest

from tests.helpers import open_page

pytestmark = pytest.mark.browser

MEASURE = """() => {
  const luminance = (css) => {
    const [r, g, b] = css.match(/[\\d.]+/g).slice(0, 3).map(Number).map((v) => {
      v /= 255; return v <= 0.03928 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4; });
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
  };
  const background = (element) => {
    for (let e = element; e; e = e.parentElement) {
      const c = getComputedStyle(e).backgroundColor;
      if (c && !c.endsWith(", 0)") && c !== "transparent") return c;
    }
    return "rgb(255, 255, 255)";
  };
  const label = [...document.querySelectorAll("label")].find((e) => e.textContent === "Speed");
  const style = getComputedStyle(label);
  const [hi, lo] = [luminance(style.color), luminance(background(label))].sort((a, b) => b - a);
  const tab = [...document.querySelectorAll("span, button, div")].find(
    (e) => e.textContent === "Colours" && e.children.length === 0);
  const image = tab.closest(".mantine-Paper-root").querySelector("img");
  const scale = image.getBoundingClientRect().width / image.naturalWidth;
  const smallest = Math.max(8, Math.round(image.naturalHeight * 0.14)) * scale;
  return {label: parseFloat(style.fontSize), contrast: (hi + 0.05) / (lo + 0.05),
          bar_text: smallest};
}"""


def test_the_projector_view_is_large_and_black_in_its_page_alone(web_app, browser):
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    other = browser.new_page(viewport={"width": 1366, "height": 768})
    open_page(page, web_app.url)
    open_page(other, web_app.url)
    for each in (page, other):
        each.get_by_text("Colours", exact=True).wait_for(timeout=30_000)
    before = page.evaluate(MEASURE)
    page.get_by_text("View", exact=True).first.click()  # open the folder
    page.get_by_role("button", name="Projector view (this page)").click()
    page.wait_for_function("document.documentElement.classList.contains("
                           "'oscillators-projector')", timeout=20_000)
    after = page.evaluate(MEASURE)
    print("projector view measured:", before, "->", after)
    assert after["label"] >= 16 > before["label"]
    assert after["contrast"] > 20
    assert after["bar_text"] >= 16 > before["bar_text"]
    assert other.evaluate(MEASURE) == pytest.approx(before)  # the other page is as it was
    page.get_by_role("button", name="Projector view (this page)").click()
    page.wait_for_function("!document.documentElement.classList.contains("
                           "'oscillators-projector')", timeout=20_000)
    assert page.evaluate(MEASURE) == pytest.approx(before)
