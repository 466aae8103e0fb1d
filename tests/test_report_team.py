"""Tests of the report's team section (paper B): Gantt bars, routes, forward speed against
v*, the spec-by-spec comparison of this plan with its seed and the standard plan.

``team_case`` is ``test_report.point_mass_team(2)`` (two point masses 3.5 m apart in x,
both flying v = (0.5, 1, 1) m/s for 2 s, 21 samples) turned into a team plan: two targets
and a station, routes, planned dwells, payload events and two comparisons.  Every expected
value below is worked out by hand from those numbers.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest
from test_report import point_mass_team, span

from stlc.output.report import build_view, render_report
from stlc.output.report.common import drone_color
from stlc.output.report.team_view import KIND_COLORS, closest_approach, is_team
from stlc.planning.solution import Comparison, SpecResult
from stlc.semantics.model import Box, Objective, Region
from stlc.team import PayloadEvent, Visit

#: v* of the synthetic mission (m/s); both drones fly hypot(0.5, 1) = √1.25 m/s
V_STAR = 2.0
V_FOR = math.sqrt(1.25)


def team_case(v_star: float | None = V_STAR):
    program, mission, sol = point_mass_team(2)
    regions = (*program.scenario.regions,
               Region("tq1", "target", Box((0.0, 0.0, 1.0), (1.0, 1.0, 2.0)), span(4)),
               Region("tq2", "target", Box((4.0, 0.0, 1.0), (5.0, 1.0, 2.0)), span(4)),
               Region("st", "station", Box((0.0, -5.0, 0.0), (2.0, -3.0, 2.0)), span(4)))
    program = replace(program, scenario=replace(program.scenario, regions=regions))
    mission = replace(mission, objective=Objective(forward_weight=1.0, forward_speed=v_star))
    t = np.asarray(sol.times)
    seed = dict(sol.channels)
    seed["uav2.pos.x"] = 3.5 - 1.0 * t  # distance |3.5 − 1.5 t|: 0.5 m at t = 2 s
    seed["uav1.vel.x"] = 3.0 + 0 * t  # forward speed hypot(3, 1) = √10
    comps = [Comparison("MILP only", seed, robustness_exact=-2.5,
                        specs={"separation": -2.5, "install": 0.5}),
             Comparison("standard", dict(sol.channels), robustness_exact=0.25,
                        specs={"separation": 0.5})]
    specs = {"separation": SpecResult(0.5, 0.4, True, 0.0, "dist", 13),
             "install": SpecResult(-0.125, -0.2, False, 1.0, "payload", 13)}
    sol = replace(
        sol, status="violated", robustness_exact=-0.125, specs=specs, comparisons=comps,
        routes={"uav1": ["tq1", "st"], "uav2": ["tq2"]},
        visits=[Visit("uav1", "install", "tq1", 0.6, 1.0), Visit("uav1", "home", "st", 1.5, 2.0),
                Visit("uav2", "install", "tq2", 0.2, 0.6)],
        events=[PayloadEvent("uav2", "install", "tq2", 0.3, 0.7),
                PayloadEvent("uav1", "install", "tq1", 0.5, 1.0),
                PayloadEvent("uav1", "refill", "st", 1.5, 2.0)])
    return program, mission, sol


@pytest.fixture
def view():
    return build_view(*team_case())


def test_not_a_team_plan_has_no_team_section():
    program, mission, sol = point_mass_team(2)
    assert not is_team(sol)
    view = build_view(program, mission, sol)
    assert view["team"] is None
    html = render_report(view)
    assert 'id="team"' not in html and 'href="#team"' not in html


def test_drones_routes_and_counts(view):
    drones = view["team"]["drones"]
    assert [d["name"] for d in drones] == ["uav1", "uav2"]
    assert [d["color"] for d in drones] == [drone_color(0), drone_color(1)]
    assert drones[0]["route"] == [{"name": "tq1", "kind": "target"},
                                  {"name": "st", "kind": "station"}]
    assert drones[0]["route_text"] == "tq1 → st"
    assert (drones[0]["installs"], drones[0]["refills"]) == (1, 1)
    assert (drones[1]["installs"], drones[1]["refills"], drones[1]["capacity"]) == (1, 0, 2)
    assert view["team"]["installed_text"] == "2 of 2 targets" and view["team"]["missing"] == []
    # the scene draws each drone in the same colour
    assert [tr["color"] for tr in view["scene"]["trajectories"]] == [drone_color(0),
                                                                      drone_color(1)]
    assert view["scene"]["per_drone"]


def test_gantt_bars_from_events_and_visits(view):
    g = view["team"]["gantt"]
    assert g["rows"] == ["uav1", "uav2"] and g["horizon"] == 2.0 and g["has_planned"]
    events = [(b["drone"], b["kind"], b["region"], b["start"], b["duration"])
              for b in g["bars"] if not b["planned"]]
    # sorted by drone, then start; duration = end − start
    assert events == [("uav1", "install", "tq1", 0.5, 0.5), ("uav1", "refill", "st", 1.5, 0.5),
                      ("uav2", "install", "tq2", 0.3, 0.4)]
    planned = [(b["drone"], b["kind"], b["start"], b["duration"])
               for b in g["bars"] if b["planned"]]
    assert planned == [("uav1", "install", 0.6, 0.4), ("uav1", "home", 1.5, 0.5),
                       ("uav2", "install", 0.2, 0.4)]
    refill = next(b for b in g["bars"] if b["kind"] == "refill")
    assert refill["color"] == KIND_COLORS["refill"]
    assert refill["text"] == "refill st: 1.5–2 s (0.5 s)"
    assert [k["label"] for k in g["legend"]] == ["install", "home", "refill"]


def test_forward_speed_against_v_star(view):
    fw = view["team"]["forward"]
    assert fw["v_star"] == V_STAR and fw["v_star_text"] == "2 m/s" and len(fw["t"]) == 21
    d1, d2 = fw["drones"]
    assert np.allclose(d1["y"], V_FOR, atol=1e-4) and d1["v_star"] == V_STAR
    assert not d1["clamped"]
    # transit: outside the payload events; uav1 dwells over t ∈ [0.5, 1] (6 samples) and
    # [1.5, 2] (6 samples), uav2 over [0.3, 0.7] (5 samples)
    assert (d1["transit_samples"], d2["transit_samples"]) == (9, 16)
    assert d1["cost"] == pytest.approx(9 * (1 - V_FOR / V_STAR) ** 2, rel=1e-4)
    assert d2["cost"] == pytest.approx(16 * (1 - V_FOR / V_STAR) ** 2, rel=1e-4)
    assert d1["mean_transit"] == pytest.approx(V_FOR, rel=1e-4)
    seed = d1["comparisons"][0]
    assert seed["label"] == "MILP only" and np.allclose(seed["y"], math.sqrt(10), atol=1e-3)


def test_v_star_clamped_to_the_feasible_forward_speed():
    fw = build_view(*team_case(v_star=5.0))["team"]["forward"]
    limit = math.hypot(3.1, 3.1)  # per-axis bounds (3.1, 3.1, 3.1) m/s
    assert all(d["clamped"] and d["v_star"] == pytest.approx(limit, rel=1e-4)
               for d in fw["drones"])
    assert fw["v_star"] == 5.0


def test_no_forward_speed_without_v_star():
    assert build_view(*team_case(v_star=None))["team"]["forward"] is None


def test_plans_spec_by_spec(view):
    plans = view["team"]["plans"]
    assert plans["columns"] == ["this plan", "MILP only", "standard"]
    rows = {r["name"]: r for r in plans["rows"]}
    assert list(rows) == ["separation", "install", "requirement", "closest approach",
                          "peak forward speed"]
    cells = [(c["text"], c["mark"]) for c in rows["separation"]["cells"]]
    assert cells == [("+0.5", "✓"), ("−2.5", "✗"), ("+0.5", "✓")]
    # the standard plan has no robustness recorded for `install`
    assert [(c["text"], c["ok"]) for c in rows["install"]["cells"]] == [
        ("−0.125", False), ("+0.5", True), ("—", None)]
    assert [c["value"] for c in rows["requirement"]["cells"]] == [-0.125, -2.5, 0.25]
    # 3.5 m apart throughout (first at t = 0); the seed closes to |3.5 − 1.5·2| = 0.5 m
    approach = rows["closest approach"]["cells"]
    assert [c["value"] for c in approach] == [3.5, 0.5, 3.5]
    assert approach[1]["text"] == "0.5 m (uav1–uav2, t = 2 s)"
    assert rows["closest approach"]["metric"]
    peaks = [c["value"] for c in rows["peak forward speed"]["cells"]]
    assert peaks == pytest.approx([V_FOR, math.sqrt(10), V_FOR], rel=1e-4)


def test_closest_approach_by_brute_force():
    rng = np.random.default_rng(4)
    t = np.arange(30) * 0.5
    ch = {f"{v}.pos.{a}": rng.normal(size=30) for v in ("a", "b", "c") for a in "xyz"}
    d, pair, when = closest_approach(ch, ["a", "b", "c"], t)
    best = min((math.dist([ch[f"{p}.pos.{a}"][k] for a in "xyz"],
                          [ch[f"{q}.pos.{a}"][k] for a in "xyz"]), f"{p}–{q}", t[k])
               for p, q in (("a", "b"), ("a", "c"), ("b", "c")) for k in range(30))
    assert d == pytest.approx(best[0]) and (pair, when) == best[1:]


def test_render_has_team_section_and_data(view):
    html = render_report(view)
    assert '<section id="team"' in html and 'href="#team"' in html
    assert 'id="team-gantt"' in html and 'id="team-forward"' in html
    assert '<code class="route-target">tq1</code> → <code class="route-station">st</code>' \
        in html
    start = html.index('id="report-data">') + len('id="report-data">')
    data = json.loads(html[start:html.index("</script>", start)])
    assert data["team"]["gantt"]["rows"] == ["uav1", "uav2"]
    assert data["team"]["forward"]["v_star"] == V_STAR
    # nothing is fetched: no external script, stylesheet or image
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", html)
