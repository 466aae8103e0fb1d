"""The payload rule (stlc.team.payload) on hand-made trajectories, one per corner case.

Grid step 0.5 s, T_ins = 1 s (n_ins = 2: 3 samples inside), T_rs = 1.5 s (n_rs = 3: 4
samples).  A trajectory is a string, one letter per sample: A, B targets, S station,
o outside.  Expected payloads are written out by hand from the rule in the docstring.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.team import Box, Drone, TeamScenario
from stlc.team.payload import payload_signal, payload_team, uninstalled

A = Box("A", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
B = Box("B", (10.0, 0.0, 0.0), (11.0, 1.0, 1.0))
S = Box("S", (20.0, 0.0, 0.0), (21.0, 1.0, 1.0))
WHERE = {"A": (0.5, 0.5, 0.5), "B": (10.5, 0.5, 0.5), "S": (20.5, 0.5, 0.5),
         "o": (5.0, 5.0, 5.0)}
STEP = 0.5


def scenario(*caps: int) -> TeamScenario:
    drones = tuple(Drone(f"d{i}", (5.0, 5.0, 5.0), (1.0,) * 3, (1.0,) * 3, c)
                   for i, c in enumerate(caps))
    return TeamScenario(drones, (A, B), (S,), (), Box("ws", (-50.0,) * 3, (50.0,) * 3),
                        install_time=1.0, refill_time=1.5, horizon=100.0, step=STEP,
                        separation=0.0)


def traj(s: str) -> tuple[np.ndarray, np.ndarray]:
    return np.arange(len(s)) * STEP, np.array([WHERE[c] for c in s], dtype=float)


def one(s: str, cap: int):
    t, p = traj(s)
    sc = scenario(cap)
    pay, ev = payload_signal(t, p, sc.drones[0], sc)
    return pay.tolist(), [(e.kind, e.region, e.start, e.end) for e in ev]


def test_install_after_n_plus_one_samples():
    assert one("ooAAAoo", 2) == ([2, 2, 2, 2, 2, 1, 1], [("install", "A", 1.0, 2.0)])
    assert one("ooAAoo", 2) == ([2] * 6, [])  # only n samples: duration 0.5 s < 1 s


def test_second_visit_to_installed_target_does_nothing():
    pay, ev = one("AAAooAAAo", 2)
    assert pay == [2, 2, 2, 1, 1, 1, 1, 1, 1]
    assert ev == [("install", "A", 0.0, 1.0)]


def test_dwelling_twice_as_long_installs_once():
    # the payload on board stays constant for the whole stay; it drops when the stay ends
    assert one("AAAAAAo", 3) == ([3, 3, 3, 3, 3, 3, 2], [("install", "A", 0.0, 2.5)])


def test_entering_empty_installs_nothing_and_leaves_target_open():
    t, p = traj("AAAoBBBBBB")
    sc = scenario(1)
    pay, ev = payload_signal(t, p, sc.drones[0], sc)
    assert pay.tolist() == [1, 1, 1, 0, 0, 0, 0, 0, 0, 0]
    assert [(e.kind, e.region) for e in ev] == [("install", "A")]
    assert uninstalled(ev, sc) == ["B"]


def test_two_drones_in_one_target_first_to_complete_installs():
    sc = scenario(2, 2)
    t, p0 = traj("oAAAAo")
    _, p1 = traj("AAAAoo")
    pay, ev = payload_team(t, {"d0": p0, "d1": p1}, sc)
    assert [(e.drone, e.region, e.start, e.end) for e in ev] == [("d1", "A", 0.0, 1.5)]
    assert pay["d0"].tolist() == [2] * 6
    assert pay["d1"].tolist() == [2, 2, 2, 2, 1, 1]


def test_two_drones_completing_together_first_listed_installs():
    sc = scenario(2, 2)
    t, p = traj("AAAo")
    pay, ev = payload_team(t, {"d1": p, "d0": p.copy()}, sc)
    assert [(e.drone, e.region) for e in ev] == [("d0", "A")]
    assert pay["d0"].tolist() == [2, 2, 2, 1] and pay["d1"].tolist() == [2, 2, 2, 2]


def test_dwell_straddling_the_horizon():
    assert one("ooooAA", 2) == ([2] * 6, [])  # would complete at sample 6 > N = 5
    # completes exactly at N: listed, the payload change falls after the plan
    assert one("oooAAA", 2) == ([2] * 6, [("install", "A", 1.5, 2.5)])


def test_leaving_and_reentering_restarts_the_count():
    assert one("AAoAAoAAo", 2) == ([2] * 9, [])


def test_refill_after_refilling_time_in_station_only():
    pay, ev = one("AAAoSSSSo", 1)
    assert pay == [1, 1, 1, 0, 0, 0, 0, 0, 1]
    assert ev == [("install", "A", 0.0, 1.0), ("refill", "S", 2.0, 3.5)]
    assert one("AAAoSSSo", 1)[0] == [1, 1, 1, 0, 0, 0, 0, 0]  # 3 samples: too short
    assert one("SSSSSSSS", 2) == ([2] * 8, [])  # full: nothing to refill


def test_back_to_back_targets_are_two_installs():
    assert one("AAABBBo", 2) == ([2, 2, 2, 1, 1, 1, 0],
                                 [("install", "A", 0.0, 1.0), ("install", "B", 1.5, 2.5)])


def test_inside_is_the_closed_box():
    t = np.arange(4) * STEP
    sc = scenario(1)
    on_face = np.array([[1.0, 0.0, 0.5]] * 3 + [[5.0, 5.0, 5.0]])
    assert payload_signal(t, on_face, sc.drones[0], sc)[0].tolist() == [1, 1, 1, 0]
    just_out = on_face.copy()
    just_out[1, 0] = 1.0 + 1e-12
    assert payload_signal(t, just_out, sc.drones[0], sc)[0].tolist() == [1, 1, 1, 1]


def test_grid_must_be_uniform_at_the_mission_step():
    sc = scenario(1)
    with pytest.raises(ValueError):
        payload_signal(np.array([0.0, 0.5, 1.2]), np.zeros((3, 3)), sc.drones[0], sc)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.text(alphabet="ABSo", min_size=12, max_size=40), min_size=2, max_size=2),
       st.lists(st.integers(0, 3), min_size=2, max_size=2))
def test_payload_properties(paths, caps):
    n = min(len(s) for s in paths)
    sc = scenario(*caps)
    t = np.arange(n) * STEP
    pos = {f"d{i}": traj(s[:n])[1] for i, s in enumerate(paths)}
    pay, ev = payload_team(t, pos, sc)
    for i, c in enumerate(caps):
        d = f"d{i}"
        assert pay[d][0] == c and (pay[d] >= 0).all() and (pay[d] <= c).all()
        mine = [e for e in ev if e.drone == d]
        # the payload changes exactly at the sample after each of the drone's events
        changes = [k for k in range(1, n) if pay[d][k] != pay[d][k - 1]]
        assert changes == [round(e.end / STEP) + 1 for e in mine if round(e.end / STEP) + 1 < n]
        for e in mine:
            k0, k1 = round(e.start / STEP), round(e.end / STEP)
            need = 2 if e.kind == "install" else 3
            assert k1 - k0 >= need
            letter = e.region
            assert all(paths[i][k] == letter for k in range(k0, k1 + 1))
            # the event is at the end of the stay: the drone leaves, or the plan ends
            assert k1 == n - 1 or paths[i][k1 + 1] != letter
            if e.kind == "refill":
                assert letter == "S" and pay[d][k1] < c
                assert k1 + 1 >= n or pay[d][k1 + 1] == c
            else:
                assert pay[d][k1] > 0
                assert k1 + 1 >= n or pay[d][k1 + 1] == pay[d][k1] - 1
    installs = [e.region for e in ev if e.kind == "install"]
    assert len(installs) == len(set(installs))
