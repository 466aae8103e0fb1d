"""Large absolute coordinates (``stlc.planning.frame``): a mission and its translate to UTM
scale (easting 4.5e5 m, northing 5.4e6 m) get the same verdict and robustness; the written
trajectory of a UTM plan is the verified one."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import stlc
from stlc.planning.frame import Frame, shift_formula, to_local
from stlc.planning.problem import from_mission
from stlc.semantics import ir

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
UTM = (4.5e5, 5.4e6, 0.0)


def mission(start, goal, obstacle, step, kappa, shift=(0.0, 0.0, 0.0)) -> str:
    """A point-mass survey: reach a 1 m goal box, stay in the workspace, avoid an obstacle
    (coordinates relative to the workspace corner, then moved by ``shift``)."""
    def p(v):
        return "(" + ", ".join(repr(float(a) + d) for a, d in zip(v, shift)) + ")"

    obs = ""
    if obstacle is not None:
        obs = f"  obstacle wall = box({p(obstacle)}, {p(np.add(obstacle, (1, 1, 20)))}) m\n"
    return (
        "vehicle d : point_mass {\n  vel_max = (2, 2, 2) m/s\n  acc_max = (1, 1, 1) m/s^2\n"
        f"  start {{ pos = {p(start)} m }}\n}}\n"
        f"scenario {{\n  workspace = box({p((0, 0, 0))}, {p((20, 20, 20))}) m\n"
        f"  target goal = box({p(goal)}, {p(np.add(goal, 1))}) m\n{obs}}}\n"
        f"mission survey {{\n  vehicles = [d]\n  horizon = 6 s\n  step = {step} s\n"
        f"  threshold = {kappa}\n"
        "  spec inside = always[0, 6] (d.pos in workspace)\n"
        "  spec reach = eventually[0, 6] (d.pos in goal)\n"
        + ("  spec clear = always[0, 6] (d.pos not in wall)\n"
           "  require inside and reach and clear\n" if obstacle is not None else
           "  require inside and reach\n")
        + "  maximize robustness\n}\n")


def test_offsets_fold_into_the_predicates_constants():
    prog = stlc.loads(mission((10, 10, 10), (11.5, 9.5, 9.5), None, 1, 0, UTM))
    local, fr = to_local(from_mission(prog, prog.missions["survey"]))
    assert fr.origin == (450000.0, 5400000.0, 0.0)
    consts = [abs(n.value) for p in ir.predicates(local.requirement)
              for n in ir.expr_nodes(p.expr) if isinstance(n, ir.Const)]
    assert consts and max(consts) <= 20.0  # the workspace's local extent, no 5.4e6
    assert local.program.vehicles["d"].start_pos == (10.0, 10.0, 10.0)
    # the rewrite keeps the value: x' + o − c at a point equals x − c
    f = ir.Pred(ir.Bin("*", ir.Const(2.0), ir.Bin("-", ir.Sig("d.pos.x"), ir.Const(450003.0))))
    g = shift_formula(f, Frame((450000.0, 0.0, 0.0)))
    assert g.expr == ir.Bin("*", ir.Const(2.0), ir.Bin("-", ir.Sig("d.pos.x"), ir.Const(3.0)))
    h = shift_formula(ir.Pred(ir.Call("abs", (ir.Sig("d.pos.y"),))), Frame((0.0, 8e3, 0.0)))
    assert h.expr == ir.Call("abs", (ir.Bin("+", ir.Sig("d.pos.y"), ir.Const(8e3)),))


def _plan(text):
    p = stlc.compile(stlc.loads(text), risk=False)
    return p.status, p.robustness


@settings(max_examples=3, deadline=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(start=st.tuples(st.integers(2, 18), st.integers(2, 18), st.integers(1, 15)),
       goal=st.tuples(st.integers(-4, 3), st.integers(-4, 3), st.integers(-3, 2)),
       wall=st.booleans(), step=st.sampled_from([1, 0.5]), kappa=st.sampled_from([0, 0.1]))
def test_translate_to_utm_keeps_verdict_and_robustness(start, goal, wall, step, kappa):
    g = tuple(min(max(s + d, 0), 19) for s, d in zip(start, goal))
    obstacle = None
    if wall:
        obstacle = tuple((s + t) / 2 for s, t in zip(start, g))[:2] + (0,)
        if all(a <= s <= a + 1 for a, s in zip(obstacle[:2], start[:2])):
            obstacle = None
    here = _plan(mission(start, g, obstacle, step, kappa))
    there = _plan(mission(start, g, obstacle, step, kappa, UTM))
    assert here[0] == there[0]
    assert abs(here[1] - there[1]) <= 1e-6


def test_utm_survey_at_a_fine_step_finds_the_plan(tmp_path):
    """A 1 m goal box 2 m from the start at UTM coordinates, 0.1 s step: the optimum is
    +0.5 (the box's half width), as at the origin; the written CSV monitors to the same ρ."""
    spec = tmp_path / "utm.stl"
    spec.write_text(mission((10, 10, 10), (11.5, 9.5, 9.5), None, 0.1, 0, UTM))
    out = tmp_path / "o"
    env = dict(os.environ, PYTHONPATH=ROOT)
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(spec), "-o", str(out),
                        "--no-risk"], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "no plan exists" not in r.stderr
    sol = json.loads((out / "solution.json").read_text())
    assert sol["status"] == "satisfied"
    assert abs(sol["robustness"]["exact"] - 0.5) <= 1e-6
    m = subprocess.run([sys.executable, "-m", "stlc", "monitor", str(spec), "--trace",
                        str(out / "trajectory.csv"), "--json"], capture_output=True,
                       text=True, env=env, timeout=120)
    assert json.loads(m.stdout)["specs"]["survey"]["robustness"] == sol["robustness"]["exact"]


@settings(max_examples=10, deadline=None, derandomize=True)
@given(start=st.tuples(*[st.decimals("0.05", "19.95", places=3)] * 3),
       goal=st.tuples(*[st.decimals("0.05", "18.95", places=3)] * 3),
       km=st.tuples(st.integers(1, 900), st.integers(1, 9000), st.just(0)))
def test_a_mission_moved_by_whole_kilometres_is_planned_as_the_original(start, goal, km):
    """Decimal coordinates moved to UTM (``450000.3`` is not exactly 450000 + 0.3 in binary)
    give, to 10 nm, the very local problem of the original — bit for bit, so the same plan:
    the same start and boxes, and every predicate the same number on a random trace."""
    from stlc.analysis import monitor

    shift = tuple(1000.0 * k for k in km)
    s, g = start, goal  # decimals, so the original's text has 1.656, not 1.6560000000000001
    here = stlc.loads(mission(s, g, None, 1, 0.1))
    there = stlc.loads(mission(s, g, None, 1, 0.1, shift))
    a = from_mission(here, here.missions["survey"])
    b, fr = to_local(from_mission(there, there.missions["survey"]))
    assert fr.origin == shift
    assert b.program.vehicles["d"].start_pos == a.program.vehicles["d"].start_pos
    assert [r.box for r in b.program.scenario.regions] == \
        [r.box for r in a.program.scenario.regions]
    rng = np.random.default_rng(int(sum(km)))
    trace = {f"d.pos.{ax}": rng.uniform(-1, 21, 7) for ax in "xyz"}
    for p, q in zip(ir.predicates(a.requirement), ir.predicates(b.requirement)):
        assert np.array_equal(monitor.robustness_signal(p, 1.0, trace, a.params),
                              monitor.robustness_signal(q, 1.0, trace, b.params))
