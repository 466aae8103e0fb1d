"""Replanning from inside a kept spec's violation set (``stlc.replan.disturb``: a recovery).

A point mass hovers 2 m from a round tower (radius 1 m) in a box it must stay in, and
keeps a 1 m clearance (the plan is that hover: `stlc simulate` plans it, the API tests fly
it as built here).  A push
of 1.6 m towards the tower at 4 s leaves it 0.4 m from the surface: clearance robustness
0.4 − 1 = −0.6 m, already broken where any replan starts.  The nominal plan is the hover
(an exact equilibrium), so every number here is computed by hand: the replan triggered at
4 s starts at s = 4.5 s (t_c = 0.4 s); getting back to κ (dist ≥ 1.05 m, x ≤ −2.05 m) from
rest at |a| ≤ 1.5 m/s² covers 0.1875·j² m in j steps of 0.5 s, so the earliest sample back
is j = 2 (0.75 m ≥ 0.65 m): 5.5 s.  Nulling the 1.6 m from rest takes 2·√(1.6/1.5) = 2.07 s,
more than the waypoint rule's 1.5 s segment, so the segment is lengthened.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stlc import cli, pipeline, vehicles
from stlc.backends.replan.segment import SegmentBackend
from stlc.planning.problem import from_mission
from stlc.planning.solution import Solution
from stlc.replan import disturb, explain
from stlc.semantics import model

HOVER = """
vehicle p : point_mass {
  vel_max = (2, 2, 1) m/s
  acc_max = (1.5, 1.5, 1) m/s^2
  start { pos = (-3, 0, 3) m }
}

scenario {
  workspace = box((-10, -10, 0), (10, 10, 12)) m
  obstacle tower = cylinder(center = (0, 0, 5) m, radius = 1 m, height = 10 m)
  target spot = box((-3.2, -1, 2.8), (-2.8, 1, 3.2)) m
}

mission watch {
  vehicles  = [p]
  horizon   = 12 s
  step      = 0.5 s
  threshold = 0.05
  spec clearance = always[0, 12] (dist(p.pos, tower) >= 1 m)
  spec stay = always[0, 12] (p.pos in spot)
  require clearance and stay
  replan { threshold = 0.3 m; event_period = 0.5 s; waypoint_period = 1 s; budget = 0.4 s
           keep = [clearance] }
  simulate { disturb p { time = 4 s; displacement = (1.6, 0, 0) m } }
}
"""


def _hover(path):
    """The mission of ``path`` and its plan: the hover at the start (an exact equilibrium)."""
    program = pipeline.load(str(path)).program
    m = program.missions["watch"]
    problem = from_mission(program, m)
    v = problem.vehicles()[0]
    vm = vehicles.model_of(v)
    n = problem.grid.n
    x0 = vm.initial_state(v)
    ch = {c: np.full(n, x0[i]) for i, c in enumerate(vm.state_channels(v))}
    ch.update({c: np.zeros(n) for c in vm.input_channels(v)})
    plan = Solution(m.name, "satisfied", 0.0, 0.0, {}, 0.0, problem.grid.times(), ch)
    return m, problem, plan


@pytest.fixture(scope="module")
def pushed(tmp_path_factory):
    path = tmp_path_factory.mktemp("recovery") / "watch.stl"
    path.write_text(HOVER)
    m, problem, plan = _hover(path)
    res = disturb.simulate_disturbances(problem, plan, list(m.simulate.disturbances), m.replan,
                                        segment=SegmentBackend)
    return path, res


def test_a_push_into_the_clearance_band_is_recovered_by_one_replan(pushed):
    _, res = pushed
    (e,) = res.triggered  # one replan, flown: no string of rejected events
    assert e.time == pytest.approx(4.0) and e.accepted
    assert e.segment[0] == pytest.approx(4.5)
    rec = e.detail["recovery"]
    assert rec["broken_at_start"] == {"clearance": pytest.approx(-0.6, abs=1e-9)}
    assert rec["back_at"] == pytest.approx(5.5)  # the earliest sample back (module doc)
    # nulling 1.6 m needs ≥ 2.07 s (5 steps, + 1): a waypoint at least 6 steps after 4.5 s
    assert e.detail["lengthened"]["needed_steps"] == 6
    assert e.segment[1] - e.segment[0] >= 3.0 - 1e-9


def test_the_recovery_never_goes_deeper_and_rejoins_the_hover(pushed):
    _, res = pushed
    x, y = res.executed["p.pos.x"], res.executed["p.pos.y"]
    t = res.times
    clearance = np.hypot(x, y) - 1.0 - 1.0  # independent of the monitor: radial distance
    assert clearance.min() == pytest.approx(-0.6, abs=1e-9)  # the push's depth, no deeper
    assert res.executed_robustness["clearance"] == pytest.approx(-0.6, abs=1e-9)
    back = t >= 5.5 - 1e-9
    assert np.all(clearance[back] >= 0.05 - 1e-6)  # back to κ at 5.5 s and kept after
    assert x[-1] == pytest.approx(-3.0, abs=1e-5) and y[-1] == pytest.approx(0.0, abs=1e-6)


def test_simulate_says_so(pushed, capsys, tmp_path):
    path, _ = pushed
    code = cli.main(["simulate", str(path), "-o", str(tmp_path / "out")])
    out, err = capsys.readouterr()
    assert code == 3  # the push broke the kept spec: the executed trajectory is reported
    assert "recovery: p started the replan at 4.5 s inside the violation set of " \
           "`clearance` (-0.600)" in out and "back to κ at 5.5 s" in out
    assert "error[STL501]: `clearance` does not hold on the executed trajectory" in err
    events = json.loads((tmp_path / "out" / "replan.json").read_text())["events"]
    (trig,) = [ev for ev in events if ev["triggered"]]
    assert trig["accepted"] and trig["detail"]["recovery"]["back_at"] == 5.5


@pytest.mark.parametrize("x, v, a, want", [
    (1.0, 0.0, 1.0, 2.0),  # rest to rest: 2·√(x/a)
    (0.0, 2.0, 1.0, 2.0 + 2.0 * math.sqrt(2.0)),  # moving away: stop (2 s), come back
    (-2.0, 2.0, 1.0, 2.0),  # on the switching curve: brake all the way, |v|/a
    (-1.0, 0.0, 2.0, 2.0 * math.sqrt(0.5)),
])
def test_min_time_of_the_double_integrator(x, v, a, want):
    assert explain.min_time(x, v, a) == pytest.approx(want)


def test_min_time_against_a_brute_force_bang_bang_search():
    """Every one-switch profile (−a then +a or the mirror, switch time on a fine grid) that
    ends at rest at 0 takes at least ``min_time``, and the best one takes it."""
    rng = np.random.default_rng(3)
    t1 = np.linspace(0, 10, 200001)
    for _ in range(30):
        x, v, a = rng.uniform(-3, 3), rng.uniform(-2, 2), rng.uniform(0.5, 3)
        best = math.inf
        for u in (-a, a):
            v1, x1 = v + u * t1, x + v * t1 + u * t1 ** 2 / 2
            t2 = v1 / u  # the second arc (−u) brings the speed to 0
            xe = x1 + v1 * t2 - u * t2 ** 2 / 2  # where it comes to rest
            ok = t2 >= 0
            cross = np.flatnonzero(ok[:-1] & ok[1:] & (np.sign(xe[:-1]) != np.sign(xe[1:])))
            for i in cross:  # the switch time where it comes to rest at 0, interpolated
                f = xe[i] / (xe[i] - xe[i + 1])
                s1 = t1[i] + f * (t1[i + 1] - t1[i])
                best = min(best, s1 + (v + u * s1) / u)
        assert best == pytest.approx(explain.min_time(x, v, a), abs=1e-3)


def test_fly_recovers_on_the_replanned_reference(pushed, tmp_path):
    """``stlc fly`` replans through the same events: flight.json lists the recovery."""
    path, _ = pushed
    code = cli.main(["fly", str(path), "-o", str(tmp_path / "out"), "-q"])
    assert code == 3  # the push itself broke the clearance
    rec = json.loads((tmp_path / "out" / "flight.json").read_text())["replan"]
    assert rec["replans"] == rec["accepted"] == 1
    (r,) = rec["recoveries"]
    assert r["accepted"] and r["back_at"] == 5.5 and r["vehicle"] == "p"


def test_a_kick_past_vel_max_is_replanned_back_inside_the_bound(pushed):
    """A velocity kick of 3 m/s in y (vel_max 2 m/s) at 4 s: the start is outside the
    state bounds, so the segment's bound on vel.y is widened by what the vehicle cannot
    have shed at 1.5 m/s² — node j allows 3 − 1.5·j·0.5 — and the replan is flown; the
    flown speed never exceeds that envelope and is back under 2 m/s after 2 steps."""
    path, _ = pushed
    m, problem, plan = _hover(path)
    kick = model.Disturbance("p", 4.0, (0.0, 0.0, 0.0), (0.0, 3.0, 0.0))
    res = disturb.simulate_disturbances(problem, plan, [kick], m.replan,
                                        segment=SegmentBackend)
    (e,) = res.triggered
    assert e.accepted and e.detail["outside_bounds"] == {"p.vel.y": pytest.approx(1.0)}
    vy = res.executed["p.vel.y"]
    s = int(round(e.segment[0] / 0.5))
    assert vy[s] == pytest.approx(3.0)  # flown open loop until the replan starts
    for j in range(1, 8):
        assert abs(vy[s + j]) <= max(2.0, 3.0 - 1.5 * 0.5 * j) + 1e-6
    assert np.all(np.abs(vy[s + 2:]) <= 2.0 + 1e-6)
    assert res.executed["p.pos.y"][-1] == pytest.approx(0.0, abs=1e-5)  # back on the plan
