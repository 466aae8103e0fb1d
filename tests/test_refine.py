"""Team refinement (paper B): v* formula, waypoint maps, separation, dwells, bounds, CSV.

Oracles are independent of ``stlc.team.refine``: hand arithmetic for v*, closed-form cubics
for the Hermite maps, and brute-force numpy over every dense sample for the exact
robustness of the separation, obstacle and dwell requirements (min over samples of the
predicate margins, i.e. the STL robustness of □(…) for those predicates).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from refine_cases import cube, head_on, straight_seed

from stlc.team import Box, Drone, TeamScenario
from stlc.team.energy import (
    feasible_forward_speed,
    forward_cost,
    forward_speed,
    optimal_forward_speed,
)
from stlc.team.refine import per_drone_csv, refine
from stlc.team.waypoints import hermite_map, knot_times

# ------------------------------------------------------------------ energy, eq. (8)-(10)


def test_v_star_matches_hand_computation():
    # m = 1.5, n_r = 4, A = 0.05, f = 0.02, κ = 1.15, ρ = 1.225:
    #   sqrt(1.5 / (2·1.225·0.05)) = sqrt(1.5 / 0.1225) = sqrt(12.244898) = 3.499271
    #   (4·1.15·0.05 / (4·0.02))^(1/4) = (0.23 / 0.08)^(1/4) = 2.875^(1/4)
    #                                  = sqrt(1.695583) = 1.302145
    #   v* = 3.499271 · 1.302145 = 4.556560
    v = optimal_forward_speed(1.5, 4, 0.05, 0.02, 1.15, 1.225)
    assert v == pytest.approx(4.556560, abs=2e-6)


def test_v_star_clamped_to_feasible_forward_speed():
    assert feasible_forward_speed(4.556576, (3.1, 3.1, 3.1)) == pytest.approx(4.384062, abs=1e-6)
    assert feasible_forward_speed(2.5, (3.1, 3.1, 3.1)) == 2.5


def test_v_star_rejects_nonpositive_inputs():
    with pytest.raises(ValueError, match="disk_area"):
        optimal_forward_speed(1.5, 4, 0.0, 0.02, 1.15)


def test_forward_cost_by_hand():
    vel = np.array([[3.0, 4.0, 9.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    assert forward_speed(vel).tolist() == [5.0, 0.0, 1.0]
    # samples 0 and 2 in transit, v* = 2: (1 − 5/2)² + (1 − 1/2)² = 2.25 + 0.25
    assert forward_cost(vel, np.array([True, False, True]), 2.0) == pytest.approx(2.5)


# ------------------------------------------------------------------ waypoint maps


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-5, 5), min_size=4, max_size=4), st.floats(0.3, 2.0))
def test_hermite_map_reproduces_cubics(coef, h):
    c0, c1, c2, c3 = coef
    knots = np.arange(6) * h
    p = c0 + c1 * knots + c2 * knots**2 + c3 * knots**3
    v = c1 + 2 * c2 * knots + 3 * c3 * knots**2
    t = np.linspace(0, knots[-1], 37)
    z = np.concatenate([p, v])
    exact = (c0 + c1 * t + c2 * t**2 + c3 * t**3, c1 + 2 * c2 * t + 3 * c3 * t**2,
             2 * c2 + 6 * c3 * t)
    for order in (0, 1, 2):
        assert np.allclose(hermite_map(knots, t, order) @ z, exact[order], atol=1e-8)


def test_knot_times_end_on_horizon():
    k = knot_times(155.0, 1.0)
    assert len(k) == 156 and k[-1] == 155.0
    k = knot_times(10.0, 3.0)
    assert len(k) == 5 and k[1] == pytest.approx(2.5)


# ------------------------------------------------------------------ brute-force oracles


def _min_distance(plan, a, b):
    return float(np.min(np.linalg.norm(plan.pos[a] - plan.pos[b], axis=1)))


def _inside_margin(p, box):
    return float(np.min(np.minimum(p - np.array(box.lo), np.array(box.hi) - p)))


def _outside_margin(p, box):
    return float(np.min(np.max(np.hstack([p - np.array(box.hi), np.array(box.lo) - p]), 1)))


def _assert_bounds(sc, plan):
    for d in sc.drones:
        assert np.all(np.abs(plan.vel[d.name]) <= np.array(d.vel_max) + 1e-6)
        assert np.all(np.abs(plan.acc[d.name]) <= np.array(d.acc_max) + 1e-6)
        # the samples are a consistent trajectory: velocity integrates to position
        dp = np.diff(plan.pos[d.name], axis=0)
        mid = 0.5 * (plan.vel[d.name][1:] + plan.vel[d.name][:-1]) * sc.step
        assert np.allclose(dp, mid, atol=2e-3)


def _assert_dwells(sc, seed, plan):
    boxes = {b.name: b for b in (*sc.targets, *sc.stations)}
    need = {"install": sc.install_time, "refill": sc.refill_time, "home": 0.0}
    key = [(v.drone, v.kind, v.region) for v in seed.visits]
    assert sorted(key) == sorted((v.drone, v.kind, v.region) for v in plan.visits)
    for d in plan.pos:  # order per drone kept
        assert ([v.region for v in seed.visits if v.drone == d]
                == [v.region for v in sorted(plan.visits, key=lambda v: v.start)
                    if v.drone == d])
    for v in plan.visits:
        assert v.end - v.start >= need[v.kind] - 1e-9
        sel = (plan.times >= v.start - 1e-9) & (plan.times <= v.end + 1e-9)
        assert _inside_margin(plan.pos[v.drone][sel], boxes[v.region]) >= 0.2
    for d in sc.drones:
        assert np.allclose(plan.pos[d.name][0], d.start)
    assert seed.times.shape == plan.times.shape


# ------------------------------------------------------------------ refinement


@pytest.fixture(scope="module")
def head_on_result():
    sc, routes = head_on()
    seed = straight_seed(sc, routes)
    plan, stats = refine(sc, seed, kappa=0.2)
    return sc, seed, plan, stats


def test_head_on_seed_collides_and_refined_plan_separates(head_on_result):
    sc, seed, plan, stats = head_on_result
    assert _min_distance(seed, "a", "b") < 0.5  # the straight seeds meet at the origin
    assert _min_distance(plan, "a", "b") >= sc.separation + 0.2
    assert stats["status"] == "Solve_Succeeded"
    _assert_bounds(sc, plan)
    _assert_dwells(sc, seed, plan)


def _team_case():
    """2 drones, 3 targets, 1 station (a landing pad big enough for both), a tower between
    the drones' starts and their targets, 50 s."""
    drones = (Drone("a", (-8.0, -6.0, 0.5), (3.1,) * 3, (3.1,) * 3, 2),
              Drone("b", (8.0, -6.0, 0.5), (3.1,) * 3, (3.1,) * 3, 2))
    sc = TeamScenario(
        drones, targets=(cube("t1", (-4, 4, 8), 1.0), cube("t2", (4, 4, 8), 1.0),
                         cube("t3", (0, 7, 6), 1.0)),
        stations=(Box("pad", (-4.0, -9.0, 0.0), (4.0, -5.0, 2.0)),),
        obstacles=(Box("tower", (-1.0, -1.0, 0.0), (1.0, 1.0, 12.0)),),
        workspace=Box("ws", (-12, -10, 0), (12, 10, 12)), install_time=5.0,
        refill_time=8.0, horizon=50.0, step=0.05, separation=3.0)
    # a crosses to the right-hand target and b to the left-hand one (paths cross at the
    # tower); both come home to the same pad
    routes = {"a": [("install", "t2"), ("install", "t3"), ("home", "pad")],
              "b": [("install", "t1"), ("home", "pad")]}
    return sc, straight_seed(sc, routes)


def test_reduced_team_case_robustness_positive():
    sc, seed = _team_case()
    assert _outside_margin(seed.pos["a"], sc.obstacles[0]) < 0  # seed flies through it
    plan, stats = refine(sc, seed, kappa=0.2)
    rho = min(_min_distance(plan, "a", "b") - sc.separation,
              *(_outside_margin(plan.pos[d], sc.obstacles[0]) for d in ("a", "b")),
              *(_inside_margin(plan.pos[d], sc.workspace) for d in ("a", "b")))
    assert rho > 0.2
    _assert_dwells(sc, seed, plan)
    _assert_bounds(sc, plan)
    assert stats["variables"] == 6 * 2 * 51 + 1


def test_energy_term_moves_forward_speed_towards_v_star(head_on_result):
    sc, seed, plan, _ = head_on_result
    fast, stats = refine(sc, seed, kappa=0.2, eta=1.0, v_star=2.5)
    assert stats["forward_cost"] < refine(sc, seed, kappa=0.2, v_star=2.5)[1]["forward_cost"]
    assert _min_distance(fast, "a", "b") >= sc.separation + 0.2
    _assert_bounds(sc, fast)
    with pytest.raises(ValueError, match="v_star"):
        refine(sc, seed, eta=1.0)


def test_per_drone_csv_columns_and_heading(head_on_result):
    _, _, plan, _ = head_on_result
    csv = per_drone_csv(plan)
    assert set(csv) == {"a", "b"}
    lines = csv["a"].strip().split("\n")
    assert lines[0] == "t,x,y,z,vx,vy,vz,ax,ay,az,heading"
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    assert rows.shape == (len(plan.times), 11)
    assert np.allclose(rows[:, 1:4], plan.pos["a"], atol=1e-4)
    moving = np.hypot(rows[:, 4], rows[:, 5]) > 0.05
    assert np.allclose(rows[moving, 10], np.arctan2(plan.vel["a"][moving, 1],
                                                    plan.vel["a"][moving, 0]), atol=1e-4)
    k = np.flatnonzero(moving)[-1] + 1  # first hovering sample after the last motion
    if k < len(rows):
        assert rows[k, 10] == rows[k - 1, 10]
    assert np.all(np.isfinite(rows[:, 10]))
