"""Disturbance replanning (paper A §4.4, ``stlc.replan.disturb``) on cheap hover plans.

The nominal plans are hovers (point mass: zero acceleration; hexarotor: the hover forces,
zero ξ̇), which are exact equilibria of the models, so every expected number is computed
by hand: a displacement persists unchanged under open-loop flight, a velocity kick grows
linearly, the replan's segment is fixed by T_e, t_c and T_g, and the kept spec's margin is
a box distance evaluated here with numpy (not with the project's monitor).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from stlc import pipeline, vehicles
from stlc.backends.nlp.model import substeps
from stlc.planning.solution import Solution
from stlc.vehicles import dynamics
from stlc.planning.problem import from_mission
from stlc.backends.replan.segment import SegmentBackend
from stlc.planning.kept import KeptSpecError
from stlc.replan import disturb
from stlc.replan.disturb import DisturbanceError
from stlc.semantics import model


def simulate_disturbances(*args, **kw):
    """The simulation with the segment backend the pipeline gives it."""
    return disturb.simulate_disturbances(*args, segment=SegmentBackend, **kw)


POINT = """
vehicle p1 : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (3, 3, 3) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-3, -3, 0), (3, 3, 3)) m
  obstacle wall = box((-0.8, -0.2, 0), (-0.4, 0.5, 2.5)) m
}
spec safety = always[0, 6] (p1.pos in workspace and p1.pos not in wall)
spec reach = eventually[0, 6] (p1.pos.x >= 0)
mission hold {
  vehicles = [p1]
  horizon = 6 s
  step = 0.1 s
  threshold = 0.01
  require safety and reach
  replan { threshold = 1 m; event_period = 0.5 s; waypoint_period = 1 s; budget = 0.4 s
           keep = [safety] }
}
"""

HEXA = """
vehicle uav1 : multirotor {
  mass    = 2.25 kg
  inertia = diag(2.07e-2, 2.10e-2, 3.10e-2) kg*m^2
  c_f     = 11.5e-4
  c_tau   = 2.38e-5
  force   = [0.29 N, 11.5 N]
  rotors  = hexarotor(arm = 0.39 m, tilt = 20 deg)
  start { pos = (0, 0, 1.0) m; att = (0, 0, 0) deg }
}
scenario { workspace = box((-3, -3, 0), (3, 3, 2.5)) m }
spec safety = always[0, 4] (uav1.pos in workspace)
mission hover {
  vehicles = [uav1]
  horizon = 4 s
  step = 0.1 s
  threshold = 0.01
  require safety
  replan { threshold = 1 m; event_period = 0.5 s; waypoint_period = 1 s; budget = 0.9 s
           keep = [safety] }
}
"""


def setup(tmp_path: Path, text: str, mission: str):
    path = tmp_path / "m.stl"
    path.write_text(text)
    program = pipeline.load(str(path)).program
    m = program.missions[mission]
    problem = from_mission(program, m)
    n = problem.grid.n
    ch = {}
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        x0 = vm.initial_state(v)
        for i, c in enumerate(vm.state_channels(v)):
            ch[c] = np.full(n, x0[i])
        for c in vm.input_channels(v):
            ch[c] = np.zeros(n)
    plan = Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0, problem.grid.times(), ch)
    return problem, plan, m.replan


def pos(res, name: str, k: int) -> np.ndarray:
    return np.array([res.executed[f"{name}.pos.{a}"][k] for a in "xyz"])


@pytest.fixture(scope="module")
def point(tmp_path_factory):
    return setup(tmp_path_factory.mktemp("point"), POINT, "hold")


def test_below_threshold_does_not_trigger_and_persists(point):
    problem, plan, cfg = point
    res = simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (0.0, 0.6, 0.0))],
                                cfg)
    assert [e.time for e in res.events] == pytest.approx([0.5 * k for k in range(13)])
    assert not any(e.triggered for e in res.events)
    for e in res.events:  # no controller: the 0.6 m offset stays, from the push on
        assert e.deviation == pytest.approx(0.6 if e.time >= 1.0 else 0.0, abs=1e-9)
    assert pos(res, "p1", -1) == pytest.approx([0.0, 0.6, 1.0], abs=1e-9)


def test_velocity_kick_triggers_when_the_drift_exceeds_zeta(point):
    problem, plan, cfg = point
    kick = model.Disturbance("p1", 1.0, velocity=(0.0, -0.45, 0.0))
    res = simulate_disturbances(problem, plan, [kick], cfg)
    # deviation 0.45 m/s · (t − 1 s): 0.9 m at 3.0 s (≤ ζ), 1.125 m at 3.5 s
    first = next(e for e in res.events if e.triggered)
    assert first.time == pytest.approx(3.5)
    assert first.deviation == pytest.approx(1.125, abs=1e-9)
    before = [e for e in res.events if e.time < 3.5]
    assert [e.deviation for e in before] == pytest.approx(
        [max(0.0, 0.45 * (e.time - 1.0)) for e in before], abs=1e-9)


def test_push_above_threshold_replans_around_the_kept_obstacle(point):
    problem, plan, cfg = point
    res = simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (-1.2, 0.0, 0.0))],
                                cfg)
    trig = res.triggered
    assert len(trig) == 1
    e = trig[0]
    assert e.time == pytest.approx(1.0) and e.deviation == pytest.approx(1.2)
    # start t_e + t_c = 1.4 s; goal: the first 1 s waypoint at least T_g later = 3.0 s
    assert e.segment == pytest.approx((1.4, 3.0))
    assert e.status in ("optimal", "acceptable") and e.accepted and e.within_budget
    ws_lo, ws_hi = np.array([-3, -3, 0]), np.array([3, 3, 3])
    w_lo, w_hi = np.array([-0.8, -0.2, 0]), np.array([-0.4, 0.5, 2.5])

    def margin_of(P):  # safety robustness per sample: min(inside workspace, outside wall)
        inside_ws = np.min(np.hstack([P - ws_lo, ws_hi - P]), axis=1)
        outside_wall = np.max(np.hstack([w_lo - P, P - w_hi]), axis=1)
        return np.minimum(inside_ws, outside_wall)

    # the straight way back from (-1.2, 0, 1) to (0, 0, 1) crosses the wall (0.2 m deep) ...
    line = np.linspace([-1.2, 0.0, 1.0], [0.0, 0.0, 1.0], 61)
    assert margin_of(line).min() == pytest.approx(-0.2)
    # ... the flown path goes round it: the safety margin by hand, on every sample
    P = np.stack([res.executed[f"p1.pos.{a}"] for a in "xyz"], axis=1)
    margin = margin_of(P)
    assert margin.min() >= problem.threshold - 1e-9
    seg = slice(15, 31)  # samples after 1.4 s up to 3.0 s
    assert e.kept["safety"] == pytest.approx(margin[seg].min(), abs=1e-9)
    assert res.executed_robustness["safety"] == pytest.approx(margin.min(), abs=1e-9)
    # rejoined: from 3.0 s on the vehicle hovers at the plan's position again
    assert pos(res, "p1", 30) == pytest.approx([0.0, 0.0, 1.0], abs=1e-6)
    assert pos(res, "p1", -1) == pytest.approx([0.0, 0.0, 1.0], abs=1e-6)
    assert all(not x.triggered for x in res.events if x.time > 1.0)


def test_pending_replan_is_the_reference_until_it_starts(point):
    """t_c = 0.6 s: the replan triggered at 1.0 s starts at 1.6 s; the event at 1.5 s
    compares with the predicted path (the pushed hover), so it does not trigger again."""
    problem, plan, cfg = point
    cfg = replace(cfg, compute_budget=0.6)
    res = simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (0.0, 1.2, 0.0))],
                                cfg)
    (e,) = res.triggered
    assert e.segment == pytest.approx((1.6, 3.0)) and e.accepted
    at = {round(x.time, 6): x.deviation for x in res.events}
    assert at[1.0] == pytest.approx(1.2) and at[1.5] == pytest.approx(0.0, abs=1e-9)
    # the vehicle hovers where it was pushed until the replan starts
    assert pos(res, "p1", 16) == pytest.approx([0.0, 1.2, 1.0], abs=1e-9)
    assert pos(res, "p1", 30) == pytest.approx([0.0, 0.0, 1.0], abs=1e-6)


def test_a_segment_too_short_to_rejoin_is_lengthened(point):
    """t_c = 0.9 s: the waypoint rule gives the first segment 1.9 → 3.0 s, 1.1 s; rest to
    rest with |a| ≤ 3 m/s² covers at most a·T²/4 = 0.9075 m < 1.2 m in that time, so the
    goal moves to the first waypoint at least 2·√(1.2/3) = 1.265 s (13 steps, + 1) after
    1.9 s: 4.0 s.  One replan, flown, back on the plan at 4.0 s."""
    problem, plan, cfg = point
    cfg = replace(cfg, compute_budget=0.9)
    res = simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (0.0, 1.2, 0.0))],
                                cfg)
    (first,) = res.triggered
    assert first.segment == pytest.approx((1.9, 4.0))
    assert first.detail["lengthened"] == {"steps": 21, "needed_steps": 14}
    assert first.accepted and first.status in ("optimal", "acceptable")
    assert pos(res, "p1", 19) == pytest.approx([0.0, 1.2, 1.0], abs=1e-9)
    assert pos(res, "p1", 40) == pytest.approx([0.0, 0.0, 1.0], abs=1e-6)


def test_impossible_budget_is_reported_and_not_flown(point):
    problem, plan, cfg = point
    cfg = replace(cfg, compute_budget=1e-4)
    res = simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (1.2, 0.0, 0.0))],
                                cfg)
    trig = res.triggered
    assert trig, "a 1.2 m push must trigger"
    for e in trig[:-1]:
        assert e.status == "max_time"
        assert e.solve_s is not None and e.solve_s > 0
        assert e.within_budget is False and e.accepted is False
    # at 6 s no sample is left after t_e + t_c: triggered, not run, not flown
    assert trig[-1].status == "not_run" and trig[-1].accepted is False
    # never flown: every later event still sees the 1.2 m offset, and it is still there
    assert [e.time for e in trig] == pytest.approx([1.0 + 0.5 * k for k in range(11)])
    assert pos(res, "p1", -1) == pytest.approx([1.2, 0.0, 1.0], abs=1e-9)
    assert any("budget = 0.0001 s is not a multiple" in note for note in res.notes)
    d = res.to_json_dict()
    assert d["events"][2]["status"] == "max_time" and d["events"][2]["solve_s"] > 0


def test_hexarotor_replan_obeys_the_dynamics_and_rejoins(tmp_path):
    problem, plan, cfg = setup(tmp_path, HEXA, "hover")
    res = simulate_disturbances(problem, plan, [model.Disturbance("uav1", 0.8, (0.0, 1.2, 0.0))],
                                cfg)
    (e,) = res.triggered
    # t_c = 0.9 s here: start 1.9 s, goal the first waypoint ≥ 2.9 s
    assert e.time == pytest.approx(1.0) and e.segment == pytest.approx((1.9, 3.0))
    assert e.accepted
    v = problem.vehicles()[0]
    vm = vehicles.model_of(v)
    names = vm.state_channels(v)
    X = np.stack([e.channels[c] for c in names], axis=1)
    U = np.stack([e.channels[c] for c in vm.input_channels(v)], axis=1)[:-1]
    # integrate the replan's inputs with an independent numpy RK4 of the model equations
    f = dynamics.multirotor_ode_np(v)
    dt = problem.grid.dt
    h = dt / substeps(dt)
    x = X[0].copy()
    for k, u in enumerate(U):
        for _ in range(substeps(dt)):
            k1 = f(x, u)
            k2 = f(x + h / 2 * k1, u)
            k3 = f(x + h / 2 * k2, u)
            k4 = f(x + h * k3, u)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        assert x == pytest.approx(X[k + 1], abs=1e-8)
    # the start is the pushed hover state, the end the hover state itself (full state)
    hover = vm.initial_state(v)
    assert X[0][:3] == pytest.approx([0.0, 1.2, 1.0], abs=1e-9)
    assert X[-1] == pytest.approx(hover, abs=1e-5)
    # the force bounds hold, and the executed trajectory is the replan on its segment
    F = X[:, 12:]
    assert F.min() >= v.force_min - 1e-6 and F.max() <= v.force_max + 1e-6
    for c in names:
        assert res.executed[c][19:31] == pytest.approx(e.channels[c], abs=1e-9)
    assert pos(res, "uav1", -1) == pytest.approx([0.0, 0.0, 1.0], abs=1e-5)
    assert res.executed_robustness["safety"] >= problem.threshold


def test_bad_inputs_raise_errors_naming_the_culprit(point):
    problem, plan, cfg = point
    with pytest.raises(DisturbanceError, match="uav9"):
        simulate_disturbances(problem, plan, [model.Disturbance("uav9", 1.0)], cfg)
    with pytest.raises(DisturbanceError, match="outside the horizon"):
        simulate_disturbances(problem, plan, [model.Disturbance("p1", 7.5)], cfg)
    with pytest.raises(KeptSpecError, match="`reach`") as err:
        simulate_disturbances(problem, plan, [], replace(cfg, specs=("reach",)))
    assert err.value.spec == "reach" and isinstance(err.value, ValueError)
    with pytest.raises(KeptSpecError, match="`nope`"):
        simulate_disturbances(problem, plan, [], replace(cfg, specs=("nope",)))


def test_inexact_plan_is_flown_with_its_defects(point):
    """A plan whose states do not follow from its inputs (here: hovering in place while
    its velocity channel says 0.1 m/s along x, i.e. a 0.01 m defect per 0.1 s step) is
    flown exactly as planned when undisturbed, and the defect is noted."""
    problem, plan, cfg = point
    ch = dict(plan.channels)
    ch["p1.vel.x"] = np.full(problem.grid.n, 0.1)
    bent = replace(plan, channels=ch)
    res = simulate_disturbances(problem, bent, [], cfg)
    assert not any(e.triggered for e in res.events)
    assert max(e.deviation for e in res.events) == pytest.approx(0.0, abs=1e-12)
    assert res.executed["p1.pos.x"] == pytest.approx(np.zeros(problem.grid.n), abs=1e-12)
    assert any("defects up to 0.01 m" in note for note in res.notes)


def test_bad_replan_settings_and_values_raise(point):
    problem, plan, cfg = point
    with pytest.raises(ValueError, match="event_period"):
        simulate_disturbances(problem, plan, [], replace(cfg, event_period=0.0))
    with pytest.raises(DisturbanceError, match="not finite"):
        simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (math.nan, 0, 0))],
                              cfg)
    with pytest.raises(DisturbanceError, match="beyond 1000 m"):  # fuzz: 1e300 m hung replans
        simulate_disturbances(problem, plan, [model.Disturbance("p1", 1.0, (1e300, 0, 0))],
                              cfg)
