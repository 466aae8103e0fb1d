"""The report in a real browser: headless Debian Chromium driven by Playwright, offline.

Opens the written report from a ``file://`` URL with every non-file request refused, and
checks that no console error occurs, that every plot container holds a rendered plotly
figure, and that the ``<script>`` in the mission text did not run.  Full-page screenshots go
to ``reports/_screens/`` (git-ignored) for a person to look at.

Skipped only when no Chromium binary is installed (Debian package ``chromium``).
"""

from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_report import synthetic_case

from stlc.report import write_report
from stlc.solution import Solution

REPO = Path(__file__).resolve().parents[1]
SCREENS = REPO / "reports" / "_screens"
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]


def chromium_path() -> str | None:
    for cand in ("/usr/bin/chromium", shutil.which("chromium"), shutil.which("chromium-browser")):
        if cand and os.path.exists(cand):
            return cand
    return None


@pytest.fixture(scope="module")
def browser():
    exe = chromium_path()
    if exe is None:
        pytest.skip("no Chromium binary (install Debian's `chromium` package to run this test)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=exe, headless=True, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


PLOTS_DRAWN = """() => {
  const els = [...document.querySelectorAll('[data-plot]')];
  return els.length > 0 && els.every(el => el.querySelector('.main-svg'));
}"""


def open_report(browser, path: Path):
    """Open a report offline; returns the page and the lists of console errors and of
    refused network requests, both filled while the page lives."""
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    errors: list[str] = []
    outside: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))

    def refuse_network(route):
        if not route.request.url.startswith(("file:", "data:", "blob:", "about:")):
            outside.append(route.request.url)
            route.abort()
        else:
            route.continue_()

    page.route("**/*", refuse_network)
    page.goto(path.as_uri(), wait_until="load")
    page.wait_for_function(PLOTS_DRAWN, timeout=60_000)
    page.wait_for_timeout(500)  # let plotly finish its layout before measuring
    return page, errors, outside


def assert_page_sound(page) -> None:
    counts = page.eval_on_selector_all(
        "[data-plot]",
        "els => els.map(el => [el.id, el.querySelectorAll('.main-svg').length,"
        " el.classList.contains('js-plotly-plot')])")
    for pid, n_svg, is_plot in counts:
        assert is_plot and n_svg >= 1, f"plot {pid} was not rendered"
    dup = page.evaluate("""() => {
      const seen = new Set(), dup = [];
      document.querySelectorAll('[id]').forEach(el => seen.has(el.id) ? dup.push(el.id)
                                                                      : seen.add(el.id));
      return dup; }""")
    assert dup == [], f"duplicate element ids: {dup}"
    assert page.evaluate("() => window.__pwned") is None, "mission text ran as script"


@pytest.mark.parametrize("status, shot", [("satisfied", "report.png"),
                                          ("violated", "report_violated.png")])
def test_report_renders_in_chromium(browser, tmp_path, status, shot):
    path = tmp_path / "report.html"
    write_report(path, *synthetic_case(status))
    page, errors, outside = open_report(browser, path)
    try:
        assert_page_sound(page)
        ids = page.eval_on_selector_all("[data-plot]", "els => els.map(el => el.id)")
        assert {"scene-3d", "scene-top", "sig-position", "sig-speed", "sig-rotor",
                "sig-heading-1", "energy-profile", "risk-0"} <= set(ids)
        # the 3D scene draws into a WebGL canvas
        assert page.locator("#scene-3d canvas").count() >= 1
        # every rotor made it into the SVG
        assert page.locator("#sig-rotor .scatterlayer .trace").count() >= 6
        assert page.locator("#source .line").count() == 16
        assert "<script>window.__pwned = 1</script>" in page.inner_text("#L1")
        banner = page.locator("[role=alert]")
        if status == "satisfied":
            assert banner.count() == 0
        else:
            assert "reach" in banner.inner_text() and "1.5 s" in banner.inner_text()
        SCREENS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(SCREENS / shot), full_page=True)
        page.click("a[href='#L14']")  # a requirement row links to its source line
        assert page.evaluate("() => location.hash") == "#L14"
        assert page.locator("#L14").is_visible()
    finally:
        page.close()
    assert outside == [], f"the report tried to reach the network: {outside}"
    assert errors == [], f"console errors: {errors}"


def test_report_without_a_plan_renders_in_chromium(browser, tmp_path):
    program, mission, _ = synthetic_case()
    sol = Solution("demo", "solver_failed", -math.inf, -math.inf, {}, math.nan, np.zeros(0), {},
                   solver={"name": "ipopt", "return_status": "Invalid_Number_Detected"})
    path = tmp_path / "report.html"
    write_report(path, program, mission, sol)
    page, errors, outside = open_report(browser, path)
    try:
        assert_page_sound(page)
        assert "Solver failed" in page.inner_text("[role=alert]")
    finally:
        page.close()
    assert outside == [] and errors == [], (outside, errors)
