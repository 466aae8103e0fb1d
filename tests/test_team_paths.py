"""Obstacle-aware seed legs (stlc.team.paths) and the chord primitive.

Clearance is checked on the dense samples with an independent box distance (the largest
outward face distance, which is ≤ the Euclidean distance to the box); bounds against the
per-axis limits; the chord primitive's minimum time against hand-computed trapezoids.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from stlc.team import Box, Drone, TeamScenario
from stlc.team.paths import MARGIN, Router, leg_steps
from stlc.team.primitives import min_duration, rest_to_rest
from stlc.team.seed import seed_plan

V, A = (3.0, 3.0, 3.0), (2.0, 2.0, 2.0)
WALL = Box("wall", (-1.0, -3.0, 0.0), (1.0, 3.0, 15.0))  # reaches the workspace top
WS = Box("ws", (-20.0, -10.0, 0.0), (20.0, 10.0, 15.0))


def face_margin(p: np.ndarray, box: Box) -> np.ndarray:
    lo, hi = np.array(box.lo), np.array(box.hi)
    return np.max(np.concatenate([p - hi, lo - p], axis=1), axis=1)


def scenario(drones, targets, stations, obstacles=(WALL,)):
    return TeamScenario(tuple(drones), tuple(targets), tuple(stations), tuple(obstacles), WS,
                        1.0, 2.0, 120.0, 0.05, 3.0)


def test_chord_primitive_time_by_hand():
    # Δ = (4, 4, 0), v̄ = (1, 2), ā = (1, 0.5): chord bounds v_s = 1/4, a_s = 0.5/4;
    # trapezoid for distance 1: 1/v_s + v_s/a_s = 4 + 2 = 6 s; synchronised: max(x: 4 + 1,
    # y: triangle 2·sqrt(4/0.5)) = 5.657 s
    v, a = (1.0, 2.0, 1.0), (1.0, 0.5, 1.0)
    assert min_duration((0, 0, 0), (4, 4, 0), v, a, straight=True) == pytest.approx(6.0)
    assert min_duration((0, 0, 0), (4, 4, 0), v, a) == pytest.approx(2 * math.sqrt(8))
    # isotropic bounds: the same time either way (one axis binds both bounds)
    assert min_duration((0, 0, 0), (10, 3, -2), V, A, straight=True) == pytest.approx(
        min_duration((0, 0, 0), (10, 3, -2), V, A))


def test_chord_primitive_stays_on_the_chord_within_bounds():
    p0, p1 = np.array([1.0, -2.0, 3.0]), np.array([9.0, 4.0, 0.0])
    prim = rest_to_rest(p0, p1, V, A, duration=9.0, straight=True)
    t = np.linspace(0.0, 9.0, 901)
    p, v, a = prim.sample(t)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    off = (p - p0) - np.outer((p - p0) @ u, u)
    assert np.max(np.abs(off)) < 1e-9
    assert np.all(np.abs(v) <= np.array(V) + 1e-9) and np.all(np.abs(a) <= np.array(A) + 1e-9)
    assert np.allclose(p[-1], p1) and np.allclose(v[-1], 0.0)


def test_clear_leg_is_direct_and_blocked_leg_detours():
    sc = scenario([], [], [])
    r = Router(sc)
    a, b = np.array([-8.0, 6.0, 5.0]), np.array([8.0, 6.0, 5.0])  # passes beside the wall
    assert len(r.path(a, b, V, A)) == 2
    a, b = np.array([-6.0, 0.0, 5.0]), np.array([6.0, 0.0, 5.0])  # through the wall
    path = r.path(a, b, V, A)
    assert len(path) > 2
    assert np.allclose(path[0], a) and np.allclose(path[-1], b)
    # the wall spans the free height: the detour passes beside it, |y| ≥ 3 + margin
    assert max(abs(q[1]) for q in path[1:-1]) >= 3.0 + MARGIN
    steps = leg_steps(path, V, A, 0.05)
    direct = min_duration(a, b, V, A)
    assert sum(steps) * 0.05 > direct  # a detour costs time


def test_seed_through_a_wall_keeps_clear_and_within_bounds():
    """A drone whose target is behind a wall: the seed detours, every dense sample is at
    least the margin outside the wall, velocity and acceleration bounds hold."""
    t = Box("t", (5.5, -0.5, 4.5), (6.5, 0.5, 5.5))
    s = Box("s", (-7.0, -1.0, 0.0), (-5.0, 1.0, 2.0))
    dr = Drone("u", (-6.0, 0.0, 0.5), V, A, 1)
    sc = scenario([dr], [t], [s])
    plan = seed_plan(sc, {"u": ["t", "s"]})
    m = face_margin(plan.pos["u"], WALL)
    assert m.min() >= MARGIN - 1e-9
    assert np.all(np.abs(plan.vel["u"]) <= np.array(V) + 1e-9)
    assert np.all(np.abs(plan.acc["u"]) <= np.array(A) + 1e-9)
    # it does reach the target and dwells there
    inside = np.all((plan.pos["u"] >= t.lo) & (plan.pos["u"] <= t.hi), axis=1)
    assert inside.sum() * sc.step >= sc.install_time


def test_no_obstacles_means_no_change():
    sc = scenario([], [], [], obstacles=())
    r = Router(sc)
    assert len(r.path((-6.0, 0.0, 5.0), (6.0, 0.0, 5.0), V, A)) == 2
