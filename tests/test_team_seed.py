"""Seed trajectories: a reduced bird-diverter mission installs every target (checked by the
payload rule from the positions alone) within the per-axis bounds; the program adapter."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from stlc.pipeline import load
from stlc.team import ScenarioError, TeamError, centre, inside
from stlc.team.milp import assign, route_time
from stlc.team.payload import payload_team, uninstalled
from stlc.team.seed import _mission_time, scenario_from_program, seed_plan

SPECS = Path(__file__).resolve().parent.parent / "specs"


@pytest.fixture(scope="module")
def full():
    program = load(str(SPECS / "bird_diverter_2x7.stl")).program
    mission = program.missions["bird_diverter_2x7"]
    return scenario_from_program(program, mission, install_time=5.0, refill_time=12.0,
                                 separation=3.0)


def test_adapter_reads_the_mission(full):
    assert [d.name for d in full.drones] == ["uav1", "uav2"]
    assert [d.capacity for d in full.drones] == [2, 3]
    assert full.drones[0].start == (-10.0, -3.0, 0.5)
    assert full.drones[1].vel_max == (3.1, 3.1, 3.1)
    assert len(full.targets) == 7 and len(full.stations) == 4 and len(full.obstacles) == 4
    assert full.targets[0].lo == (-15.5, -3.0, 13.0) and full.targets[0].hi == (-14.5, -2.0, 14.0)
    assert full.workspace.lo == (-25.0, -10.0, 0.0)
    assert (full.install_time, full.refill_time) == (5.0, 12.0)
    assert (full.horizon, full.step, full.separation) == (155.0, 0.05, 3.0)


def test_adapter_install_time_sources():
    # the mission's field wins; the keyword is the fallback; neither is an error
    assert _mission_time(SimpleNamespace(name="m", install_time=4.0), "install_time", 5.0) == 4.0
    assert _mission_time(SimpleNamespace(name="m", install_time=None), "install_time", 5.0) == 5.0
    assert _mission_time(SimpleNamespace(name="m"), "refill_time", 12.0) == 12.0
    with pytest.raises(ScenarioError) as err:
        _mission_time(SimpleNamespace(name="m"), "install_time", None)
    assert "installation time" in err.value.message and err.value.subject == "m"
    with pytest.raises(ScenarioError):
        _mission_time(SimpleNamespace(name="m"), "refill_time", 0.0)


def test_adapter_needs_point_masses():
    hand = load(str(SPECS / "handover.stl")).program
    with pytest.raises(ScenarioError) as err:
        scenario_from_program(hand, next(iter(hand.missions.values())), install_time=1.0,
                              refill_time=1.0)
    assert err.value.reason == "scenario" and "point-mass" in err.value.message


def test_reduced_mission_seed_installs_every_target(full):
    sc = dataclasses.replace(full, targets=full.targets[:3], stations=full.stations[:1])
    routes, stats = assign(sc)
    plan = seed_plan(sc, routes)
    n = round(sc.horizon / sc.step) + 1
    assert plan.times.shape == (n,) and plan.times[-1] == pytest.approx(sc.horizon)
    payload, events = payload_team(plan.times, plan.pos, sc)
    assert uninstalled(events, sc) == []
    station = sc.stations[0]
    for d, dr in enumerate(sc.drones):
        pos, vel, acc = plan.pos[dr.name], plan.vel[dr.name], plan.acc[dr.name]
        assert pos.shape == vel.shape == acc.shape == (n, 3)
        np.testing.assert_allclose(pos[0], dr.start)
        assert (np.abs(vel) <= np.asarray(dr.vel_max) + 1e-9).all()
        assert (np.abs(acc) <= np.asarray(dr.acc_max) + 1e-9).all()
        # sampled motion is consistent with the sampled velocity (no jumps)
        dp = np.abs(np.diff(pos, axis=0))
        assert (dp <= np.asarray(dr.vel_max) * sc.step + 1e-9).all()
        assert inside(pos[-1], station) and (payload[dr.name] >= 0).all()
        home = [v for v in plan.visits if v.drone == dr.name and v.kind == "home"]
        assert len(home) == 1 and home[0].end == sc.horizon
        assert home[0].start == pytest.approx(route_time(sc, d, routes[dr.name]))
        np.testing.assert_allclose(pos[-1], centre(station))
    for v in plan.visits:
        if v.kind == "install":
            ev = [e for e in events if e.region == v.region]
            assert len(ev) == 1 and ev[0].drone == v.drone
            assert v.end - v.start >= sc.install_time
            # the counting stay contains the planned dwell (it also holds the samples
            # inside the box while arriving and leaving)
            assert ev[0].start <= v.start + 1e-9 and ev[0].end >= v.end - 1e-9


def test_seed_with_refill_keeps_payload_rule(full):
    sc = dataclasses.replace(full, drones=full.drones[:1], targets=full.targets[:3],
                             stations=full.stations[:1])
    route = {"uav1": ["tr1", "tr2", "rs_a", "tr3", "rs_a"]}
    plan = seed_plan(sc, route)
    payload, events = payload_team(plan.times, plan.pos, sc)
    # capacity 2: empty after tr2, refilled at rs_a, and the home stay refills again (at
    # the horizon, where it ends: the payload change falls after the plan)
    assert [(e.kind, e.region) for e in events] == [
        ("install", "tr1"), ("install", "tr2"), ("refill", "rs_a"), ("install", "tr3"),
        ("refill", "rs_a")]
    assert payload["uav1"].min() == 0 and payload["uav1"][-1] == 1
    assert events[-1].end == pytest.approx(sc.horizon)
    for e in events:
        assert e.end - e.start >= (12.0 if e.kind == "refill" else 5.0) - 1e-9
    visits = [(v.kind, v.region) for v in plan.visits]
    assert visits == [("install", "tr1"), ("install", "tr2"), ("refill", "rs_a"),
                      ("install", "tr3"), ("home", "rs_a")]


def test_seed_errors(full):
    sc = dataclasses.replace(full, drones=full.drones[:1], horizon=20.0)
    with pytest.raises(TeamError) as err:
        seed_plan(sc, {"uav1": ["tr1", "tr2", "rs_a"]})
    assert err.value.reason == "horizon"
    with pytest.raises(TeamError) as err:
        seed_plan(full, {"uav1": ["nowhere"]})
    assert err.value.reason == "route"
