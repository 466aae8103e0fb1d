"""``stlc simulate --move``: paper A §6's re-plan decision when the human moves.  A move
that breaks the plan is replanned from the state at the event (what was flown before it
is kept), and the executed trajectory satisfies the mission at the new pose (exact
monitor, recomputed here); a move that does not break it keeps the plan."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from stlc.analysis import monitor
from stlc.analysis.trace import read_trace
from stlc.pipeline import load

SOURCE = """\
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
  spec reach = eventually[1, 3] always[0, 0.4] (p.pos in op.r)
  require reach and always (p.pos in workspace)
  minimize -robustness
}
"""


def run(tmp_path, move: str, out: str):
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    r = subprocess.run([sys.executable, "-m", "stlc", "simulate", str(f), "--mission", "m",
                        "--move", move, "-o", str(tmp_path / out), "-q"],
                       capture_output=True, text=True, timeout=600)
    rec = json.loads((tmp_path / out / "replan.json").read_text()) if r.returncode in (0, 3) \
        else None
    return r, rec, str(f)


def test_move_that_breaks_the_plan_is_replanned(tmp_path):
    r, rec, f = run(tmp_path, "op@0.6:1.5,-1.2,0", "a")
    assert r.returncode == 0, r.stderr
    ev = rec["events"][0]
    assert ev["kind"] == "move" and ev["triggered"] and ev["accepted"]
    assert ev["detail"]["decision"] == "replan" and ev["detail"]["robustness_new_pose"] < 0
    prog = load(f, ["op.pos.y=-1.2 m"]).program
    nominal = read_trace(str(tmp_path / "a" / "trajectory.csv"))
    flown = read_trace(str(tmp_path / "a" / "executed.csv"))
    req = prog.missions["m"].requirement
    # independently: the nominal plan fails at the new pose, the flown one satisfies it
    assert monitor.robustness(req, 0.2, nominal.channels, prog.params) < 0
    rho = monitor.robustness(req, 0.2, flown.channels, prog.params)
    # executed.csv holds 9 significant digits (strictjson): metres to ~1e-8
    assert rho >= 0 and rho == pytest.approx(rec["executed"]["robustness"]["mission"], abs=1e-7)
    # what was flown before the event (samples 0..3, t <= 0.6 s) is the nominal plan
    for k in ("p.pos.x", "p.pos.y", "p.vel.x"):
        np.testing.assert_allclose(flown.channels[k][:4], nominal.channels[k][:4], atol=1e-9)
    assert "move" in (tmp_path / "a" / "report.html").read_text()


def test_small_move_keeps_the_plan(tmp_path):
    r, rec, f = run(tmp_path, "op@0.6:1.52,0,0:2", "b")
    assert r.returncode == 0, r.stderr
    ev = rec["events"][0]
    assert not ev["triggered"] and rec["replans"]["count"] == 0
    nominal = read_trace(str(tmp_path / "b" / "trajectory.csv"))
    flown = read_trace(str(tmp_path / "b" / "executed.csv"))
    np.testing.assert_array_equal(flown.channels["p.pos.y"], nominal.channels["p.pos.y"])
    prog = load(f, ["op.pos.x=1.52 m", "op.att.z=2 deg"]).program
    assert monitor.robustness(prog.missions["m"].requirement, 0.2, nominal.channels,
                              prog.params) >= 0


def test_bad_move(tmp_path):
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    for mv, code in [("opp@1:0,0,0", "STL101"), ("op@9:0,0,0", "STL306")]:
        r = subprocess.run([sys.executable, "-m", "stlc", "simulate", str(f), "--move", mv,
                            "-o", str(tmp_path / "c")], capture_output=True, text=True)
        assert r.returncode == 1 and f"error[{code}]" in r.stderr, r.stderr
    r = subprocess.run([sys.executable, "-m", "stlc", "simulate", str(f), "--move", "op@1:0,0"],
                       capture_output=True, text=True)
    assert r.returncode == 2


def test_library_warm_start(tmp_path):
    """--library DIR: the replan starts from the sweep plan nearest to the new pose (a
    sweep directory written by hand here); the verdict is still the exact monitor's."""
    from stlc.output.solution import trajectory_csv
    from stlc.pipeline import plan
    from stlc.backends.replan.move import _library_plans, replan_rest
    from stlc.replan.move import Move, simulate_move

    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    lib = tmp_path / "lib"
    (lib / "plans").mkdir(parents=True)
    rows = ["instance,op.pos.y,status,robustness,spec.reach,iterations,solve_s,total_s,worker,"
            "error"]
    for i, y in enumerate((0.0, -1.2)):
        lo = load(str(f), [f"op.pos.y={y} m"])
        _, s = plan(lo.program, lo.program.missions["m"], values=lo.values)
        assert s.status == "satisfied"
        (lib / "plans" / f"{i}.csv").write_text(trajectory_csv(s))
        rows.append(f"{i},{y},satisfied,{s.robustness_exact},0,1,0,0,w,")
    (lib / "sweep.csv").write_text("\n".join(rows) + "\n")
    plans = _library_plans(str(lib))
    assert [v for v, _ in plans] == [{"op.pos.y": 0.0}, {"op.pos.y": -1.2}]
    prog = load(str(f)).program
    problem, sol = plan(prog, prog.missions["m"])
    res = simulate_move(problem, sol, Move("op", 0.6, (1.5, -1.1, 0.0)), library=str(lib),
                        replanner=replan_rest)
    ev = res.events[0]
    assert ev.triggered and ev.detail["warm_start"].startswith("library")
    moved = load(str(f), ["op.pos.y=-1.1 m"]).program
    rho = monitor.robustness(moved.missions["m"].requirement, 0.2, res.executed, moved.params)
    assert rho == pytest.approx(res.executed_robustness["mission"], abs=1e-12)
    assert ev.accepted == (rho >= 0)


def test_move_block_in_the_file(tmp_path):
    """`move op { ... }` in the mission's `simulate` block is the same event as --move: the
    plan is replanned and the flown trajectory satisfies the mission at the new pose."""
    f = tmp_path / "m.stl"
    f.write_text(SOURCE.replace("  minimize -robustness\n", "  minimize -robustness\n"
                                "  simulate {\n    move op { time = 0.6 s; pos = (1.5, -1.2, 0) m }"
                                "\n  }\n"))
    r = subprocess.run([sys.executable, "-m", "stlc", "simulate", str(f), "-o",
                        str(tmp_path / "o"), "-q"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    ev = json.loads((tmp_path / "o" / "replan.json").read_text())["events"][0]
    assert ev["kind"] == "move" and ev["time"] == pytest.approx(0.6)
    assert ev["detail"]["pos"] == [1.5, -1.2, 0.0] and ev["detail"]["decision"] == "replan"
    prog = load(str(f), ["op.pos.y=-1.2 m"]).program
    flown = read_trace(str(tmp_path / "o" / "executed.csv"))
    assert monitor.robustness(prog.missions["m"].requirement, 0.2, flown.channels,
                              prog.params) >= 0


def test_move_block_keeps_what_it_does_not_give(tmp_path):
    """A block with `att` only keeps the human's position — the one after --set."""
    from stlc.simulation import _file_move

    text = SOURCE.replace("  minimize -robustness\n", "  minimize -robustness\n  simulate {\n"
                          "    move op { time = 1 s; att = (0, 0, 90) deg }\n  }\n")
    for sets, x in (((), 1.5), (("op.pos.x=1.25 m",), 1.25)):
        (tmp_path / "m.stl").write_text(text)
        prog = load(str(tmp_path / "m.stl"), list(sets)).program
        mv = _file_move(prog, prog.missions["m"].simulate.moves[0])
        assert mv.pos == (x, 0.0, 0.0) and mv.time == 1.0
        assert mv.att == pytest.approx((0.0, 0.0, np.pi / 2))
