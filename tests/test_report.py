"""Tests of the HTML mission report: the view model, rendering and escaping.

``synthetic_case`` builds a small handover-like program (a hexarotor, a workspace, an
obstacle, a human yawed by 90° with regions in its frame), a 2 s plan of 21 samples and a
``Solution`` with two named specs; ``test_report_browser`` reuses it.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from stlc.diagnostics import Span
from stlc.output.report import build_view, load_samples, render_report, script_json, write_report
from stlc.output.report.common import num
from stlc.output.report.predicates import readable
from stlc.output.report.risk_view import MAX_BINS, MIN_BINS
from stlc.output.report.scene import region_role, rotation
from stlc.planning.solution import Comparison, Solution, SpecResult, Window
from stlc.semantics.ir import Always, And, Bin, Bound, Const, Eventually, Or, Pred, Sig
from stlc.semantics.model import (
    Box,
    Human,
    Mission,
    Multirotor,
    Normal,
    Objective,
    PointMass,
    Program,
    Region,
    RiskCase,
    RiskConfig,
    Rotor,
    Scenario,
)
from stlc.semantics.origin import FACE, Origin

FILE = "demo.stl"
SOURCE = """\
# handover test mission <script>window.__pwned = 1</script>
vehicle uav1 = multirotor(hexarotor)
scenario {
  workspace ws = box[(-3.6, -2.85, 0), (3.6, 2.85, 2.5)]
  obstacle pillar = box[(1.5, -1.5, 0), (2.0, -1.0, 2.5)]
  human operator at (1, 2, 0) attitude (0, 0, 90 deg)
  region vis in operator = box[(0.5, -0.25, 0.8), (1.0, 0.25, 1.2)]
  region behind in operator = box[(-1.0, -0.5, 0), (-0.2, 0.5, 2.0)]
  region ho in operator = box[(0.3, -0.15, 0.9), (0.55, 0.15, 1.2)]
}
mission demo {
  horizon = 2 s  step = 0.1 s
  spec safe = always[0, 2] (uav1.pos.z in [0.2, 2.5] and uav1.pos not in operator.behind)
  spec reach = eventually[1, 2] (uav1.pos.x >= -0.5 or uav1.pos in operator.ho)
  require safe and reach   # </script><img src=x onerror="window.__pwned=2">
}
"""
NASTY = "</script><script>window.__pwned = 3</script>"
C_F = 11.5e-4


def span(line: int, col: int = 3, end: int = 40) -> Span:
    return Span(FILE, line, col, line, end)


def hexarotor() -> Multirotor:
    rotors = tuple(Rotor((0.2 * math.cos(k * math.pi / 3), 0.2 * math.sin(k * math.pi / 3), 0.0),
                         (0.0, 0.0, 1.0), 1 if k % 2 == 0 else -1) for k in range(6))
    return Multirotor("uav1", 2.25, ((0.0207, 0, 0), (0, 0.021, 0), (0, 0, 0.031)), C_F,
                      2.38e-5, 0.29, 11.5, rotors, (-1.8, 0.0, 1.0), span=span(2))


BEHIND = "not (uav1.pos not in operator.behind (x >= lo))"
#: what the checker and the normal form record about that predicate (``ir.Pred.origin``)
BEHIND_ORIGIN = Origin(FACE, "uav1.pos not in operator.behind", subject="uav1.pos",
                       region="operator.behind", region_text="operator.behind", axis="x",
                       side="lo", regions=("operator.behind",), negated=True)
HO_ORIGIN = Origin(FACE, "uav1.pos in operator.ho", subject="uav1.pos", region="operator.ho",
                   region_text="operator.ho", axis="y", side="lo", regions=("operator.ho",))


def formulas() -> dict:
    z_hi = Pred(Bin("-", Const(2.5), Sig("uav1.pos.z")), "uav1.pos.z <= 2.5", span(13, 28, 45))
    z_lo = Pred(Bin("-", Sig("uav1.pos.z"), Const(0.2)), "uav1.pos.z >= 0.2", span(13, 50, 67))
    behind = Pred(Bin("-", Const(-1.0), Sig("uav1.pos.x")), BEHIND, span(13, 72, 103),
                  origin=BEHIND_ORIGIN)
    reach = Pred(Bin("-", Sig("uav1.pos.x"), Const(-0.5)), f"uav1.pos.x >= -0.5 {NASTY}",
                 span(14, 34, 52))
    ho = Pred(Bin("-", Sig("uav1.pos.y"), Const(2.3)), "uav1.pos in operator.ho (y >= lo)",
              span(14, 56, 80), origin=HO_ORIGIN)
    return {"safe": Always(0.0, 2.0, And((z_hi, z_lo, behind)), span(13)),
            "reach": Eventually(1.0, 2.0, Or((reach, ho)), span(14))}


def program_and_mission() -> tuple[Program, Mission]:
    specs = formulas()
    mission = Mission("demo", ("uav1",), 2.0, 0.1, specs, And(tuple(specs.values())),
                      span=Span(FILE, 11, 1, 16, 2),
                      spec_spans={"safe": span(13), "reach": span(14)})
    scenario = Scenario(
        regions=(
            Region("ws", "workspace", Box((-3.6, -2.85, 0.0), (3.6, 2.85, 2.5)), span(4)),
            Region("pillar", "obstacle", Box((1.5, -1.5, 0.0), (2.0, -1.0, 2.5)), span(5)),
            Region("operator.vis", "region",
                   Box((0.5, -0.25, 0.8), (1.0, 0.25, 1.2), "operator"), span(7)),
            Region("operator.behind", "region",
                   Box((-1.0, -0.5, 0.0), (-0.2, 0.5, 2.0), "operator"), span(8)),
            Region("operator.ho", "region",
                   Box((0.3, -0.15, 0.9), (0.55, 0.15, 1.2), "operator"), span(9)),
        ),
        humans=(Human("operator", (1.0, 2.0, 0.0), (0.0, 0.0, math.pi / 2), span=span(6)),),
    )
    program = Program(FILE, SOURCE, vehicles={"uav1": hexarotor()}, scenario=scenario,
                      missions={"demo": mission})
    return program, mission


def channels(t: np.ndarray) -> dict[str, np.ndarray]:
    s = t / t[-1]
    pos = np.stack([-1.8 + 2.5 * s, 2.0 * s ** 2, 1.0 + 0.1 * np.sin(math.pi * s)])
    vel = np.gradient(pos, t, axis=1)
    ch = {f"uav1.pos.{a}": pos[i] for i, a in enumerate("xyz")}
    ch |= {f"uav1.vel.{a}": vel[i] for i, a in enumerate("xyz")}
    heading = np.arctan2(vel[1], vel[0]) + 0.2 * np.sin(3 * t)
    ch |= {"uav1.att.x": 0.02 * np.sin(t), "uav1.att.y": 0.03 * np.cos(t), "uav1.att.z": heading}
    for i in range(6):
        force = 3.68 + 0.8 * np.sin(2 * t + i)
        ch[f"uav1.force.{i + 1}"] = force
        ch[f"uav1.rotor_speed.{i + 1}"] = np.sqrt(force / C_F)
    ch["uav1.speed"] = np.linalg.norm(vel, axis=0)
    ch["uav1.heading"] = heading
    ch["uav1.course"] = np.arctan2(vel[1], vel[0])
    return ch


def risk_json() -> dict:
    return {"cases": [
        {"name": "σ² = 0.25", "K": 15000, "delta": 0.01, "seed": 0,
         "var": {"0.7": {"value": 0.12, "lower": 0.1, "upper": 0.14},
                 "0.9": {"value": 0.03, "lower": 0.01, "upper": 0.05}},
         "cvar": {"0.7": {"value": 0.05, "lower": 0.02, "upper": 0.07},
                  "0.9": {"value": -0.02, "lower": None, "upper": 0.01}},
         "p_violation": {"value": 0.081, "upper": 0.088},
         "specs": {"safe": {"p_violation": 0.0}, "reach": {"p_violation": 0.081}},
         "driver": "reach",
         "histogram": {"edges": [-0.2, -0.1, 0.0, 0.1, 0.2, 0.3],
                       "counts": [300, 915, 6000, 7000, 785]}},
        {"name": "σ² = 0.75", "K": 15000, "delta": 0.01, "seed": 0, "epsilon": 0.0133,
         "nominal_robustness": 0.2, "mean": 0.05, "min": -0.4, "max": 0.3,
         "var": {"0.7": {"value": -0.01, "lower": -0.03, "upper": 0.01}},
         "cvar": {"0.7": {"value": -0.1, "lower": -0.15, "upper": -0.08}},
         "p_violation": {"value": 0.31, "upper": 0.32},
         "specs": {"safe": {"p_violation": 0.01, "p_violation_upper": 0.012,
                            "driver_fraction": 0.05},
                   "reach": {"p_violation": 0.3, "p_violation_upper": 0.31,
                             "driver_fraction": 0.95}},
         "drivers": {"safe": {"count": 230, "fraction": 0.05},
                     "reach": {"count": 4420, "fraction": 0.95}}},
    ]}


def synthetic_case(status: str = "satisfied", risk: bool = True
                   ) -> tuple[Program, Mission, Solution]:
    """A small program, its mission and a solution with the given status."""
    program, mission = program_and_mission()
    t = np.round(np.arange(21) * 0.1, 10)
    ch = channels(t)
    violated = status != "satisfied"
    reach_rho = -0.12 if violated else 0.05
    specs = {
        "safe": SpecResult(0.25, 0.21, True, 1.2, BEHIND, 13, binding_line=13,
                           binding_origin=BEHIND_ORIGIN),
        "reach": SpecResult(reach_rho, reach_rho - 0.04, not violated, 1.5,
                            f"uav1.pos.x >= -0.5 {NASTY}", 14, binding_line=14),
    }
    power = sum(C_F * ch[f"uav1.rotor_speed.{i + 1}"] ** 6 for i in range(6)) * 1e-9
    typed: dict = {
        "bounds": {"speed": [0.0, 2.0], "rotor_speed": [40.0, 80.0], "force": [0.29, 11.5],
                   "heading_margin_deg": 30.0},
        "windows": [Window("safe", 0.0, 2.0), Window("reach", 1.0, 2.0)],
        "energy_profile": power,
        "comparisons": [Comparison(f"w = 0 {NASTY}", {}, float(power.sum() * 1.3),
                                   power * 1.3, robustness_exact=0.07, peak_speed=2.4,
                                   peak_rotor_speed=79.0)],
        "risk": risk_json() if risk else None,
    }
    sol = Solution(
        mission="demo", status=status, robustness_exact=min(0.25, reach_rho),
        robustness_smooth=min(0.21, reach_rho - 0.04), specs=specs, energy=float(power.sum()),
        times=t, channels=ch,
        timing={"parse_s": 0.01, "check_s": 0.02, "build_s": 1.5, "solve_s": 3.25,
                "total_s": 4.8},
        solver={"name": "ipopt", "iterations": 48,
                "return_status": "Solve_Succeeded" if status != "solver_failed"
                else "Maximum_Iterations_Exceeded",
                "stages": [{"label": "λ = 10", "lam": 10.0, "iterations": 20,
                            "status": "Solve_Succeeded", "exact": -0.02, "solve_s": 1.25},
                           {"label": "λ = 50", "lam": 50.0, "iterations": 28,
                            "status": "Solve_Succeeded", "exact": 0.05, "solve_s": 2.0}]},
        smoothing={"method": "gkl", "lambda": 10.0, "lambda_final": 50.0,
                   "schedule": [10.0, 20.0, 50.0]},
        problem_size={"variables": 4321, "constraints": 3876, "samples": 21},
        notes=["λ raised from 10 to 50 (schedule)"],
        **typed,
    )
    return program, mission, sol


@pytest.fixture
def case():
    return synthetic_case()


@pytest.fixture
def view(case):
    return build_view(*case)


def data_block(html: str) -> str:
    m = re.search(r'<script type="application/json" id="report-data">(.*?)</script>', html,
                  re.S)
    assert m, "the JSON data block is missing"
    return m.group(1)


# --------------------------------------------------------------------------- view model


def test_view_is_plain_json(view):
    text = json.dumps(view, allow_nan=False)
    assert json.loads(text) == view


def test_summary(view):
    s = view["summary"]
    assert s["mission"] == "demo" and s["status"] == "satisfied"
    assert s["status_label"] == "Satisfied"
    assert s["robustness_exact"] == 0.05 and s["robustness_smooth"] == 0.01
    assert s["robustness_exact_text"] == "+0.05"
    assert s["energy"] is not None and s["energy_text"] != "—"
    assert [t["name"] for t in s["timing"]] == ["parse", "check", "build", "solve", "total"]
    assert s["solve_text"] == "3.25 s"
    assert s["solver_name"] == "ipopt" and s["iterations"] == "48"
    assert s["return_status"] == "Solve_Succeeded"
    assert s["smoothing_method"] == "gkl" and s["smoothing_lam_text"] == "50 (declared 10)"
    assert s["stages"]["columns"] == ["label", "λ", "iterations", "status", "exact ρ",
                                      "solve (s)"]
    assert s["stages"]["rows"][1] == ["λ = 50", "50", "28", "Solve_Succeeded", "+0.05", "2"]
    assert s["energy_text"].endswith(" J") and s["specs_text"] == "2 of 2 specs hold"
    assert s["objective"]["text"] == "minimise −ρ̃"
    assert all(e["name"] != "stages" for e in s["solver_extra"])
    assert s["smoothing_schedule"] == "10, 20, 50"
    assert {"name": "variables", "text": "4321"} in s["problem_size"]
    assert view["banner"] is None


def test_spec_rows(view):
    rows = {r["name"]: r for r in view["specs"]}
    assert list(rows) == ["safe", "reach"]
    safe = rows["safe"]
    assert safe["robustness"] == 0.25 and safe["satisfied"] and safe["verdict"] == "satisfied"
    assert safe["tightest_time"] == 1.2 and safe["tightest_text"] == "1.2 s"
    # the monitor's label, and its readable form (outside the region, past its x = lo face)
    assert safe["binding_predicate_raw"] == BEHIND
    assert safe["binding_predicate"] == "uav1.pos outside operator.behind (x < lo)"
    assert safe["line"] == 13 and safe["anchor"] == "L13"
    assert safe["predicate_anchor"] == "L13"
    assert safe["window_text"] == "[0, 2] s" and safe["window_color"] == "#1f77b4"
    assert rows["reach"]["anchor"] == "L14" and rows["reach"]["window_text"] == "[1, 2] s"


def test_spec_line_falls_back_to_spans():
    program, mission, sol = synthetic_case()
    sol.specs["safe"] = replace(sol.specs["safe"], line=0)
    rows = build_view(program, mission, sol)["specs"]
    assert rows[0]["line"] == 13 and rows[0]["anchor"] == "L13"


def test_human_frame_box_corners_rotated_by_yaw():
    program, mission, sol = synthetic_case()
    boxes = {b["name"]: b for b in build_view(program, mission, sol)["scene"]["boxes"]}
    vis = boxes["operator.vis"]
    assert vis["frame"] == "operator" and len(vis["corners"]) == 8
    # operator at (1, 2, 0), yaw 90°: local (x, y, z) -> world (1 - y, 2 + x, z)
    # local corner (1.0, 0.25, 1.2) -> world (0.75, 3.0, 1.2)
    assert any(np.allclose(c, (0.75, 3.0, 1.2), atol=1e-4) for c in vis["corners"])
    # local corner (0.5, -0.25, 0.8) -> world (1.25, 2.5, 0.8)
    assert any(np.allclose(c, (1.25, 2.5, 0.8), atol=1e-4) for c in vis["corners"])
    # every corner is pos + R·local
    R, pos = rotation((0, 0, math.pi / 2)), np.array([1.0, 2.0, 0.0])
    lo, hi = np.array([0.5, -0.25, 0.8]), np.array([1.0, 0.25, 1.2])
    local = [R.T @ (np.array(c) - pos) for c in vis["corners"]]
    assert all(np.all(p >= lo - 1e-4) and np.all(p <= hi + 1e-4) for p in local)
    # a world-frame box is not moved
    assert any(np.allclose(c, (2.0, -1.0, 2.5)) for c in boxes["pillar"]["corners"])


def test_rotation_convention():
    # R = Rz(yaw) Ry(pitch) Rx(roll): pitch 90° maps body x to world -z
    assert np.allclose(rotation((0, math.pi / 2, 0)) @ [1, 0, 0], [0, 0, -1])
    assert np.allclose(rotation((math.pi / 2, 0, 0)) @ [0, 1, 0], [0, 0, 1])
    r, p, y = 0.3, -0.2, 1.1
    rz = rotation((0, 0, y))
    assert np.allclose(rotation((r, p, y)), rz @ rotation((0, p, 0)) @ rotation((r, 0, 0)))


def test_region_colours(view):
    boxes = {b["name"]: b for b in view["scene"]["boxes"]}
    assert boxes["ws"]["wireframe"] and boxes["ws"]["role"] == "workspace"
    assert boxes["pillar"]["role"] == "nofly" and boxes["pillar"]["color"] == "#d62728"
    assert boxes["operator.behind"]["color"] == "#d62728"
    vis = boxes["operator.vis"]  # never used by the mission: a human's region, approach
    assert vis["role"] == "approach" and not vis["visible"]
    assert boxes["operator.ho"]["role"] == "approach"
    assert not boxes["operator.ho"]["wireframe"]
    assert region_role("target") == "target" and region_role("station") == "station"
    assert region_role("home") == "home" and region_role("obstacle") == "nofly"
    assert region_role("target", None, {"out"}) == "target"  # the declaration first
    # a human's regions: by use, whatever their names; a free region is a region
    assert region_role("region", "visitor", {"out"}) == "nofly"
    assert region_role("region", "operator", {"stay"}) == "visibility"
    assert region_role("region", "operator", {"stay", "out"}) == "approach"
    assert region_role("region", "operator", {"in"}) == "approach"
    assert region_role("region", None, {"out"}) == "region"
    assert vis["label"] == "vis"
    assert [r["label"] for r in view["scene"]["roles"]] == ["no-fly", "approach"]


def test_regions_the_mission_never_mentions_are_hidden(view):
    boxes = {b["name"]: b for b in view["scene"]["boxes"]}
    # obstacles and the workspace always show; a free region only when a spec mentions it
    assert boxes["ws"]["visible"] and boxes["pillar"]["visible"]
    assert boxes["operator.behind"]["visible"] and boxes["operator.ho"]["visible"]
    assert not boxes["operator.vis"]["visible"]
    assert view["scene"]["hidden"] == ["operator.vis"]


def test_trajectory_and_humans(view):
    trajs = view["scene"]["trajectories"]
    assert [tr["vehicle"] for tr in trajs] == ["uav1"]
    tr = trajs[0]
    assert len(tr["x"]) == len(tr["t"]) == 21
    assert tr["x"][0] == -1.8 and tr["t"][-1] == 2.0
    (h,) = view["scene"]["humans"]
    assert h["name"] == "operator" and h["att_deg"] == [0.0, 0.0, 90.0]
    assert np.allclose(h["facing"], (1.0, 2.6, 0.0), atol=1e-4)


def test_signal_plots_with_bounds(view):
    sig = view["signals"]
    plots = {p["id"]: p for p in sig["plots"]}
    assert {"sig-position", "sig-speed", "sig-rotor", "sig-force", "sig-heading-1",
            "sig-heading-error-1"} <= set(plots)
    assert "sig-distance" not in plots and "sig-payload" not in plots  # single drone, no payload
    assert "sig-vel" not in plots  # per-axis limits: point masses only
    assert len(plots["sig-position"]["traces"]) == 3
    # a zero lower speed bound says nothing: only Γ_vel is drawn
    assert [(b["value"], b["text"]) for b in plots["sig-speed"]["bounds"]] == [
        (2.0, "Γ_vel = 2 m/s")]
    rotor = plots["sig-rotor"]
    assert len(rotor["traces"]) == 6
    labels = {b["label"]: b["value"] for b in rotor["bounds"]}
    assert labels["Γ_pro min"] == 40.0 and labels["Γ_pro max"] == 80.0
    assert labels["ξ max 11.5 N ≙"] == pytest.approx(100.0)  # sqrt(11.5 / 11.5e-4)
    assert {b["text"] for b in rotor["bounds"]} >= {"Γ_pro max = 80 Hz", "ξ max 11.5 N ≙ 100 Hz"}
    assert [b["value"] for b in plots["sig-force"]["bounds"]] == [0.29, 11.5]
    heading = plots["sig-heading-1"]
    assert heading["unit"] == "deg" and heading["band"]["name"] == "course ± γ (30°)"
    # the band is a closed polygon: course + γ forward in time, course − γ backward
    xs, ys = heading["band"]["x"], heading["band"]["y"]
    n = xs.index(None) // 2
    assert xs[:n] == xs[n:2 * n][::-1]
    assert np.allclose(np.array(ys[:n]) - np.array(ys[n:2 * n][::-1]), 60.0, atol=1e-2)
    err = plots["sig-heading-error-1"]
    assert [b["value"] for b in err["bounds"]] == [30.0, -30.0]
    assert np.allclose(err["traces"][0]["y"][1:], np.degrees(0.2 * np.sin(3 * np.arange(1, 21)
                                                                          * 0.1)), atol=1e-3)
    assert len(sig["t"]) == 21
    assert [w["spec"] for w in sig["windows"]] == ["safe", "reach"]
    # safe's window is the whole plan: shading it would tint everything
    assert plots["sig-position"]["windows"] == ["reach"]
    assert sig["markers"] == []
    tl = sig["timeline"]["specs"]
    assert [(s["name"], s["start"], s["end"], s["tightest"]) for s in tl] == [
        ("safe", 0.0, 2.0, 1.2), ("reach", 1.0, 2.0, 1.5)]


def test_bounds_span_the_window_of_the_spec_that_states_them():
    program, mission, sol = synthetic_case()
    comfort = Always(1.0, 2.0, And((
        Pred(Bin("-", Const(2.0), Sig("uav1.speed")), "uav1.speed <= 2 m/s", span(14),
             Bound("uav1.speed", "upper", 2.0, Sig("uav1.speed"))),
        Pred(Bin("-", Sig("uav1.rotor_speed.1"), Const(40.0)),
             "uav1.rotor_speed in [40 Hz, 80 Hz] (lower)", span(14),
             Bound("uav1.rotor_speed.1", "lower", 40.0, Sig("uav1.rotor_speed.1"))))),
        span(14))
    specs = {**mission.specs, "comfort": comfort}
    mission = replace(mission, specs=specs)
    sol.specs["comfort"] = SpecResult(0.3, 0.2, True, 1.5, "uav1.speed <= 2 m/s", 14)
    sol.windows = [*sol.windows, Window("comfort", 1.0, 2.0)]
    plots = {p["id"]: p for p in build_view(program, mission, sol)["signals"]["plots"]}
    (speed,) = plots["sig-speed"]["bounds"]
    assert (speed["x0"], speed["x1"]) == (1.0, 2.0)
    rotor = {b["label"]: b for b in plots["sig-rotor"]["bounds"]}
    assert (rotor["Γ_pro min"]["x0"], rotor["Γ_pro min"]["x1"]) == (1.0, 2.0)
    assert rotor["ξ max 11.5 N ≙"]["x0"] is None  # actuator limits hold throughout
    assert "comfort" in plots["sig-speed"]["windows"]
    assert "comfort" not in plots["sig-position"]["windows"]


def test_hovering_masks_the_direction_of_motion():
    program, mission, sol = synthetic_case()
    ch = dict(sol.channels)
    for a in "xy":
        ch[f"uav1.vel.{a}"] = np.where(sol.times < 0.5, 0.0, ch[f"uav1.vel.{a}"])
    ch["uav1.course"] = np.arctan2(ch["uav1.vel.y"], ch["uav1.vel.x"])
    hover = Pred(Bin("-", Const(0.1), Sig("uav1.horizontal_speed")),
                 "uav1.horizontal_speed <= 0.1 m/s", span(14),
                 Bound("uav1.horizontal_speed", "upper", 0.1, Sig("uav1.horizontal_speed")))
    mission = replace(mission, requirement=And((mission.requirement, hover)))
    plots = {p["id"]: p for p in build_view(program, mission,
                                            replace(sol, channels=ch))["signals"]["plots"]}
    err = plots["sig-heading-error-1"]
    assert err["traces"][0]["y"][:5] == [None] * 5 and err["traces"][0]["y"][5] is not None
    assert err["spans"] == [{"start": 0.0, "end": 0.4, "label": "hovering"}]
    assert "0.1 m/s" in err["note"]
    course = plots["sig-heading-1"]["traces"][1]
    assert course["y"][:5] == [None] * 5


def test_team_signals_distance_and_payload():
    program, mission, sol = synthetic_case()
    ch = dict(sol.channels)
    for a, off in zip("xyz", (0.0, 4.0, 0.0), strict=True):
        ch[f"uav2.pos.{a}"] = ch[f"uav1.pos.{a}"] + off
    ch["uav1.payload"] = np.where(sol.times < 1.0, 2.0, 1.0)
    sol = replace(sol, channels=ch, bounds={"distance_min": 3.0})
    view = build_view(program, replace(mission, vehicles=("uav1", "uav2")), sol)
    plots = {p["id"]: p for p in view["signals"]["plots"]}
    dist = plots["sig-distance"]
    assert dist["traces"][0]["name"] == "uav1–uav2"
    assert np.allclose(dist["traces"][0]["y"], 4.0)
    assert [(b["value"], b["text"], b["x0"]) for b in dist["bounds"]] == [(3.0, "Γ_dis = 3 m",
                                                                            None)]
    assert plots["sig-payload"]["traces"][0]["shape"] == "hv"
    assert len(view["scene"]["trajectories"]) == 2
    assert plots["sig-position"]["traces"][3]["name"] == "uav2 x"


def point_mass_team(n: int = 3) -> tuple[Program, Mission, Solution]:
    """``n`` point masses abreast, no human, no risk, no comparison, no energy."""
    program, mission, _ = synthetic_case()
    names = tuple(f"uav{k + 1}" for k in range(n))
    vehicles = {v: PointMass(v, (3.1, 3.1, 3.1), (3.1, 3.1, 3.1), (2.0 * k, -3.0, 0.5),
                             capacity=2)
                for k, v in enumerate(names)}
    sep = Always(0.0, 2.0, Pred(Bin("-", Sig("d"), Const(3.0)),
                                "dist(d.pos, e.pos) >= Gamma_dis", span(13)), span(13))
    mission = replace(mission, vehicles=names, specs={"separation": sep}, requirement=sep,
                      spec_spans={"separation": span(13)})
    program = replace(program, vehicles=vehicles, missions={"demo": mission},
                      scenario=replace(program.scenario, humans=(), regions=tuple(
                          r for r in program.scenario.regions if r.box.frame is None)))
    t = np.round(np.arange(21) * 0.1, 10)
    ch = {}
    for k, v in enumerate(names):
        ch |= {f"{v}.pos.x": 3.5 * k + 0.5 * t, f"{v}.pos.y": -3.0 + t, f"{v}.pos.z": 0.5 + t,
               f"{v}.vel.x": 0.5 + 0 * t, f"{v}.vel.y": 1.0 + 0 * t, f"{v}.vel.z": 1.0 + 0 * t,
               f"{v}.acc.x": 0 * t, f"{v}.acc.y": 0 * t, f"{v}.acc.z": 0 * t,
               f"{v}.speed": 1.5 + 0 * t, f"{v}.course": np.arctan2(1.0, 0.5) + 0 * t}
    sol = Solution("demo", "violated", -0.5, -0.6,
                   {"separation": SpecResult(-0.5, -0.6, False, 0.0,
                                             "dist(d.pos, e.pos) >= Gamma_dis", 13)},
                   0.0, t, ch, solver={"name": "ipopt", "iterations": 12,
                                       "return_status": "Solve_Succeeded"},
                   energy_profile=np.zeros(21),
                   bounds={"speed_axis": [3.1, 3.1, 3.1], "distance_min": 3.0},
                   windows=[Window("separation", 0.0, 2.0)])
    return program, mission, sol


def test_point_mass_team_without_risk_or_comparison():
    view = build_view(*point_mass_team())
    plots = {p["id"]: p for p in view["signals"]["plots"]}
    assert {"sig-position", "sig-speed", "sig-vel", "sig-acc", "sig-distance"} <= set(plots)
    assert not any(k.startswith(("sig-rotor", "sig-force", "sig-heading")) for k in plots)
    assert [t["name"] for t in plots["sig-distance"]["traces"]] == [
        "uav1–uav2", "uav1–uav3", "uav2–uav3"]
    assert {b["text"] for b in plots["sig-vel"]["bounds"]} == {"v̄ = 3.1 m/s", "−v̄"}
    assert len(plots["sig-vel"]["traces"]) == 9
    e = view["energy"]
    assert not e["modelled"] and not e["has_comparison"] and e["profiles"] == []
    assert e["total_text"] == "—" and view["summary"]["energy_text"] == "—"
    assert view["risk"] is None and view["scene"]["humans"] == []
    assert view["banner"]["spec"]["binding_predicate"] == "dist(d.pos, e.pos) ≥ Gamma_dis"
    assert view["signals"]["markers"] == [{"spec": "separation", "t": 0.0,
                                           "label": "separation fails"}]
    html = render_report(view)
    assert "Energy not computed" in html and "paper B's power model" in html
    assert 'id="energy-profile"' not in html


def test_signals_derived_when_channels_missing():
    program, mission, sol = synthetic_case()
    ch = {k: v for k, v in sol.channels.items()
          if k.split(".")[1] in ("pos", "vel", "att")}
    view = build_view(program, mission, replace(sol, channels=ch, energy_profile=None,
                                                comparisons=[], bounds={}, windows=[],
                                                risk=None))
    plots = {p["id"]: p for p in view["signals"]["plots"]}
    assert "sig-speed" in plots and "sig-heading-1" in plots  # from vel and att.z
    assert "sig-rotor" not in plots and "sig-force" not in plots
    assert plots["sig-heading-1"]["band"] is None
    # windows derived from the outermost temporal operator of each spec
    assert view["signals"]["windows"][1] == {"spec": "reach", "start": 1.0, "end": 2.0,
                                             "color": "#ff7f0e", "text": "[1, 2] s"}


def test_energy_and_comparison(view):
    e = view["energy"]
    assert e["modelled"] and e["has_profile"] and e["has_comparison"]
    assert [c["label"] for c in e["columns"]] == ["this plan (w = 0)", f"w = 0 {NASTY}"]
    assert e["columns"][1]["peak_speed_text"] == "2.4 m/s"
    assert e["columns"][0]["peak_rotor_speed_text"].endswith("Hz")
    assert e["columns"][0]["energy_text"].endswith(" J")
    assert e["columns"][0]["delta_text"] == "—"
    assert e["columns"][1]["delta_text"].endswith("(+30 %)")
    assert len(e["profiles"]) == 2 and len(e["profiles"][0]["y"]) == 21
    cum = e["profiles"][0]["cumulative"]
    assert cum[-1] == pytest.approx(e["total"], rel=1e-4)  # per sample: sums to the energy


def test_comparison_labelled_with_its_objective():
    program, mission, sol = synthetic_case()
    mission = replace(mission, objective=Objective(energy_weight=0.5),
                      options={"compare": [("no_energy", Objective())]})
    sol.comparisons = [replace(sol.comparisons[0], label="no_energy",
                               peak_rotor_speed=math.nan)]
    e = build_view(program, mission, sol)["energy"]
    assert [c["label"] for c in e["columns"]] == ["this plan (w = 0.5)", "no_energy (w = 0)"]
    assert e["columns"][1]["peak_rotor_speed_text"] == "—"  # NaN: not recorded


def test_risk_present(view):
    risk = view["risk"]
    a, b = risk["cases"]
    assert a["name"] == "σ² = 0.25" and a["driver"] == "reach"
    assert [r["beta"] for r in a["rows"]] == ["0.7", "0.9"]
    assert a["rows"][0]["var_text"] == "+0.12"
    assert a["rows"][1]["cvar_lower_text"] == "—"
    assert a["p_violation_text"] == "0.081" and a["p_violation_upper_text"] == "0.088"
    assert a["specs"][0]["name"] == "reach"
    assert len(a["histogram"]["centers"]) == 5 and a["histogram"]["centers"][0] == -0.15
    assert b["driver"] == "reach" and b["histogram"] is None  # stlc.analysis.risk format: drivers
    assert b["specs"][0]["share_text"] == "95 %"
    assert a["top_var_text"] == "+0.03" and b["top_beta"] == "0.7"
    assert risk["top_beta"] == "max β"  # the cases' largest β differ


def test_risk_histogram_from_samples(tmp_path):
    program, mission, sol = synthetic_case()
    rng = np.random.default_rng(0)
    rho = rng.normal(0.1, 0.1, 15000)
    view = build_view(program, mission, sol, {"σ² = 0.75/exact/requirement": rho})
    b = view["risk"]["cases"][1]
    h = b["histogram"]
    assert sum(h["counts"]) == 15000 and MIN_BINS <= len(h["counts"]) <= MAX_BINS
    assert min(h["centers"]) > rho.min() and max(h["centers"]) < rho.max()
    assert b["var_lines"][0] == {"beta": "0.7", "value": -0.01, "cvar": -0.1,
                                 "var_text": "−0.01", "cvar_text": "−0.1"}
    # write_report finds risk_samples.npz next to the report (as compile writes it)
    np.savez_compressed(tmp_path / "risk_samples.npz",
                        **{"cases": np.array(["σ² = 0.75"]), "σ² = 0.75/exact/requirement": rho,
                           "σ² = 0.75/param/operator.pos.x": rho})
    assert set(load_samples(tmp_path / "risk_samples.npz")) == {"σ² = 0.75/exact/requirement"}
    write_report(tmp_path / "report.html", program, mission, sol)
    data = json.loads(data_block((tmp_path / "report.html").read_text()).replace("<\\/", "</"))
    assert sum(data["risk"]["cases"][1]["histogram"]["counts"]) == 15000
    assert load_samples(tmp_path / "missing.npz") is None
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    assert load_samples(tmp_path / "bad.npz") is None


def test_risk_case_declaration_linked():
    program, mission, sol = synthetic_case()
    case = RiskCase("σ² = 0.25", (Normal(("operator.pos.x", "operator.pos.y", "operator.pos.z"),
                                         (0.0, 0.0, 0.0),
                                         ((0.25, 0, 0), (0, 0.25, 0), (0, 0, 0))),), span(12))
    mission = replace(mission, risk=RiskConfig((case,)))
    a = build_view(program, mission, sol)["risk"]["cases"][0]
    assert a["distribution"] == "operator.pos ~ N((0, 0, 0) m, diag(0.25, 0.25, 0) m²)"
    assert a["anchor"] == "L12"


def test_risk_absent():
    program, mission, sol = synthetic_case(risk=False)
    view = build_view(program, mission, sol)
    assert view["risk"] is None
    html = render_report(view)
    assert 'id="risk"' not in html and 'href="#risk"' not in html


def test_non_finite_numbers_are_null():
    program, mission, sol = synthetic_case()
    sol.specs["safe"] = replace(sol.specs["safe"], robustness=math.inf, tightest_time=None)
    sol.channels["uav1.speed"] = sol.channels["uav1.speed"].copy()
    sol.channels["uav1.speed"][3] = math.nan
    view = build_view(program, mission, sol)
    json.dumps(view, allow_nan=False)
    assert view["specs"][0]["robustness_text"] == "+∞"
    assert view["specs"][0]["tightest_text"] == "—"
    render_report(view)


def test_empty_solution_still_renders():
    """A solver that failed before producing a plan: no samples, no channels, no specs."""
    program, mission, _ = synthetic_case()
    program = replace(program, scenario=Scenario())
    sol = Solution("demo", "solver_failed", -math.inf, -math.inf, {}, math.nan,
                   np.zeros(0), {}, solver={"name": "ipopt",
                                            "return_status": "Invalid_Number_Detected"})
    view = build_view(program, mission, sol)
    json.dumps(view, allow_nan=False)
    assert view["signals"]["plots"] == [] and view["scene"]["trajectories"] == []
    assert view["banner"]["title"] == "Solver failed" and view["banner"]["spec"] is None
    html = render_report(view)
    assert "Invalid_Number_Detected" in html and "The mission has no named specs." in html


def test_num_rounds_to_five_digits():
    assert num(1.23456789) == 1.2346
    assert num(123456.7) == 123460.0
    assert num(math.inf) is None and num(None) is None and num("x") is None


READABLE_SPECS = """
spec a = uav1.pos not in operator.behind
spec b = not (uav1.pos in pole)
spec c = uav1.pos in operator.handover
spec d = uav1.rotor_speed in [40 Hz, 80 Hz]
spec e = not (uav1.rotor_speed in [40 Hz, 80 Hz])
spec f = abs(angdiff(uav1.heading, uav1.course)) <= 30 deg
spec g = not (uav1.speed <= 0.4 m/s)
spec h = not (uav1.pos.x<=2 m)
spec i = always[0, 5] (uav1.pos in operator.visibility) and eventually[0, 5] (uav1.pos in
         operator.handover) and (uav1.pos not in operator.handover) until[0, 5] true
"""


@pytest.fixture(scope="module")
def readable_program(tmp_path_factory):
    from stlc.pipeline import load

    src = (Path(__file__).parent.parent / "specs" / "handover.stl").read_text()
    path = tmp_path_factory.mktemp("readable") / "r.stl"
    path.write_text(src[:src.index("# ---- shared")] + READABLE_SPECS, encoding="utf-8")
    return load(str(path)).program


@pytest.mark.parametrize("spec, texts", [
    # box membership is six face predicates; the normal form pushes the negation of `not
    # in` onto each face (``origin.negated``): outside, past that face
    ("a", {"uav1.pos outside operator.behind (y > hi)", "uav1.pos outside operator.behind "
           "(x < lo)"}),
    ("b", {"uav1.pos outside pole (x < lo)"}),
    ("c", {"uav1.pos in operator.handover (x ≥ lo)", "uav1.pos in operator.handover (z ≤ hi)"}),
    ("d", {"uav1.rotor_speed ≥ 40 Hz", "uav1.rotor_speed ≤ 80 Hz"}),
    ("e", {"uav1.rotor_speed > 80 Hz", "uav1.rotor_speed < 40 Hz"}),
    ("f", {"abs(angdiff(uav1.heading, uav1.course)) ≤ 30 deg"}),
    ("g", {"uav1.speed > 0.4 m/s"}),
    ("h", {"uav1.pos.x > 2 m"}),  # the operands as written, the operator flipped
])
def test_readable_predicates_from_their_origin(readable_program, spec, texts):
    """The checker records each predicate's origin; ``readable`` renders it (the label is
    not read, except as the fallback of a predicate built without one)."""
    from stlc.semantics import ir, nnf

    preds = ir.predicates(nnf.normalize(readable_program.specs[spec]))
    assert all(p.origin is not None for p in preds)
    assert texts <= {readable(p.origin, p.label) for p in preds}


def test_readable_without_origin():
    assert readable(None, "not (f(x))") == "not (f(x))"
    assert readable(None, "") == "—"


def test_region_uses_come_from_the_origins(readable_program):
    from stlc.output.report.predicates import mentioned
    from stlc.output.report.scene import region_uses

    uses = region_uses([readable_program.specs[s] for s in ("a", "b", "i")])
    assert uses["operator.behind"] == {"out"} and uses["pole"] == {"out"}
    assert uses["operator.visibility"] == {"stay"}
    assert uses["operator.handover"] == {"in", "out"}
    assert mentioned([readable_program.specs["i"]]) == {"operator.visibility",
                                                        "operator.handover"}


def test_the_binding_predicate_keeps_its_line_through_negation():
    """The normal form pushes ``not`` onto the face predicates; each keeps the span of the
    predicate written in the source (the report's link to the binding predicate)."""
    from stlc.semantics import ir, nnf

    f = formulas()["safe"]
    lines = {p.span.line for p in ir.predicates(nnf.normalize(ir.Not(f)))}
    assert 13 in lines and 0 not in lines


def test_source_lines(view):
    lines = view["source"]["lines"]
    assert lines[0]["code"] == "" and lines[0]["comment"].startswith("# handover test mission")
    l15 = lines[14]
    assert l15["code"].strip() == "require safe and reach"
    assert l15["comment"].startswith("# </script>")
    assert "spec" in lines[12]["cls"] and "binding" in lines[12]["cls"]
    assert "in-mission" in lines[10]["cls"] and lines[2]["cls"] == ""


def test_spec_spanning_several_lines_is_highlighted():
    program, mission, sol = synthetic_case()
    mission = replace(mission, spec_spans={**mission.spec_spans,
                                           "safe": Span(FILE, 13, 3, 14, 10)})
    lines = build_view(program, mission, sol)["source"]["lines"]
    assert "spec" in lines[12]["cls"] and "spec" in lines[13]["cls"]
    # a span that runs to the next declaration (column 1) leaves out the comment lines
    # and blank lines before it
    source = program.source.replace("  require safe", "  # the requirement:\n\n  require safe")
    program = replace(program, source=source)
    mission = replace(mission, spec_spans={"safe": Span(FILE, 13, 3, 14, 1),
                                           "reach": Span(FILE, 14, 3, 17, 1)})
    rows = {r["name"]: r for r in build_view(program, mission, sol)["specs"]}
    assert (rows["safe"]["line"], rows["safe"]["end_line"]) == (13, 13)
    assert (rows["reach"]["line"], rows["reach"]["end_line"]) == (14, 14)


# --------------------------------------------------------------------------- rendering


def test_render_satisfied(case):
    html = render_report(build_view(*case))
    assert html.startswith("<!DOCTYPE html>")
    for section in ("summary", "requirements", "scene-section", "signals", "energy", "risk",
                    "source"):
        assert f'<section id="{section}"' in html
    assert 'role="alert"' not in html
    assert '<a href="#L13">' in html and 'id="L13"' in html
    assert "Plotly" in html  # plotly.js is inlined
    # self-contained: no external resources
    assert not re.search(r"<(script|link|img|iframe)[^>]+(src|href)=", html)
    json.loads(data_block(html).replace("<\\/", "</"))


@pytest.mark.parametrize("status", ["violated", "solver_failed"])
def test_failure_banner_names_the_spec(status):
    program, mission, sol = synthetic_case(status)
    view = build_view(program, mission, sol)
    b = view["banner"]
    assert b["status"] == status and b["spec"]["name"] == "reach"
    assert b["spec"]["margin_text"] == "0.12" and b["spec"]["tightest_text"] == "1.5 s"
    assert view["signals"]["markers"] == [{"spec": "reach", "t": 1.5, "label": "reach fails"}]
    html = render_report(view)
    banner = html[html.index('role="alert"'):html.index('<section id="summary"')]
    assert "reach" in banner and "1.5 s" in banner and "0.12" in banner
    assert ("Solver failed" if status == "solver_failed" else "Mission violated") in banner
    if status == "solver_failed":
        assert "Maximum_Iterations_Exceeded" in banner
    assert html.index('role="alert"') < html.index('id="summary"')
    assert 'class="line spec fail"' in html or "fail" in html[html.index('id="L14"') - 40:]


def test_mission_text_is_escaped(case):
    html = render_report(build_view(*case))
    block = data_block(html)
    page = html.replace(block, "")
    assert "<script>window.__pwned" not in page
    assert "w = 0 &lt;/script&gt;&lt;script&gt;window.__pwned = 3" in html  # table header
    assert "&lt;script&gt;window.__pwned = 1&lt;/script&gt;" in html
    assert 'onerror="window' not in html and "&lt;img src=x onerror=" in html
    assert "</script" not in block and "<\\/script>" in block
    assert "<script>window.__pwned = 3<\\/script>" in block
    data = json.loads(block.replace("<\\/", "</"))
    assert NASTY in json.dumps(data, ensure_ascii=False)
    # in the data block "<script>" is inert: nothing in it can close the element
    assert len(re.findall(r"<script\b", page)) == 3  # the page's own three blocks


def test_script_json_escapes_comment_openers():
    text = str(script_json({"a": "<!-- </script> </SCRIPT"}))
    assert "<!--" not in text and "</" not in text
    assert json.loads(text.replace("<\\/", "</")) == {"a": "<!-- </script> </SCRIPT"}


def test_write_report_is_atomic(tmp_path, case):
    path = tmp_path / "out" / "report.html"
    n = write_report(path, *case)
    assert n == path.stat().st_size and n > 100_000
    assert os.listdir(path.parent) == ["report.html"]
    assert path.read_text(encoding="utf-8").endswith("</html>\n")
    n2 = write_report(path, *case)  # overwriting works too
    assert n2 == n


def test_region_roles_do_not_depend_on_names(tmp_path):
    """The shipped handover with its human's regions renamed (``behind`` → ``zone1``,
    ``visibility`` → ``zone2``, ``handover`` → ``zone3``) colours them as before: by use."""
    from stlc.output.report.scene import region_uses
    from stlc.pipeline import load

    src = (Path(__file__).parent.parent / "specs" / "handover.stl").read_text()
    for old, new in (("operator.behind", "operator.zone1"), ("region behind", "region zone1"),
                     ("operator.visibility", "operator.zone2"),
                     ("region visibility", "region zone2"),
                     ("operator.handover", "operator.zone3"), ("region handover", "region zone3")):
        src = src.replace(old, new)
    path = tmp_path / "renamed.stl"
    path.write_text(src, encoding="utf-8")
    program = load(str(path)).program
    m = program.missions["handover_left_tb"]
    uses = region_uses([m.requirement, *m.specs.values()])
    roles = {r.name: region_role(r.kind, r.box.frame, uses.get(r.name, set()))
             for r in program.scenario.regions}
    assert roles["operator.zone1"] == "nofly" and roles["operator.zone2"] == "visibility"
    assert roles["operator.zone3"] == "approach" and roles["operator.ltb1"] == "approach"
    assert roles["pole"] == "nofly" and roles["workspace"] == "workspace"


def test_solver_details_are_spelled_out_not_python():
    from stlc.output.report.view import _plain

    phases = [["first plan", 0.25, True], ["better class (choices free)", 1.5, False]]
    assert _plain(phases) == "first plan, 0.25, True; better class (choices free), 1.5, False"
    assert _plain({"grid": 0.5, "binaries": 120}) == "grid: 0.5; binaries: 120"
    assert _plain([]) == "—" and _plain({}) == "—"


def test_the_templates_cache_going_away_only_costs_a_compile(tmp_path):
    import shutil

    import jinja2

    from stlc.output.report.render import _BytecodeCache

    d = tmp_path / "cache"
    d.mkdir()
    env = jinja2.Environment(loader=jinja2.DictLoader({"t": "{{ x }}!"}),
                             bytecode_cache=_BytecodeCache(str(d)))
    assert env.get_template("t").render(x=1) == "1!"
    assert any(p.name.startswith("__jinja2_") for p in d.iterdir())  # kept for the next
    shutil.rmtree(d)  # the user deletes the cache while a run goes on
    env2 = jinja2.Environment(loader=jinja2.DictLoader({"t": "{{ x }}?"}),
                              bytecode_cache=_BytecodeCache(str(d)))
    assert env2.get_template("t").render(x=2) == "2?"
