"""``--set NAME=VALUE``: diagnostics, what it changes, and the one parametric code path (a
compile with ``--set`` equals a compile of the edited file; one build serves both)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from stlc.analysis import monitor
from stlc.backends.nlp import cache as nlp_cache
from stlc.diagnostics import StlcError
from stlc.pipeline import load, plan

SOURCE = """\
const T = 3 s
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
scenario {
  workspace = box((-3, -3, -1), (3, 3, 1)) m
  human op {
    pos = (1.5, 0, 0) m
    att = (0, 0, 0) deg
    region r = box((-0.4, 0.2, -0.2), (0.0, 0.6, 0.2)) m
  }
}
mission m {
  vehicles = [p]
  horizon = 4 s
  step = 0.2 s
  spec reach = eventually[1, T] always[0, 0.4] (p.pos in op.r)
  spec stay = always (p.pos in workspace)
  require reach and stay
  minimize -robustness
}
"""


def write(tmp_path: Path, text: str, name: str = "f.stl") -> str:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return str(p)


def codes(e: StlcError) -> list[str]:
    return [d.code for d in e.diagnostics]


def test_values_applied_to_the_checked_program(tmp_path):
    path = write(tmp_path, SOURCE)
    lo = load(path, ["op.att.z=90 deg", "op.pos.y=-0.5 m", "p.start.pos.x=25 cm", "T=2 s"])
    pr = lo.program
    assert pr.params["op.att.z"] == pytest.approx(np.pi / 2)
    assert pr.params["op.pos.y"] == -0.5 and pr.params["op.pos.x"] == 1.5
    assert pr.scenario.humans[0].att == pytest.approx((0, 0, np.pi / 2))
    assert pr.vehicles["p"].start_pos == pytest.approx((0.25, 0, 0))
    assert lo.values == pytest.approx({"op.att.z": np.pi / 2, "op.pos.y": -0.5,
                                       "p.start.pos.x": 0.25, "T": 2.0})
    # the const moved the window's end: a trace inside the region only at t = 2.2..2.6 s
    # satisfies `reach` with T = 3 s and violates it with T = 2 s
    t = np.arange(0, 4.01, 0.2)
    inside = (t > 2.1) & (t < 2.7)
    # op at (1.5, -0.5) turned 90 deg: the region's frame x axis is world y
    cx, cy = 1.5 - 0.4, -0.5 - 0.2  # centre of the box in world (frame (-0.2, 0.4) turned)
    ch = {"p.pos.x": np.where(inside, cx, 0.0), "p.pos.y": np.where(inside, cy, 0.0),
          "p.pos.z": np.zeros_like(t)}
    f2 = pr.missions["m"].specs["reach"]
    f3 = load(path, ["op.att.z=90 deg", "op.pos.y=-0.5 m"]).program.missions["m"].specs["reach"]
    assert monitor.robustness(f3, 0.2, ch, pr.params) > 0
    assert monitor.robustness(f2, 0.2, ch, pr.params) < 0


def test_errors_are_diagnostics(tmp_path):
    path = write(tmp_path, SOURCE)
    with pytest.raises(StlcError) as e:
        load(path, ["op.att.w=3 deg"])
    assert codes(e.value) == ["STL101"] and "did you mean" in e.value.diagnostics[0].help
    for bad, code in [("op.pos.x=3 deg", "STL204"), ("T=3", "STL204"), ("op.pos.x=3", "STL204"),
                      ("T=abc", "STL201"), ("op.pos.x", "STL201"), ("p.start.att.z=1 deg",
                                                                       "STL101")]:
        with pytest.raises(StlcError) as e:
            load(path, [bad])
        assert codes(e.value) == [code], bad
    with pytest.raises(StlcError) as e:  # all problems at once
        load(path, ["nope=1 m", "op.pos.z=1 s"])
    assert sorted(codes(e.value)) == ["STL101", "STL204"]
    r = subprocess.run([sys.executable, "-m", "stlc", "check", path, "--set", "op.pos.q=1 m"],
                       capture_output=True, text=True)
    assert r.returncode == 1 and "error[STL101]" in r.stderr and "did you mean `op.pos.z`" in r.stderr
    assert "Traceback" not in r.stderr


def test_set_equals_edited_file_one_build(tmp_path):
    """The parametric NLP with --set values gives the plan of the edited file (exactly: the
    same NLP with the same parameter values), and the second instance reuses the build."""
    nlp_cache.clear()
    path = write(tmp_path, SOURCE)
    edited = write(tmp_path, SOURCE.replace("pos = (1.5, 0, 0) m", "pos = (1.2, 0, 0) m")
                   .replace("att = (0, 0, 0) deg", "att = (0, 0, 20) deg")
                   .replace("start { pos = (0, 0, 0) m }", "start { pos = (0, 0.3, 0) m }"),
                   "edited.stl")
    sets = ["op.pos.x=1.2 m", "op.att.z=20 deg", "p.start.pos.y=0.3 m"]
    b0 = nlp_cache.STATS["builds"]
    lo = load(path, sets)
    _, a = plan(lo.program, lo.program.missions["m"], values=lo.values)
    b1 = nlp_cache.STATS["builds"]
    pr_e = load(edited).program
    _, b = plan(pr_e, pr_e.missions["m"])  # (its spans differ: a build of its own)
    b2 = nlp_cache.STATS["builds"]
    assert a.robustness_exact == pytest.approx(b.robustness_exact, abs=1e-9)
    for k in b.channels:
        np.testing.assert_allclose(a.channels[k], b.channels[k], atol=1e-9)
    assert a.channels["p.pos.y"][0] == pytest.approx(0.3)
    # the nominal instance of the same file: no new build, its own start and pose
    pr_n = load(path).program
    _, c = plan(pr_n, pr_n.missions["m"])
    assert b1 - b0 == 1 and nlp_cache.STATS["builds"] == b2  # one build for both
    assert c.channels["p.pos.y"][0] == pytest.approx(0.0)
    # the verdict is the exact monitor's on each instance's own plan and parameters
    for pr, s in ((lo.program, a), (pr_n, c)):
        f = pr.missions["m"].requirement
        assert s.robustness_exact == pytest.approx(
            monitor.robustness(f, 0.2, s.channels, pr.params), abs=1e-12)


WALL = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
scenario {
  workspace = box((-3, -3, -1), (3, 3, 1)) m
  obstacle wall = box((0.6, -0.4, -1), (0.9, 0.4, 1)) m
  region goal = box((1.4, -0.3, -0.3), (2.0, 0.3, 0.3)) m
}
mission m {
  vehicles = [p]
  horizon = 4 s
  step = 0.2 s
  spec avoid = always (p.pos not in wall and p.pos in workspace)
  spec reach = eventually[2, 3] always[0, 0.4] (p.pos in goal)
  require avoid and reach
  minimize -robustness
}
"""


def test_set_region_centre(tmp_path):
    """--set 'wall.center.y=...' moves the obstacle (size kept): the instance's program has
    the moved box, its formulas read the centre as a parameter — the exact monitor gives
    the edited file's robustness on any trace — and a compile equals the edited file's."""
    path = write(tmp_path, WALL)
    edited = write(tmp_path, WALL.replace("box((0.6, -0.4, -1), (0.9, 0.4, 1))",
                                          "box((0.6, -0.1, -1), (0.9, 0.7, 1))"), "e.stl")
    lo = load(path, ["wall.center.y=0.3 m"])
    pr, pe = lo.program, load(edited).program
    wall = pr.scenario.region("wall")
    assert wall.box.lo == pytest.approx((0.6, -0.1, -1)) and wall.box.hi == pytest.approx(
        (0.9, 0.7, 1)) and pr.params["wall.center.y"] == 0.3
    rng = np.random.default_rng(1)  # random traces through and around the wall
    for _ in range(20):
        ch = {f"p.pos.{a}": rng.uniform(-1.5, 2.5, 21) for a in "xyz"}
        assert monitor.robustness(pr.missions["m"].requirement, 0.2, ch, pr.params) == \
            pytest.approx(monitor.robustness(pe.missions["m"].requirement, 0.2, ch, pe.params),
                          abs=1e-12)
    _, a = plan(pr, pr.missions["m"], values=lo.values)
    _, b = plan(pe, pe.missions["m"])
    assert a.status == b.status == "satisfied"
    assert a.robustness_exact == pytest.approx(b.robustness_exact, abs=1e-9)
    with pytest.raises(StlcError) as e:  # the workspace is not placeable; a length is needed
        load(path, ["workspace.center.x=1 m"])
    assert codes(e.value) == ["STL101"]
    with pytest.raises(StlcError) as e:
        load(path, ["wall.center.x=1 deg"])
    assert codes(e.value) == ["STL204"]


def test_set_region_centre_one_build(tmp_path):
    """On the NLP, the centre is a parameter: two placements share one build, and each
    plan's verdict is the exact monitor's at its own placement."""
    nlp_cache.clear()
    path = write(tmp_path, WALL)
    b0 = nlp_cache.STATS["builds"]
    for y in (0.3, -0.35):
        lo = load(path, [f"wall.center.y={y} m"])
        _, s = plan(lo.program, lo.program.missions["m"], values=lo.values, backend="casadi")
        f = lo.program.missions["m"].requirement
        assert s.robustness_exact == pytest.approx(
            monitor.robustness(f, 0.2, s.channels, lo.program.params), abs=1e-12)
        assert s.status == "satisfied"
    assert nlp_cache.STATS["builds"] - b0 == 1


def test_library_warm_start_runs_the_energy_stage_first(tmp_path):
    """A plan-library seed (a neighbouring instance's plan) skips the robustness stages: the
    energy stage starts from it; the verdict is still the exact monitor's at the instance's
    own pose, and the plan starts at the instance's own start."""
    from stlc.backends.nlp.library import LibrarySeed
    from stlc.pipeline import backend_chain
    from stlc.planning.problem import from_mission

    path = write(tmp_path, SOURCE.replace("minimize -robustness",
                                          "minimize 0.5 * energy - robustness"))
    lo = load(path, ["op.pos.y=0.1 m"])
    _, a = plan(lo.program, lo.program.missions["m"], values=lo.values, backend="casadi")
    assert a.status == "satisfied"
    # a compile also runs the energy stage first, from its MILP seed (schedule.ENERGY_FIRST)
    assert [s["label"] for s in a.solver["stages"]][0].startswith("energy")
    lo2 = load(path, ["op.pos.y=-0.05 m", "p.start.pos.x=0.1 m"])
    m2 = lo2.program.missions["m"]
    chain = backend_chain(from_mission(lo2.program, m2, values=lo2.values))
    _, b = plan(lo2.program, m2, values=lo2.values,
                chain=[LibrarySeed(a.channels, "a", 0.1), chain[-1]])
    # (then, for a point mass, the smoothing stage: ``nlp.smoothing``)
    labels = [s["label"] for s in b.solver["stages"]
              if not s["label"].startswith("smooth")]
    assert labels and all(x.startswith("energy") for x in labels), labels
    assert b.status == "satisfied" and b.channels["p.pos.x"][0] == pytest.approx(0.1)
    assert b.robustness_exact == pytest.approx(
        monitor.robustness(m2.requirement, 0.2, b.channels, lo2.program.params), abs=1e-12)


def test_library_picks_the_most_robust_of_the_nearest():
    """``PlanLibrary.nearest`` with a score: the best-scored of the k nearest, ties to the
    nearer; without one, the nearest."""
    from stlc.backends.nlp.library import PlanLibrary

    lib = PlanLibrary()
    for y, rho in ((0.0, 0.1), (1.0, 0.5), (2.0, 0.9), (9.0, 5.0), (10.0, 0.0)):
        lib.add({"y": y}, {"rho": np.array([rho])}, str(y))
    assert lib.nearest({"y": 0.9})[1] == "1.0"
    score = lambda ch: float(ch["rho"][0])  # noqa: E731
    assert lib.nearest({"y": 0.9}, score, k=3)[1] == "2.0"  # 9.0 is not among the 3 nearest
    assert lib.nearest({"y": 0.9}, lambda ch: 0.0, k=3)[1] == "1.0"
