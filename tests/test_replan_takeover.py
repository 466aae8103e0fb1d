"""Backup-drone takeover (paper B §IV-C, ``stlc.replan.takeover``).

One small team mission (tests/missions/takeover_cross.stl: uav1 installs ta and ends in s1,
uav2 installs tb and hovers in s2 from about 15 s to the end, the backup uav3 waits at
(10, 0, 1) so that its straight path to ta crosses s2) planned once; the expected values are
computed here from the positions, boxes and dwell times, not taken from the takeover code.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from stlc import pipeline
from stlc.backends.replan.takeover import TakeoverBackend
from stlc.replan import takeover
from stlc.replan.takeover import TakeoverError, retire
from stlc.semantics import model


def simulate_failure(*args, **kw):
    """The takeover with the backup planner the pipeline gives it."""
    return takeover.simulate_failure(*args, planner=TakeoverBackend(), **kw)


MISSION = "tests/missions/takeover_cross.stl"
T_INS, GAMMA, T_N = 2.0, 2.0, 45.0


@pytest.fixture(scope="module")
def planned():
    program = pipeline.load(MISSION).program
    problem, sol = pipeline.plan(program, program.missions["cross"])
    assert sol.routes["uav1"][0] == "ta"  # the scenario the cases below are built on
    return program, problem, sol


def _pos(ch, d):
    return np.stack([np.asarray(ch[f"{d}.pos.{a}"]) for a in "xyz"], axis=1)


def _box(program, name):
    b = program.scenario.region(name).box
    return np.asarray(b.lo, float), np.asarray(b.hi, float)


def _inside(p, box):
    lo, hi = box
    return np.all((p >= lo) & (p <= hi), axis=1)


def _first_stay(flags):
    """(first, last) sample of the first run of True."""
    k0 = int(np.argmax(flags))
    k1 = k0
    while k1 + 1 < len(flags) and flags[k1 + 1]:
        k1 += 1
    return k0, k1


def test_pending_targets_by_hand(planned):
    program, problem, sol = planned
    dt = problem.grid.dt
    k_in, k_out = _first_stay(_inside(_pos(sol.channels, "uav1"), _box(program, "ta")))
    t_in = k_in * dt
    assert (k_out - k_in) * dt >= T_INS  # the plan's own stay counts
    start = program.vehicles["uav3"].start_pos
    # the stay counts when it has lasted T_ins (n_ins + 1 samples) by the failure sample
    cases = {t_in - 1.0: ["ta"],               # in transit to ta
             t_in + 1.0: ["ta"],               # installing, half way
             t_in + T_INS - dt: ["ta"],        # one sample short of T_ins
             t_in + T_INS: []}                 # T_ins done: installed at t_fail
    for t_fail, expected in cases.items():
        t_fail = round(t_fail / dt) * dt
        out = retire(problem, sol, model.Failure("uav1", t_fail, "uav3"), start)
        assert out["pending"] == expected, t_fail
        assert out["installed"] == (["ta"] if not expected else [])


def test_nothing_pending_is_no_replan(planned):
    program, problem, sol = planned
    res = simulate_failure(problem, sol, model.Failure("uav1", 30.0, "uav3"))
    (ev,) = res.events
    assert ev.kind == "failure" and not ev.triggered and ev.solve_s is None
    assert not any(k.startswith("uav3.") for k in res.executed)  # the backup was not sent
    assert res.executed_robustness["install"] >= 0  # uav1 had installed ta


def test_backup_installs_and_keeps_separation(planned):
    program, problem, sol = planned
    dt, t_fail, t_rep = problem.grid.dt, 2.0, 18.0
    k0 = round((t_fail + t_rep) / dt)
    uav2 = _pos(sol.channels, "uav2")
    start = np.asarray(program.vehicles["uav3"].start_pos, float)
    lo, hi = _box(program, "ta")
    # premise: uav2 hovers on [t0, T_N], and the straight path from the backup's start to
    # ta's centre passes within Γ_dis of it
    assert np.ptp(uav2[k0:], axis=0).max() < 1e-6
    line = start + np.linspace(0, 1, 401)[:, None] * ((lo + hi) / 2 - start)
    assert np.min(np.linalg.norm(line - uav2[k0], axis=1)) < GAMMA

    res = simulate_failure(problem, sol, model.Failure("uav1", t_fail, "uav3"),
                           model.ReplanConfig(takeover_delay=t_rep))
    (ev,) = res.events
    assert ev.triggered and ev.kind == "failure" and ev.vehicle == "uav1"
    assert ev.detail["pending"] == ["ta"]
    assert ev.status in ("optimal", "acceptable") and ev.accepted
    assert ev.detail["sep_rows"] > 0  # rows against the fixed uav2 were generated
    assert ev.segment == pytest.approx((t_fail + t_rep, T_N))
    ex = res.executed
    p3 = _pos(ex, "uav3")
    # waits at its start until t0, then installs ta: a stay of ≥ T_ins in the box
    assert np.allclose(p3[:k0 + 1], start)
    k_in, k_out = _first_stay(_inside(p3, (lo, hi)))
    assert k_in > k0 and (k_out - k_in) * dt >= T_INS
    assert res.executed_robustness["install"] >= 0
    # separation by hand over every pair of the executed team, and by the monitor
    pos = {d: _pos(ex, d) for d in ("uav1", "uav2", "uav3")}
    for a, b in (("uav1", "uav2"), ("uav1", "uav3"), ("uav2", "uav3")):
        assert np.min(np.linalg.norm(pos[a] - pos[b], axis=1)) >= GAMMA
    assert res.executed_robustness["separation"] >= 0
    # the failed drone is parked in its home station s1 after t_fail
    s_lo, s_hi = _box(program, "s1")
    k_f = round(t_fail / dt)
    assert np.allclose(pos["uav1"][k_f + 1:], (s_lo + s_hi) / 2)
    # the backup's bounds on the dense grid: channels and finite differences
    v = program.vehicles["uav3"]
    vel = np.stack([ex[f"uav3.vel.{a}"] for a in "xyz"], 1)
    acc = np.stack([ex[f"uav3.acc.{a}"] for a in "xyz"], 1)
    assert np.all(np.abs(vel) <= np.asarray(v.vel_max) + 1e-9)
    assert np.all(np.abs(acc) <= np.asarray(v.acc_max) + 1e-9)
    assert np.all(np.abs(np.diff(p3, axis=0)) / dt <= np.asarray(v.vel_max) + 1e-6)
    # replan.json / executed.csv contents
    doc = json.loads(res.to_json())
    assert doc["events"][0]["detail"]["pending"] == ["ta"]
    assert doc["executed"]["satisfied"]["install"] is True
    assert res.executed_csv().splitlines()[0].split(",")[0] == "t"
    # the replanned segment is reported on its own grid
    assert ev.times[0] == pytest.approx(t_fail + t_rep) and len(ev.channels["uav3.pos.x"]) \
        == len(ev.times)


def test_no_time_left_is_reported_not_accepted(planned):
    _, problem, sol = planned
    res = simulate_failure(problem, sol, model.Failure("uav1", 2.0, "uav3"),
                           model.ReplanConfig(takeover_delay=50.0))
    (ev,) = res.events
    assert ev.triggered and ev.status == "infeasible" and ev.accepted is False
    assert res.executed_robustness["install"] < 0  # nobody installs ta


@pytest.mark.parametrize("failure, culprit", [
    (model.Failure("uav9", 2.0, "uav3"), "uav9"),    # not in the mission
    (model.Failure("uav1", 2.0, "ghost"), "ghost"),  # backup not declared
    (model.Failure("uav1", 2.0, "uav2"), "uav2"),    # backup already in the team
    (model.Failure("uav1", 2.0, "scout"), "scout"),  # backup without capacity
    (model.Failure("uav1", T_N, "uav3"), "45"),      # t_fail outside [0, T_N)
    (model.Failure("uav1", -1.0, "uav3"), "-1"),
])
def test_bad_inputs_raise(planned, failure, culprit):
    _, problem, sol = planned
    with pytest.raises(ValueError, match=culprit) as info:
        simulate_failure(problem, sol, failure)
    assert isinstance(info.value, TakeoverError)
