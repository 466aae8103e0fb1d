"""The MILP seed's inner boxes of speed limits (``stlc.backends.milp.seed_inner``): a path that
keeps the box keeps the limit (checked by the exact monitor on random traces), the box is
the largest axis-aligned one (its corner lies on the sphere), predicates that are not an
upper bound on a norm are left as they are, and the handover's seed path keeps its slow
phase under the comfort speed limit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc import pipeline
from stlc.analysis import monitor
from stlc.backends.milp import seed as milp_seed
from stlc.backends.milp.seed_inner import inner_norms
from stlc.planning.problem import from_mission
from stlc.semantics import ir

LIMITS = """\
vehicle p : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-6, -6, 0), (6, 6, 2)) m
  target goal = box((3, -1, 0.5), (5, 1, 1.5)) m
}
mission slow {
  vehicles = [p]
  horizon = 8 s
  step = 0.25 s
  threshold = 0.05
  spec limit = always[0, 8] (p.speed <= 1.2 m/s)
  spec fast = always[0, 8] (p.speed >= 0.1 m/s)
  spec reach = eventually[4, 8] (p.pos in goal)
  require limit and fast and reach
  maximize robustness
}
"""


@pytest.fixture(scope="module")
def slow(tmp_path_factory):
    f = tmp_path_factory.mktemp("inner") / "slow.stl"
    f.write_text(LIMITS, encoding="utf-8")
    program = pipeline.load(str(f)).program
    return from_mission(program, program.missions["slow"])


def _spec(problem, name):
    return problem.specs[name].normal


def _channels(V: np.ndarray) -> dict[str, np.ndarray]:
    ch = {f"p.vel.{a}": V[i] for i, a in enumerate("xyz")}
    ch.update({f"p.pos.{a}": np.zeros(V.shape[1]) for a in "xyz"})
    ch["p.speed"] = np.linalg.norm(V, axis=0)
    return ch


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-1, 1)] * 3), min_size=33, max_size=33),
       st.floats(0.5, 1.3))
def test_a_trace_inside_the_box_keeps_the_speed_limit(slow, vs, scale):
    V = np.asarray(vs, float).T * scale * 1.2 / math.sqrt(3)  # inside the box iff scale ≤ 1
    limit = _spec(slow, "limit")
    inner = inner_norms(limit, slow.params)
    assert inner != limit  # the limit was replaced
    r_in = monitor.robustness(inner, slow.grid.dt, _channels(V), slow.params)
    r = monitor.robustness(limit, slow.grid.dt, _channels(V), slow.params)
    inside = np.max(np.abs(V)) <= 1.2 / math.sqrt(3)
    assert r_in >= -1e-12 if inside else r_in <= 1e-12
    if r_in >= 0:  # inside the box at every sample ⇒ under the limit at every sample
        assert r >= -1e-12
        assert r_in <= r + 1e-12  # and with no more margin than the ball gives


def test_the_box_corner_lies_on_the_sphere(slow):
    inner = inner_norms(_spec(slow, "limit"), slow.params)
    c = 1.2 / math.sqrt(3)  # by hand: the half-side of the cube inside the ball of 1.2
    V = np.tile([[c], [c], [-c]], 33)
    assert monitor.robustness(inner, slow.grid.dt, _channels(V), slow.params) == \
        pytest.approx(0.0, abs=1e-12)
    assert monitor.robustness(_spec(slow, "limit"), slow.grid.dt, _channels(V),
                              slow.params) == pytest.approx(0.0, abs=1e-12)


def test_other_predicates_are_left_as_they_are(slow):
    for name in ("fast", "reach"):  # a lower bound on a norm (not convex); a box
        f = _spec(slow, name)
        assert inner_norms(f, slow.params) == f
    # a bound that reads a signal is not a constant radius
    v = ir.Sig("p.vel.x")
    e = ir.Bin("-", ir.Sig("p.pos.x"), ir.Call("sqrt", (ir.Bin("*", v, v),)))
    p = ir.Pred(e, "pos.x >= |vel.x|")
    assert inner_norms(p, {}) == p


def test_the_seed_path_keeps_the_speed_limit(slow):
    paths, rec = milp_seed.plan(slow)
    assert rec["status"] == "Optimal"
    _, V, _ = paths["p"]
    assert np.max(np.linalg.norm(V, axis=0)) <= 1.2 + 1e-6


def test_the_handover_seed_keeps_the_comfort_speed_limit():
    program = pipeline.load("specs/handover.stl").program
    problem = from_mission(program, program.missions["handover_left_tb"])
    paths, rec = milp_seed.plan(problem)
    _, V, _ = paths["uav1"]
    t = problem.grid.times()
    slow_phase = (t >= 10.0 - 1e-9) & (t <= 17.0 + 1e-9)  # comfort: always[10, 17]
    assert np.max(np.linalg.norm(V[:, slow_phase], axis=0)) <= 0.4 + 1e-6
