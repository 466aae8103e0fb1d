"""Honest verdicts and bounded loops (issue 23, items 2, 4, 6, 7): simulate's exit code
counts the nominal plan, a repeated option is a usage error, no `inf` where a predicate
belongs, histograms of equal huge robustness, replanning loops bounded by the samples, the
NLP refused before it is built, and risk on a long trace in bounded memory."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from stlc.analysis.risk import robustness_histogram
from stlc.cli import main
from stlc.output.compile import summary
from stlc.output.report.risk_view import histogram
from stlc.output.solution import Solution, SpecResult
from stlc.replan.disturb import _event_samples, _waypoint_goal

ROOT = Path(__file__).resolve().parent.parent
POINT = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
mission east {
  vehicles = [p]
  horizon = 3 s
  step = 0.1 s
  spec go = eventually[0, 3] (p.pos.x >= GOAL m)
  spec low = always[0, 3] (p.pos.z <= 1 m)
  require go and low
  minimize -robustness
  replan { keep = [low]REPLAN }
}
"""


def write(tmp_path: Path, goal: float = 1, replan: str = "") -> Path:
    f = tmp_path / "p.stl"
    f.write_text(POINT.replace("GOAL", str(goal)).replace("REPLAN", replan))
    return f


def test_simulate_exits_3_when_the_nominal_plan_is_violated(tmp_path, capsys):
    f = write(tmp_path, goal=100)  # 100 m in 3 s at 1 m/s: no plan exists
    rc = main(["simulate", str(f), "-o", str(tmp_path / "o"), "-q", "--disturb",
               "1:0.2,0,0"])
    err = capsys.readouterr().err
    assert rc == 3
    # STL501 (no plan found) or, from the exact MILP backend, STL504 (no plan exists)
    assert ("error[STL501]" in err or "error[STL504]" in err) and "`go`" in err


def test_simulate_of_a_satisfied_plan_still_exits_0(tmp_path, capsys):
    f = write(tmp_path)
    assert main(["simulate", str(f), "-o", str(tmp_path / "o"), "-q", "--disturb",
                 "1:0.2,0,0"]) == 0


@pytest.mark.parametrize("argv", [
    ["simulate", "x.stl", "--fail", "uav1@5", "--fail", "uav2@6", "--backup", "uav3"],
    ["simulate", "x.stl", "--fail", "uav1@5", "--backup", "uav3", "--backup", "uav4"],
    ["compile", "x.stl", "--mission", "a", "--mission", "b"],
    ["compile", "x.stl", "-o", "a", "--out", "b"],
    ["risk", "x.stl", "--trajectory", "a.csv", "--trajectory", "b.csv"],
])
def test_a_repeated_single_option_is_a_usage_error(argv, capsys):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert "more than once" in capsys.readouterr().err


def test_repeatable_disturbances_are_all_kept(tmp_path):
    from stlc.cli import _parser

    a = _parser().parse_args(["simulate", "x.stl", "--disturb", "1:1,0,0", "--disturb",
                              "2:0,1,0"])
    assert [d.time for d in a.disturb] == [1.0, 2.0]


def test_an_unsatisfiable_spec_is_never_violated_by_inf(capsys):
    sol = Solution("m", "violated", -math.inf, -math.inf, {
        "refill": SpecResult(-math.inf, None, False, 0.0, "", 7)}, 0.0, np.arange(2),
        {"t": np.arange(2)})
    summary(sol, "out")
    err = capsys.readouterr().err
    assert "STL501" in err and "inf" not in err and not err.rstrip().endswith(":")


@pytest.mark.parametrize("value", [1e15, -1e15, 1e300, 0.0, 2.5])
def test_histograms_of_equal_values_of_any_size(value):
    rho = np.full(300, value)
    h = robustness_histogram(rho)
    assert sum(h["counts"]) == 300 and h["edges"][0] <= value <= h["edges"][-1]
    assert sum(histogram(rho)["counts"]) == 300


def test_risk_of_a_drone_far_away_exits_0(tmp_path, capsys):
    sit = (ROOT / "tests" / "test_assess.py").read_text().split('SIT_STL = """\\\n')[1]
    (tmp_path / "sit.stl").write_text(sit.split('"""')[0])
    rows = "".join(f"{k / 10:.1f},1e15,0,1,0,0,0\n" for k in range(11))
    (tmp_path / "far.csv").write_text("t,uav1.pos.x,uav1.pos.y,uav1.pos.z,uav1.vel.x,"
                                      "uav1.vel.y,uav1.vel.z\n" + rows)
    assert main(["risk", str(tmp_path / "sit.stl"), "--trajectory",
                 str(tmp_path / "far.csv"), "-o", str(tmp_path / "o")]) == 0


def test_event_instants_are_bounded_by_the_samples():
    assert _event_samples(1e-9, 4.0, 0.1, 41) == set(range(41))  # clamped: every sample
    assert _event_samples(0.5, 4.0, 0.1, 41) == set(range(0, 41, 5))
    assert _event_samples(1e300, 4.0, 0.1, 41) == {0}


@pytest.mark.parametrize("period", [1.0, 1e4, 1.2e11, 1e300])
def test_waypoint_goal_answers_for_any_period(period):
    t0 = time.perf_counter()
    g = _waypoint_goal(5, 3, period, 0.1, 40)
    assert time.perf_counter() - t0 < 0.1
    # brute force: the first waypoint ceil(j·T/dt) >= s + G, capped at the last sample
    want = next((w for j in range(1000) if (w := math.ceil(j * period / 0.1 - 1e-9)) >= 8),
                40)
    assert g == min(want, 40)


@pytest.mark.parametrize("period", ["1e4 s", "1e300 s"])
def test_a_huge_waypoint_period_replans_to_the_end_at_once(tmp_path, capsys, period):
    f = write(tmp_path, replan=f"; waypoint_period = {period}; threshold = 0.1 m")
    t0 = time.monotonic()
    rc = main(["simulate", str(f), "-o", str(tmp_path / "o"), "-q", "--disturb",
               "1:0.5,0,0"])
    assert rc in (0, 3), capsys.readouterr().err
    assert time.monotonic() - t0 < 60
    import json

    rj = json.loads((tmp_path / "o" / "replan.json").read_text())
    seg = [e["segment"] for e in rj["events"] if e["triggered"]][0]
    assert seg[1] == pytest.approx(3.0)  # the segment ends at the horizon


def test_a_17000_sample_multirotor_is_refused_before_building(tmp_path, capsys):
    src = (ROOT / "tests" / "missions" / "hexa_climb.stl").read_text()
    f = tmp_path / "h.stl"
    f.write_text(src.replace("step = 0.1 s", "step = 0.001 s")
                 .replace("horizon = 3 s", "horizon = 17 s")
                 .replace("always[0, 3]", "always[0, 17]"))
    t0 = time.monotonic()
    rc = main(["compile", str(f), "-o", str(tmp_path / "o"), "-q", "--max-memory", "8G"])
    err = capsys.readouterr().err
    assert rc == 1 and "error[STL606]" in err and "17,001 samples" in err
    assert "8 GB" in err and "coarser step" in err and f"{f}:" in err
    assert time.monotonic() - t0 < 20
    assert not (tmp_path / "o").exists()


def test_max_memory_moves_the_limit(tmp_path, capsys):
    from stlc import limits

    f = ROOT / "tests" / "missions" / "hexa_climb.stl"
    try:
        assert main(["compile", str(f), "-o", str(tmp_path / "o"), "-q",
                     "--max-memory", "100M"]) == 1
        assert "STL606" in capsys.readouterr().err
        with pytest.raises(SystemExit):
            main(["compile", str(f), "--max-memory", "lots"])
    finally:  # `main` sets the process's budget: 100 MB must not outlive this test
        limits.set_max_memory(None)


def test_risk_on_a_long_trace_stays_in_bounded_memory(tmp_path):
    sit = (ROOT / "tests" / "test_assess.py").read_text().split('SIT_STL = """\\\n')[1]
    sit = "\n".join(line for line in sit.split('"""')[0].replace("K = 400", "K = 50")
                    .splitlines() if not line.lstrip().startswith("case ")
                    or "case walking" in line)
    (tmp_path / "sit.stl").write_text(sit)
    n = 100_000  # windows of 1 s at 1e-5 s: every row is read by every realisation
    t = np.arange(n) * 1e-5
    cols = np.column_stack([t] + [np.full(n, v) for v in (1.5, 0, 1, 0, 0, 0)])
    np.savetxt(tmp_path / "long.csv", cols, delimiter=",", fmt="%.5f", comments="",
               header="t,uav1.pos.x,uav1.pos.y,uav1.pos.z,uav1.vel.x,uav1.vel.y,uav1.vel.z")
    code = ("import resource, sys\nfrom stlc.cli import main\nrc = main(sys.argv[1:])\n"
            "print('MAXRSS', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, "
            "file=sys.stderr)\nsys.exit(rc)")
    e = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-c", code, "risk", "sit.stl", "--trajectory",
                        "long.csv", "-o", "o"], cwd=tmp_path, env=e, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    peak_kb = int(r.stderr.split("MAXRSS")[1].split()[0])
    # 150 MB measured alone; once 736 MB inside a whole-suite run (not understood yet);
    # 5.3 GB before the chunks were bounded by the trace length (issue 23: below 1 GB)
    assert peak_kb < 1 << 20, peak_kb
