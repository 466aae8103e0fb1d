"""The Python API at the CLI's parity: ``compile(time_limit=, backend=)``, ``simulate``,
``sweep`` (a table), ``risk``, and the ``Plan``'s views — per-vehicle arrays, a pandas
table (pandas optional), the report's figures, Jupyter's HTML.  Every number is checked
against an independent computation: the exact monitor on the arrays handed out, the
spec file's own numbers, or the CLI's files.  Small missions (seconds each)."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import stlc

ROOT = Path(__file__).resolve().parents[1]
REACH = ROOT / "specs" / "benchmarks" / "reach_avoid.stl"

#: a point mass past an operator whose position is uncertain (two risk cases, few samples)
RISKY = """\
vehicle uav1 : point_mass {
  vel_max = (2, 2, 1) m/s
  acc_max = (3, 3, 2) m/s^2
  start { pos = (-2, 0, 1) m }
}
scenario {
  workspace = box((-3, -3, 0), (3, 3, 2.5)) m
  target drop = box((1.5, -0.5, 0.5), (2.5, 0.5, 1.5)) m
  human operator {
    pos = (0, 1, 0) m
    att = (0, 0, -90) deg
    region near = box((0.5, -0.6, 0), (1.5, 0.6, 2)) m
  }
}
mission pass {
  vehicles = [uav1]
  horizon = 4 s
  step = 0.2 s
  threshold = 0.01
  spec deliver = eventually[2, 4] (uav1.pos in drop)
  spec keep = always[0, 4] (uav1.pos not in operator.near)
  require deliver and keep
  maximize robustness
  risk {
    K = 200; delta = 0.05; beta = [0.9]; seed = 3
    case tight { operator.pos ~ normal((0, 1, 0) m, diag(0.01, 0.01, 0) m^2) }
    case wide  { operator.pos ~ normal((0, 1, 0) m, diag(0.5, 0.5, 0) m^2) }
  }
}
"""


@pytest.fixture(scope="module")
def program():
    return stlc.load(REACH)


@pytest.fixture(scope="module")
def plan(program):
    return stlc.compile(program, "reach_avoid", time_limit=60)


def test_compile_verdict_is_the_exact_monitor_on_the_arrays_handed_out(program, plan):
    assert plan.status == "satisfied" and plan.satisfied
    assert plan.threshold == pytest.approx(0.1)  # the file's `threshold = 0.1`
    again = stlc.monitor(program, plan.trajectory)
    assert plan.robustness == pytest.approx(again["reach_avoid"], abs=1e-9)
    for name, rho in plan.specs.items():
        assert rho == pytest.approx(again[name], abs=1e-9)
    assert plan.robustness >= plan.threshold


def test_compile_backend_and_time_limit(program):
    forced = stlc.compile(program, backend="nlp", time_limit=60)
    assert forced.solution.solver["chain"]["name"] == "nlp"
    assert forced.solution.solver["chain"]["forced"] is True
    with pytest.raises(ValueError, match="positive"):
        stlc.compile(program, time_limit=0)
    # a limit far below what the mission needs: the best verified plan comes back, stopped
    slow = stlc.load(ROOT / "tests" / "missions" / "patrol_slow.stl")
    t0 = time.perf_counter()
    stopped = stlc.compile(slow, time_limit=2)
    wall = time.perf_counter() - t0
    assert stopped.solution.solver.get("stopped_by") == "time_limit"
    assert stopped.status in ("stopped", "satisfied")
    assert wall < 2 + 8, wall  # the limit plus verification, on a loaded machine
    assert stopped.robustness == pytest.approx(
        stlc.monitor(slow, stopped.trajectory)["patrol"], abs=1e-9)


def test_vehicle_arrays_are_the_channels(plan):
    robot = plan.vehicle("robot")
    assert plan.vehicles == ["robot"]
    n = len(plan.trajectory["t"])
    assert robot.pos.shape == (n, 3) and robot.vel.shape == (n, 3)
    for i, a in enumerate("xyz"):
        assert np.array_equal(robot.pos[:, i], plan.trajectory[f"robot.pos.{a}"])
    assert np.array_equal(robot["t"], plan.trajectory["t"])
    # the file: `start { pos = (1, 2, 1) m }`, 16 samples of 1 s
    assert robot.pos[0] == pytest.approx([1, 2, 1]) and n == 16
    with pytest.raises(KeyError, match="robot"):
        plan.vehicle("uav9")
    with pytest.raises(AttributeError, match="no field `rotor_speed`"):
        _ = robot.rotor_speed


def test_to_dataframe_and_without_pandas(plan, monkeypatch):
    df = plan.to_dataframe()
    assert list(df.columns) == ["t", *plan.solution.channels]
    assert np.array_equal(df["robot.pos.y"].to_numpy(), plan.trajectory["robot.pos.y"])
    monkeypatch.setitem(sys.modules, "pandas", None)  # as if pandas were not installed
    with pytest.raises(ImportError, match="needs pandas.*plan.trajectory"):
        plan.to_dataframe()


def test_plot_draws_the_report_figures(plan):
    figs = plan.figures()
    assert {"scene", "top", "position", "speed"} <= set(figs)
    scene = plan.plot()
    meshes = [t for t in scene.data if t.type == "mesh3d" and t.name == "obs"]
    # the file: obstacle obs = box((3, 4, -1), (5, 6, 3)) m (drawn inside the workspace)
    assert len(meshes) == 1
    assert (min(meshes[0].x), max(meshes[0].x)) == (3, 5)
    assert (min(meshes[0].y), max(meshes[0].y)) == (4, 6)
    path = [t for t in scene.data if t.type == "scatter3d" and t.name == "robot"]
    assert list(path[0].x) == pytest.approx(plan.vehicle("robot").pos[:, 0], abs=1e-4)
    speed = plan.plot("speed")
    want = np.linalg.norm(plan.vehicle("robot").vel, axis=1)
    assert list(speed.data[0].y) == pytest.approx(want, rel=1e-4, abs=1e-6)
    with pytest.raises(KeyError, match="figures: scene"):
        plan.plot("nonsense")


def test_repr_html_for_jupyter(plan):
    html = plan._repr_html_()
    assert html.startswith("<div") and "reach_avoid" in html
    assert "exact ρ = +0.5000 ≥ κ = 0.1" in html  # the verdict with its evidence
    assert "<script" not in html and html.count("<tr>") == 1 + len(plan.specs)
    page = plan.report_html()
    assert page.startswith("<!DOCTYPE html>") and "reach_avoid" in page


def test_sweep_table_in_the_units_given(program, plan):
    rows = stlc.sweep(program, "reach_avoid", vary={"robot.start.pos.x": ("100 cm", "150 cm", 2)})
    assert list(rows["robot.start.pos.x"]) == [100.0, 150.0]  # centimetres stay centimetres
    assert rows.attrs["units"] == {"robot.start.pos.x": "cm"}
    assert list(rows["status"]) == ["satisfied", "satisfied"]
    # instance 0 is the file's own start (1 m): the exact MILP's optimum, as compiled
    assert rows["robustness"][0] == pytest.approx(plan.robustness, abs=1e-6)
    assert {"spec.avoid", "spec.reach", "spec.inside", "solve_s"} <= set(rows.columns)


def test_compile_set_takes_what_the_cli_set_takes(program):
    rows = stlc.sweep(program, "reach_avoid", vary={"robot.start.pos.x": ("150 cm", "150 cm", 1)})
    moved = stlc.compile(program, set={"robot.start.pos.x": "150 cm"})
    assert moved.vehicle("robot").pos[0] == pytest.approx([1.5, 2, 1])  # was (1, 2, 1)
    assert moved.robustness == pytest.approx(rows["robustness"][0], abs=1e-6)
    assert moved.robustness == pytest.approx(
        stlc.monitor(moved.program, moved.trajectory)["reach_avoid"], abs=1e-9)


def test_sweep_without_pandas_is_a_list_of_records(program, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    rows = stlc.sweep(program, "reach_avoid", ["robot.start.pos.y=2 m:2 m:1"])
    assert isinstance(rows, list) and len(rows) == 1 and rows.units == {"robot.start.pos.y": "m"}
    assert rows[0]["robot.start.pos.y"] == 2.0 and rows[0]["status"] == "satisfied"


def test_simulate_verdict_is_the_monitor_on_what_was_flown(program):
    flight = stlc.simulate(program, "reach_avoid", disturb=[("robot", 4.0, (0.0, 1.5, 0.0))])
    trig = [e for e in flight.events if e["triggered"]]
    assert trig and trig[0]["time"] == pytest.approx(4.0)
    assert trig[0]["deviation"] == pytest.approx(1.5, abs=1e-6)
    again = stlc.monitor(flight.plan.program, flight.executed)
    assert flight.robustness["mission"] == pytest.approx(again["reach_avoid"], abs=1e-9)
    # the push is in the executed trajectory: 1.5 m off the plan in y at t = 4 s
    k = int(np.argmin(np.abs(flight.executed["t"] - 4.0)))
    dy = flight.executed["robot.pos.y"][k] - flight.plan.trajectory["robot.pos.y"][k]
    assert dy == pytest.approx(1.5, abs=1e-6)
    assert flight.ok == (flight.result.ok() and flight.plan.satisfied)
    assert "<div" in flight._repr_html_() and flight.to_json()["mission"] == "reach_avoid"


def test_risk_from_a_plan_and_from_its_csv_agree(tmp_path):
    src = tmp_path / "risky.stl"
    src.write_text(RISKY, encoding="utf-8")
    program = stlc.load(src)
    plan = stlc.compile(program, time_limit=60)
    assert plan.risk is not None  # compile ran the risk cases
    from_plan = stlc.risk(program, trajectory=plan)
    out = plan.write(tmp_path / "out")
    from_csv = stlc.risk(program, "pass", Path(out) / "trajectory.csv")
    cli_json = json.loads((Path(out) / "risk.json").read_text())
    for got in (from_plan, from_csv):
        assert [c["name"] for c in got["cases"]] == ["tight", "wide"]
        for c, ref in zip(got["cases"], cli_json["cases"]):
            pv = c["p_violation"]
            assert pv["value"] == pytest.approx(pv["count"] / c["K"])  # a frequency of K
            assert pv["value"] == pytest.approx(ref["p_violation"]["value"], abs=1e-12)
    tight, wide = from_plan["cases"]
    assert tight["p_violation"]["value"] <= wide["p_violation"]["value"]
    with pytest.raises(TypeError, match="trajectory"):
        stlc.risk(program)
    assert not math.isnan(tight["nominal_robustness"])


def test_plot_draws_round_regions():
    plan = stlc.compile(ROOT / "specs" / "tower_inspection.stl", time_limit=120)
    scene = plan.plot()
    tower = next(t for t in scene.data if t.type == "mesh3d" and t.name == "tower")
    # the file: cylinder(center = (0, 0, 5) m, radius = 1.5 m, height = 10 m)
    r = np.hypot(np.asarray(tower.x), np.asarray(tower.y))
    assert r.max() == pytest.approx(1.5, abs=1e-3) and len(tower.x) > 8
    assert (min(tower.z), max(tower.z)) == pytest.approx((0, 10), abs=1e-6)
    top = next(t for t in scene.data if t.type == "mesh3d" and t.name == "top")
    d = np.linalg.norm(np.stack([top.x, np.asarray(top.y) - 3.5, np.asarray(top.z) - 9]), axis=0)
    assert d == pytest.approx(np.full(d.shape, 0.8), abs=1e-3)  # sphere(radius = 0.8 m)


def test_fly_from_python_is_the_commands_flight(tmp_path):
    """``stlc.fly`` returns ``flight.json``; the flown robustness is the exact monitor's on
    the written ``flown.csv``."""
    climb = Path(__file__).parent / "missions" / "hexa_climb.stl"
    rec = stlc.fly(climb, out=tmp_path / "f", runs=20, seed=3, wind=(2.0, 0.0, 0.0))
    assert rec["runs"]["n"] == 20
    assert 0 <= rec["runs"]["p_violation"] <= rec["runs"]["p_violation_upper"] <= 1
    again = stlc.monitor(stlc.load(climb), str(tmp_path / "f" / "flown.csv"))
    assert again["climb"] == pytest.approx(rec["flown"]["robustness"], abs=1e-6)


def test_the_api_plans_what_the_command_line_plans(tmp_path):
    """The same mission from Python and from ``stlc compile`` gives the same plan: the
    first planning pins the solver threads as the CLI does (MUMPS's thread count changes
    IPOPT's path; the handover differed by 4e-4 in ρ without it)."""
    import os
    import subprocess

    root = Path(__file__).resolve().parents[1]
    env = {k: v for k, v in os.environ.items()
           if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    env["PYTHONPATH"] = str(root) + os.pathsep + env.get("PYTHONPATH", "")
    spec = str(root / "specs" / "handover.stl")
    api = subprocess.run([sys.executable, "-c", "import stlc; p = stlc.compile(stlc.load("
                          f"{spec!r}), 'handover_left_tb', risk=False); print(repr(p.robustness))"],
                         env=env, capture_output=True, text=True, timeout=600)
    assert api.returncode == 0, api.stderr
    cli = subprocess.run([sys.executable, "-m", "stlc", "compile", spec, "--mission",
                          "handover_left_tb", "--no-risk", "-q", "-o", str(tmp_path / "o")],
                         env=env, capture_output=True, text=True, timeout=600)
    assert cli.returncode == 0, cli.stderr
    exact = json.loads((tmp_path / "o" / "solution.json").read_text())["robustness"]["exact"]
    assert float(api.stdout.strip().splitlines()[-1]) == pytest.approx(exact, abs=1e-9)
