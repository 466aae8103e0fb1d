"""A reduced team mission end to end (parse → MILP seed → refinement → verification →
outputs), checked against what the mission says, computed independently of the planner:
pairwise distances and bounds on the dense samples, installs from the payload rule."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from stlc.cli import main
from stlc.pipeline import load, plan
from stlc.team import inside
from stlc.team.payload import payload_team
from stlc.team.seed import scenario_from_program

MISSION = Path(__file__).parent / "missions" / "team_small.stl"


@pytest.fixture(scope="module")
def planned():
    program = load(str(MISSION)).program
    mission = program.missions["team_small"]
    problem, sol = plan(program, mission)
    return program, mission, problem, sol


def test_team_plan_satisfies_the_mission(planned):
    program, mission, problem, sol = planned
    assert sol.status == "satisfied"
    # no drone declares paper B's aerodynamic data: energy "not computed", never 0.0 J
    assert sol.energy != sol.energy and sol.energy_by_vehicle == {}
    assert sol.robustness_exact >= mission.threshold
    assert all(s.robustness >= mission.threshold for s in sol.specs.values())


def test_separation_and_bounds_on_the_dense_trajectory(planned):
    program, mission, problem, sol = planned
    t = np.asarray(sol.times)
    assert np.allclose(np.diff(t), mission.step)  # the mission's declared step
    pos = {d: np.stack([sol.channels[f"{d}.pos.{a}"] for a in "xyz"], 1) for d in sol.routes}
    dmin = np.min(np.linalg.norm(pos["uav1"] - pos["uav2"], axis=1))
    assert dmin >= 2.0 + mission.threshold - 1e-6  # Γ_dis = 2 m
    for d in sol.routes:
        v = program.vehicles[d]
        for f, lim in (("vel", v.vel_max), ("acc", v.acc_max)):
            arr = np.stack([sol.channels[f"{d}.{f}.{a}"] for a in "xyz"], 1)
            assert np.all(np.abs(arr) <= np.asarray(lim) + 1e-6), (d, f)
        # the velocities are the derivative of the positions (a flyable trajectory)
        vel = np.stack([sol.channels[f"{d}.vel.{a}"] for a in "xyz"], 1)
        assert np.max(np.abs(np.gradient(pos[d], t, axis=0) - vel)) < 0.2


def test_installs_and_refills_follow_the_payload_rule(planned):
    program, mission, problem, sol = planned
    sc = scenario_from_program(program, mission)
    pos = {d: np.stack([sol.channels[f"{d}.pos.{a}"] for a in "xyz"], 1) for d in sol.routes}
    payload, events = payload_team(sol.times, pos, sc)
    assert [(e.drone, e.kind, e.region) for e in events] == \
        [(e.drone, e.kind, e.region) for e in sol.events]
    installs = [e for e in events if e.kind == "install"]
    assert sorted(e.region for e in installs) == ["ta", "tb", "tc"]  # each once
    for e in installs:
        k = int(round(e.end / mission.step))
        assert payload[e.drone][k] >= 1  # it carried a diverter
    stations = {b.name: b for b in sc.stations}
    for e in events:
        if e.kind == "refill":
            k0, k1 = (int(round(x / mission.step)) for x in (e.start, e.end))
            assert np.all(inside(pos[e.drone][k0:k1 + 1], stations[e.region]))
            assert e.end - e.start >= sc.refill_time - 1e-9
    for d, c in payload.items():
        assert c.min() >= 0 and c.max() <= program.vehicles[d].capacity
        np.testing.assert_array_equal(sol.channels[f"{d}.payload"], c)


def test_seed_is_kept_and_judged_spec_by_spec(planned):
    program, mission, problem, sol = planned
    labels = [c.label for c in sol.comparisons]
    assert labels[0] == "MILP only" and "standard" in labels
    for c in sol.comparisons:
        assert set(c.specs) == set(sol.specs)
        assert c.robustness_exact == pytest.approx(min(c.specs.values()), abs=1e-9)


def test_cli_writes_team_outputs(tmp_path):
    out = tmp_path / "out"
    (out / "mine.txt").parent.mkdir()
    (out / "mine.txt").write_text("keep me")
    assert main(["compile", str(MISSION), "-o", str(out), "-q"]) == 0
    names = {p.name for p in out.iterdir()}
    assert {"solution.json", "trajectory.csv", "report.html", "trajectory.uav1.csv",
            "trajectory.uav2.csv", "mine.txt"} <= names
    assert (out / "mine.txt").read_text() == "keep me"
    sol = json.loads((out / "solution.json").read_text())
    assert sol["status"] == "satisfied"
    assert {e["region"] for e in sol["team"]["events"] if e["kind"] == "install"} == \
        {"ta", "tb", "tc"}
    head = (out / "trajectory.uav1.csv").read_text().splitlines()[0]
    assert head == "t,x,y,z,vx,vy,vz,ax,ay,az,heading"
    assert "uav1.payload" in (out / "trajectory.csv").read_text().splitlines()[0]


AERO = """  mass = 1.5 kg
  rotors = 4
  disk_area = 0.05 m^2
  flat_plate_area = 0.01 m^2
  induced_factor = 1.15
"""


def test_forward_speed_from_declared_aerodynamic_data(tmp_path):
    """Without `forward_speed`, v* is paper B eq. 8 from each drone's data:
    v* = sqrt(m / (2 ρ A)) · (4 κ A / (n f))^(1/4)
       = sqrt(1.5 / (2·1.225·0.05)) · (4·1.15·0.05 / (4·0.01))^(1/4)
       = 3.49927 · 5.75^(1/4) = 3.49927 · 1.54851 = 5.41865 m/s (by hand),
    clamped by the planner to hypot(3.1, 3.1) = 4.38406 m/s."""
    from stlc.backends.team.backend import forward_speed_target
    from stlc.planning.problem import from_mission

    text = MISSION.read_text().replace("  forward_speed = 2 m/s\n", "")
    text = text.replace("  capacity = 2\n", "  capacity = 2\n" + AERO)
    path = tmp_path / "aero.stl"
    path.write_text(text)
    program = load(str(path)).program
    problem = from_mission(program, program.missions["team_small"])
    v = forward_speed_target(problem)
    assert set(v) == {"uav1", "uav2"}
    assert v["uav1"] == pytest.approx(5.41865, rel=1e-5)
    _, sol = plan(program, program.missions["team_small"])
    assert sol.status == "satisfied" and sol.solver["forward_cost"] is not None
    # the plan's energy from paper B's power model (stlc.vehicles.power), recomputed here
    # from the plan's own velocities and accelerations: T = m |a + g e_z|, the induced
    # velocity v_i solving v_i sqrt(V^2 + v_i^2) = v_h^2 by bisection (V horizontal),
    # P = kappa T v_i + rho f V^3 / 2, E = sum_k dt P_k per drone
    dt = float(sol.times[1] - sol.times[0])
    by_hand = {}
    for d in ("uav1", "uav2"):
        vel = np.stack([sol.channels[f"{d}.vel.{a}"] for a in "xyz"], axis=1)
        acc = np.stack([sol.channels[f"{d}.acc.{a}"] for a in "xyz"], axis=1)
        thrust = 1.5 * np.linalg.norm(acc + [0.0, 0.0, 9.81], axis=1)
        vh2 = thrust / (2 * 1.225 * 4 * 0.05)
        V = np.hypot(vel[:, 0], vel[:, 1])
        lo, hi = np.zeros_like(V), np.sqrt(vh2)  # v_i <= v_h; the left side grows with v_i
        for _ in range(80):
            mid = (lo + hi) / 2
            low = mid * np.sqrt(V**2 + mid**2) < vh2
            lo, hi = np.where(low, mid, lo), np.where(low, hi, mid)
        vi = (lo + hi) / 2
        by_hand[d] = float(np.sum(dt * (1.15 * thrust * vi + 0.5 * 1.225 * 0.01 * V**3)))
    assert sol.energy_by_vehicle == pytest.approx(by_hand, rel=1e-9)
    assert sol.energy == pytest.approx(sum(by_hand.values()), rel=1e-9)
    # a hovering 1.5 kg drone draws 92.73 W: the plan's mean power is of that order
    assert 60 < sol.energy / (2 * sol.times[-1]) < 140


def test_aerodynamic_data_must_be_complete_and_motion_primitive_is_not_an_alias(tmp_path):
    from stlc.diagnostics import StlcError

    text = MISSION.read_text().replace("  capacity = 2\n", "  capacity = 2\n  rotors = 4\n", 1)
    path = tmp_path / "partial.stl"
    path.write_text(text)
    with pytest.raises(StlcError) as e:
        load(str(path))
    assert [d.code for d in e.value.diagnostics] == ["STL104"]
    assert "disk_area" in e.value.diagnostics[0].message
    path.write_text(MISSION.read_text().replace("uav1 : point_mass", "uav1 : motion_primitive"))
    with pytest.raises(StlcError) as e:
        load(str(path))
    (d,) = e.value.diagnostics
    assert d.code == "STL105" and "point_mass" in (d.help or "")
