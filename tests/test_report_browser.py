"""The report in a real browser: headless Debian Chromium driven by Playwright, offline.

Opens the written report from a ``file://`` URL with every non-file request refused, and
checks that no console error occurs, that every plot container holds a rendered plotly
figure, and that the ``<script>`` in the mission text did not run.  Besides the synthetic
solutions of ``test_report``, a small real mission (two point masses, an operator with
regions in their frame, a comparison plan and two risk cases; it plans in a few seconds) is
compiled with ``stlc.output.compile.plan`` and written with ``write_outputs``, so the page is tested
on the data shapes ``compile`` really produces, for a satisfied and for a violated plan.
Full-page screenshots go to ``reports/_screens/`` (git-ignored) for a person to look at.

Skipped only when no Chromium binary is installed (Debian package ``chromium``).
"""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_report import synthetic_case

from stlc.output.report import write_report
from stlc.planning.solution import Solution

#: two point masses hand a parcel to an operator while keeping apart; `far` cannot deliver in
#: time (a violated plan)
TEAM_STL = """\
# Two drones and an operator. <script>window.__pwned = 1</script>
vehicle uav1 : point_mass {
  vel_max = (2, 2, 1) m/s
  acc_max = (3, 3, 2) m/s^2
  start { pos = (-2, -1.5, 1) m }
}
vehicle uav2 : point_mass {
  vel_max = (2, 2, 1) m/s
  acc_max = (3, 3, 2) m/s^2
  start { pos = (2, -1.5, 1) m }
}
scenario {
  workspace = box((-3, -3, 0), (3, 3, 2.5)) m
  obstacle post = box((-0.3, -0.6, 0), (0.3, 0, 2.5)) m
  target drop = box((1, 1, 0.5), (2, 2, 1.5)) m
  human operator {
    pos = (-1.5, 2, 0) m
    att = (0, 0, -90) deg
    region handover = box((0.6, -0.4, 0.7), (1.2, 0.4, 1.3)) m
    region behind = box((-1, -0.5, 0), (-0.2, 0.5, 2)) m
    region unused = box((2, -0.5, 0), (2.5, 0.5, 2)) m
  }
}
spec safety = always[0, 4] (uav1.pos in workspace and uav1.pos not in post
                            and uav2.pos in workspace and uav2.pos not in post
                            and uav1.pos not in operator.behind)
mission team {
  vehicles = [uav1, uav2]
  horizon = 4 s
  step = 0.2 s
  threshold = 0.01
  spec separation = always[0, 4] (dist(uav1.pos, uav2.pos) >= 1 m)
  spec hand = eventually[2, 4] (uav1.pos in operator.handover)
  spec deliver = eventually[2, 4] (uav2.pos in drop)
  spec calm = always[3, 4] (uav2.speed <= 1.5 m/s)
  require safety and separation and hand and deliver and calm
  minimize -robustness
  # </script><img src=x onerror="window.__pwned=2">
  compare gentle { minimize 0.5 * energy - robustness }
  risk {
    K = 300; delta = 0.05; beta = [0.8, 0.9]; seed = 3
    case small { operator.pos ~ normal((-1.5, 2, 0) m, diag(0.01, 0.01, 0) m^2) }
    case wide  { operator.pos ~ normal((-1.5, 2, 0) m, diag(0.1, 0.1, 0) m^2) }
  }
}
mission far {
  vehicles = [uav1, uav2]
  horizon = 4 s
  step = 0.2 s
  spec separation = always[0, 4] (dist(uav1.pos, uav2.pos) >= 1 m)
  spec deliver = eventually[0, 1] (uav2.pos in drop)
  require safety and separation and deliver
  minimize -robustness
}
"""

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
      // ids that plotly gives the inside of each 3-D figure (`scene`) are its own
      document.querySelectorAll('[id]').forEach(el => {
        if (el.parentElement && el.parentElement.closest('.js-plotly-plot')) return;
        seen.has(el.id) ? dup.push(el.id) : seen.add(el.id); });
      return dup; }""")
    assert dup == [], f"duplicate element ids: {dup}"
    assert page.evaluate("() => window.__pwned") is None, "mission text ran as script"


def screenshot(page, name: str) -> None:
    SCREENS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SCREENS / name), full_page=True)


def report_data(page) -> dict:
    return json.loads(page.eval_on_selector("#report-data", "el => el.textContent"))


@pytest.mark.parametrize("status, shot", [("satisfied", "report.png"),
                                          ("violated", "report_violated.png")])
def test_report_renders_in_chromium(browser, tmp_path, status, shot):
    path = tmp_path / "report.html"
    write_report(path, *synthetic_case(status))
    page, errors, outside = open_report(browser, path)
    try:
        assert_page_sound(page)
        ids = page.eval_on_selector_all("[data-plot]", "els => els.map(el => el.id)")
        assert {"scene-3d", "scene-top", "sig-timeline", "sig-position", "sig-speed",
                "sig-rotor", "sig-heading-1", "sig-heading-error-1", "energy-profile",
                "risk-0"} <= set(ids)
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
        # the bound lines are labelled on the plots
        assert "Γ_pro max = 80 Hz" in page.inner_text("#sig-rotor")
        screenshot(page, shot)
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


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    """The two missions of ``TEAM_STL`` planned, risk-assessed and written as ``compile``
    does; returns {mission: output directory}."""
    from stlc.output.compile import write_outputs
    from stlc.pipeline import assess_risk, load, plan

    root = tmp_path_factory.mktemp("real")
    src = root / "team.stl"
    src.write_text(TEAM_STL, encoding="utf-8")
    loaded = load(str(src))
    out = {}
    for name, mission in loaded.program.missions.items():
        _, sol = plan(loaded.program, mission, quiet=True)
        sol.timing.update(loaded.timing)
        assess_risk(loaded.program, mission, sol)
        write_outputs(str(root / name), loaded.program, mission, sol)
        out[name] = root / name
    return out


def test_real_compiled_mission_renders_in_chromium(browser, compiled):
    outdir = compiled["team"]
    assert sorted(os.listdir(outdir)) == [".stlc-outputs.json", "flight", "report.html",
                                          "risk.json", "risk_samples.npz", "rosbag2",
                                          "solution.json", "trajectory.csv"]
    page, errors, outside = open_report(browser, outdir / "report.html")
    try:
        assert_page_sound(page)
        ids = set(page.eval_on_selector_all("[data-plot]", "els => els.map(el => el.id)"))
        assert {"scene-3d", "scene-top", "sig-timeline", "sig-position", "sig-speed", "sig-vel",
                "sig-acc", "sig-distance", "risk-0", "risk-1"} <= ids
        assert not any(i.startswith(("sig-rotor", "sig-heading")) for i in ids)
        assert "energy-profile" not in ids  # point masses: no rotor energy
        data = report_data(page)
        status = json.loads((outdir / "solution.json").read_text())["status"]
        assert page.inner_text(".top .pill").lower() == status.replace("_", " ")
        # the trajectory of both drones, every sample
        assert [len(t["x"]) for t in data["scene"]["trajectories"]] == [21, 21]
        # the operator's regions, moved into the world; the unused one hidden
        boxes = {b["name"]: b for b in data["scene"]["boxes"]}
        assert boxes["operator.handover"]["visible"] and not boxes["operator.unused"]["visible"]
        assert "unused" in page.inner_text("#scene-section")
        # bounds the mission states: Γ_dis on the distance plot, Γ_vel over calm's window
        assert "Γ_dis = 1 m" in page.inner_text("#sig-distance")
        speed = next(p for p in data["signals"]["plots"] if p["id"] == "sig-speed")
        assert [(b["value"], b["x0"], b["x1"]) for b in speed["bounds"]] == [(1.5, 3.0, 4.0)]
        # histograms from risk_samples.npz: every realisation counted
        for case in data["risk"]["cases"]:
            assert sum(case["histogram"]["counts"]) == 300
        assert page.locator("#risk-1 .bars path, #risk-1 .point path").count() > 0
        # the comparison plan side by side
        assert "gentle (w = 0.5)" in page.inner_text("#energy")
        # readable binding predicates, linked to their source line
        rows = page.locator("#requirements tbody tr")
        assert rows.count() == 5
        assert "<=" not in page.inner_text("#requirements tbody")
        assert page.locator("#L1").inner_text().endswith("<script>window.__pwned = 1</script>")
        screenshot(page, "report_real_team.png")
    finally:
        page.close()
    assert outside == [] and errors == [], (outside, errors)


def test_real_violated_plan_renders_in_chromium(browser, compiled):
    outdir = compiled["far"]
    sol = json.loads((outdir / "solution.json").read_text())
    # reaching the drop in 1 s is impossible, and the exact MILP's relaxation proves it
    assert sol["status"] == "infeasible" and "deliver" in sol["conflict"]
    assert sol["specs"]["deliver"]["robustness"] < 0
    assert "risk.json" not in os.listdir(outdir)
    page, errors, outside = open_report(browser, outdir / "report.html")
    try:
        assert_page_sound(page)
        banner = page.inner_text("[role=alert]")
        assert "No plan exists" in banner and "deliver" in banner  # the conflict is named
        assert page.locator("#risk").count() == 0 and page.locator("a[href='#risk']").count() == 0
        # the failure time is marked on the plots, and the failing lines in the source
        assert "deliver fails" in page.inner_text("#sig-position")
        assert page.locator("#source .line.fail").count() >= 1
        screenshot(page, "report_real_violated.png")
    finally:
        page.close()
    assert outside == [] and errors == [], (outside, errors)


def test_real_team_mission_renders_in_chromium(browser, tmp_path):
    """A compiled team mission (MILP seed + refinement): the team section's Gantt chart and
    forward-speed plot are drawn, offline, without console errors."""
    from stlc.cli import main

    out = tmp_path / "team"
    assert main(["compile", str(REPO / "tests" / "missions" / "team_small.stl"), "-o",
                 str(out), "-q"]) == 0
    page, errors, outside = open_report(browser, out / "report.html")
    try:
        assert_page_sound(page)
        team = page.inner_text("#team")
        assert "uav1" in team and "uav2" in team and "MILP only" in team
        assert page.locator("#team .js-plotly-plot").count() >= 2  # Gantt + forward speed
        screenshot(page, "report_real_team_mission.png")
    finally:
        page.close()
    assert outside == [] and errors == [], (outside, errors)


def synthetic_simulation(sol):
    """A hand-made simulation of the synthetic plan: a push at 0.5 s that triggers a replan,
    one event instant below ζ, the executed path offset until the segment rejoins."""
    from stlc.replan.result import ReplanEvent, SimulationResult

    t = sol.times
    nominal = {k: v for k, v in sol.channels.items()}
    executed = {k: np.array(v, float) for k, v in nominal.items()}
    executed["uav1.pos.y"] = executed["uav1.pos.y"] + np.where((t >= 0.5) & (t < 1.5), 1.2, 0)
    seg_t = t[(t >= 0.9) & (t <= 1.5)]
    seg = {f"uav1.pos.{a}": np.interp(seg_t, t, executed[f"uav1.pos.{a}"]) for a in "xyz"}
    events = [ReplanEvent(0.0, "uav1", 0.0, False),
              ReplanEvent(0.5, "uav1", 1.2, True, solve_s=0.12, status="optimal",
                          within_budget=True, accepted=True, segment=(0.9, 1.5),
                          kept={"safe <script>": 0.2}, times=seg_t, channels=seg),
              ReplanEvent(1.0, "uav1", 0.3, False)]
    from stlc.semantics.model import Disturbance

    return SimulationResult("demo", t, nominal, executed, events, 0.4,
                            {"mission": 0.04, "safe": 0.2}, 0.01,
                            [Disturbance("uav1", 0.5, (0.0, 1.2, 0.0))], kept=("safe",))


def test_simulation_section_renders_in_chromium(browser, tmp_path):
    program, mission, sol = synthetic_case()
    sim = synthetic_simulation(sol)
    path = tmp_path / "report.html"
    write_report(path, program, mission, sol, simulation=sim)
    page, errors, outside = open_report(browser, path)
    try:
        assert_page_sound(page)
        ids = page.eval_on_selector_all("[data-plot]", "els => els.map(el => el.id)")
        assert {"replan-3d", "replan-top", "replan-deviation"} <= set(ids)
        text = page.inner_text("#replan")
        assert "0.12" in text and "optimal" in text and "safe <script>" in text
        # the deviation plot shows the executed offset (1.2 m) against ζ = 1 m
        data = report_data(page)["replan"]
        assert max(data["deviation"]["series"][0]["d"]) == pytest.approx(1.2)
        assert data["deviation"]["zeta"] == 1.0 and data["deviation"]["events"] == [0.5]
        assert page.locator("#replan-top .scatterlayer .trace").count() >= 4
        screenshot(page, "report_replan.png")
    finally:
        page.close()
    assert outside == [] and errors == [], (outside, errors)
