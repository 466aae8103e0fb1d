"""A plan whose optimum is exactly on the boundary (ρ = κ = 0) is judged on its own
numbers (``stlc.planning.boundary``), and ``trajectory.csv`` writes the verified numbers
round-trip exact, so ``stlc monitor`` on the written file gives the same verdict."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np

from stlc.planning.boundary import DEFECT_TOL, reconcile
from stlc.semantics import ir
from stlc.strictjson import channels_csv

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# the optimum is ρ = 0 exactly: the start is on the workspace floor (z = 0) and the
# workspace's lower face binds at t = 0 whatever the plan; at a 0.3 s step the inputs'
# re-simulation rounds a state on the x = 0 face to −2.9e-16 (seen before the fix: STL501
# "violated by 0.0000", exit 3)
FLOOR = """\
vehicle robot : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (0.5, 0.5, 0.5) m/s^2
  start { pos = (1.3, 2.7, 0) m }
}
scenario {
  workspace = box((0, 0, 0), (10, 10, 2)) m
  target goal = box((1, 1, 0), (3, 3, 2)) m
}
mission floor {
  vehicles = [robot]
  horizon = 6 s
  step = 0.3 s
  threshold = 0
  spec inside = always[0, 6] (robot.pos in workspace)
  spec reach = eventually[0, 6] (robot.pos in goal)
  require inside and reach
  maximize robustness
}
"""


def _stlc(*args):
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True, env=env, timeout=300)


def test_boundary_optimum_is_satisfied_and_its_csv_agrees(tmp_path):
    spec = tmp_path / "floor.stl"
    spec.write_text(FLOOR)
    out = tmp_path / "o"
    r = _stlc("compile", str(spec), "-o", str(out), "-q", "--no-risk")
    assert r.returncode == 0, r.stdout + r.stderr
    sol = json.loads((out / "solution.json").read_text())
    assert sol["status"] == "satisfied" and sol["robustness"]["exact"] >= 0.0
    m = _stlc("monitor", str(spec), "--trace", str(out / "trajectory.csv"), "--json",
              "--fail-on-violation")
    assert m.returncode == 0, m.stdout + m.stderr
    written = json.loads(m.stdout)["specs"]["floor"]["robustness"]
    assert written == sol["robustness"]["exact"]  # the same numbers, to the last bit


def _fake(states, resim, feasible=True):
    return SimpleNamespace(solver_states=states, channels=resim, feasible=feasible)


FLOOR_Z = SimpleNamespace(requirement=ir.Pred(ir.Sig("d.pos.z"), "d.pos.z >= 0"))  # ρ = min z


def test_reconcile_accepts_rounding_only():
    z_solver = np.array([0.0, 0.5, 1.0])
    rob = lambda ch: float(np.min(ch["d.pos.z"]))  # noqa: E731
    same = lambda problem, ch: (ch, [])  # noqa: E731
    resim = {"d.pos.z": np.array([0.0, 0.5, 1.0]) - np.array([9e-15, 0, 0])}
    got = reconcile(FLOOR_Z, _fake({"d.pos.z": z_solver}, resim), rob(resim), 0.0, same, rob)
    assert got is not None and got.robustness == 0.0 and got.defect == 9e-15
    assert "solver's own samples" in got.note
    far = {"d.pos.z": z_solver - 10 * DEFECT_TOL}  # a real defect, not rounding: kept violated
    assert reconcile(FLOOR_Z, _fake({"d.pos.z": z_solver}, far), rob(far), 0.0, same, rob) is None
    # the solver's feasibility tolerance (−1e-15 under a face): put on the face
    low = {"d.pos.z": z_solver - 1e-15}
    got = reconcile(FLOOR_Z, _fake({}, low), rob(low), 0.0, same, rob)
    assert got is not None and got.robustness == 0.0 and "put on it" in got.note
    assert list(got.channels["d.pos.z"]) == [0.0, 0.5 - 1e-15, 1.0 - 1e-15]  # only at the face
    assert reconcile(FLOOR_Z, _fake({"d.pos.z": z_solver}, resim, False), -9e-15, 0.0, same,
                     rob) is None


def test_csv_round_trips_utm_coordinates(tmp_path):
    rng = np.random.default_rng(7)
    ch = {"d.pos.x": 4.5e5 + rng.random(50), "d.pos.y": 5.4e6 + rng.random(50),
          "d.pos.z": rng.random(50) * 1e-12}
    t = np.arange(50) * 0.1
    path = tmp_path / "t.csv"
    path.write_text(channels_csv(t, ch))
    back = np.genfromtxt(path, delimiter=",", names=True)
    assert np.array_equal(back["t"], t)
    for k, v in ch.items():
        assert np.array_equal(back[k.replace(".", "")], v)
