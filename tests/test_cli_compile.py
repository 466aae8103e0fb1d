"""``stlc compile`` as users run it: outputs, the solution.json contract, trajectory.csv,
quiet mode, exit codes, several missions, nothing written on bad input; and a smoke test of
``stlc bench compile``.

The plans are re-checked independently: trajectory.csv is read back as a trace and the
exact monitor re-evaluates the mission's requirement on it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from stlc.analysis import monitor
from stlc.analysis.trace import read_trace
from stlc.cli import main
from stlc.pipeline import load
from stlc.semantics import nnf

ROOT = Path(__file__).resolve().parent.parent
SPECS = ROOT / "specs"
CLIMB = ROOT / "tests" / "missions" / "hexa_climb.stl"
OUTPUTS = {"report.html", "solution.json", "trajectory.csv", ".stlc-outputs.json",
           "flight", "rosbag2"}  # the flight-stack folders (stlc.flight.export)

POINT_MASS = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
"""


def mission(name: str, require: str, horizon: float = 3.0) -> str:
    return f"""
mission {name} {{
  vehicles = [p]
  horizon = {horizon:g} s
  step = 0.1 s
  end = free
  spec go = {require}
  require go
  minimize -robustness
}}
"""


#: reach x ≥ 2 m by 3 s: optimal robustness 0.75 (0.5 s at 2 m/s², then 1 m/s)
REACH = POINT_MASS + mission("reach", "eventually[0, 3] (p.pos.x >= 2 m)")
#: x ≥ 100 m by 3 s at ≤ 1 m/s: impossible, the best is 2.75 - 100 = -97.25
FAR = POINT_MASS + mission("far", "eventually[0, 3] (p.pos.x >= 100 m)")
FAR_GO_LINE = next(i for i, line in enumerate(FAR.splitlines(), 1) if "spec go" in line)
#: two satisfiable missions in one file
TWO = POINT_MASS + mission("east", "eventually[0, 3] (p.pos.x >= 1 m)") + mission(
    "north", "eventually[0, 3] (p.pos.y >= 1 m)")


def write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def files(d: Path) -> set[str]:
    return {p.name for p in d.iterdir()}


def recheck(stl: Path, outdir: Path, mission_name: str) -> tuple[float, dict]:
    """Exact robustness of the mission's requirement on the written trajectory.csv, and
    the solution.json it should agree with."""
    program = load(str(stl)).program
    trace = read_trace(outdir / "trajectory.csv")
    f = nnf.normalize(program.missions[mission_name].requirement)
    r = float(monitor.robustness(f, trace.dt, trace.channels, program.params))
    return r, json.loads((outdir / "solution.json").read_text(encoding="utf-8"))


def assert_contract(sol: dict, mission_name: str, spec_names: set[str]) -> None:
    assert sol["mission"] == mission_name
    assert sol["status"] in ("satisfied", "violated", "solver_failed", "infeasible")
    assert isinstance(sol["robustness"]["exact"], float)
    assert isinstance(sol["robustness"]["smooth"], float)
    assert set(sol["specs"]) == spec_names
    for s in sol["specs"].values():
        assert isinstance(s["robustness"], float)
        # satisfied means margin ≥ the declared threshold κ, not merely ≥ 0
        assert s["satisfied"] == (s["robustness"] >= sol["smoothing"]["threshold"])
    # energy: J for vehicles with an energy model, null ("not computed") for point masses
    assert sol["energy"] is None or isinstance(sol["energy"], float)
    for key in ("parse_s", "check_s", "build_s", "solve_s", "total_s"):
        assert sol["timing"][key] >= 0.0, key
    assert sol["timing"]["total_s"] >= sol["timing"]["solve_s"]
    assert sol["solver"]["name"]
    assert isinstance(sol["solver"]["iterations"], int) and sol["solver"]["iterations"] > 0
    assert isinstance(sol["solver"]["return_status"], str)


# ---------------------------------------------------------------- a multirotor, as a process


@pytest.fixture(scope="module")
def climb(tmp_path_factory):
    """``python -m stlc compile hexa_climb.stl -o OUT -q`` in a real process."""
    out = tmp_path_factory.mktemp("climb") / "out"
    env = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(CLIMB), "-o", str(out),
                        "-q"], capture_output=True, text=True, env=env, timeout=300)
    return r, out


def test_quiet_satisfied_compile_prints_nothing_and_exits_0(climb):
    r, out = climb
    assert r.returncode == 0, r.stderr
    assert r.stdout == "" and r.stderr == ""


def test_compile_writes_exactly_the_three_outputs(climb):
    r, out = climb
    assert files(out) == OUTPUTS
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".stlc-")]
    html = (out / "report.html").read_text(encoding="utf-8")
    assert html.lstrip().lower().startswith("<!doctype html")
    assert "climb" in html


def test_solution_json_contract(climb):
    r, out = climb
    sol = json.loads((out / "solution.json").read_text(encoding="utf-8"))
    assert_contract(sol, "climb", {"stay", "reach"})
    assert sol["status"] == "satisfied"
    assert sol["robustness"]["exact"] > 0
    # GKL is sound
    assert sol["robustness"]["smooth"] <= sol["robustness"]["exact"] + 1e-9
    # the requirement is `stay and reach`
    assert sol["robustness"]["exact"] == pytest.approx(
        min(s["robustness"] for s in sol["specs"].values()), abs=1e-9)
    assert sol["energy"] > 0  # a multirotor spends energy hovering
    assert sol["problem_size"]["samples"] == 31


def test_trajectory_csv_has_every_channel(climb):
    r, out = climb
    header = (out / "trajectory.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header[0] == "t"
    v = load(str(CLIMB)).program.vehicles["uav1"]
    n_rotors = len(v.rotors)
    assert n_rotors == 6
    expected = [f"uav1.{f}.{a}" for f in ("pos", "att", "vel", "rate") for a in "xyz"]
    expected += [f"uav1.force.{i}" for i in range(1, n_rotors + 1)]
    expected += [f"uav1.dforce.{i}" for i in range(1, n_rotors + 1)]
    expected += [f"uav1.rotor_speed.{i}" for i in range(1, n_rotors + 1)]
    assert set(expected) <= set(header)
    assert len(header) == len(set(header))
    trace = read_trace(out / "trajectory.csv")
    assert trace.n == 31 and trace.dt == pytest.approx(0.1)
    # rotor speed (Hz) is √(ξ / c_f)
    for i in range(1, n_rotors + 1):
        xi = trace.channels[f"uav1.force.{i}"]
        hz = trace.channels[f"uav1.rotor_speed.{i}"]
        assert hz == pytest.approx((xi / v.c_f) ** 0.5, rel=1e-6)


def test_trajectory_csv_rechecks_to_the_reported_robustness(climb):
    r, out = climb
    exact, sol = recheck(CLIMB, out, "climb")
    assert exact == pytest.approx(sol["robustness"]["exact"], abs=1e-6)


# ---------------------------------------------------------------- point masses, in process


def test_point_mass_compile_and_recheck(tmp_path, capsys):
    stl = write(tmp_path, "reach.stl", REACH)
    out = tmp_path / "out"
    assert main(["compile", str(stl), "-o", str(out), "-q"]) == 0
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == ""
    assert files(out) == OUTPUTS
    exact, sol = recheck(stl, out, "reach")
    assert_contract(sol, "reach", {"go"})
    assert sol["status"] == "satisfied"
    assert exact == pytest.approx(sol["robustness"]["exact"], abs=1e-6)
    assert 0.70 <= exact <= 0.75 + 1e-6  # the optimum is 0.75
    header = (out / "trajectory.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header[0] == "t"
    assert {f"p.{f}.{a}" for f in ("pos", "vel", "acc") for a in "xyz"} <= set(header)


def test_progress_goes_to_stderr_without_quiet(tmp_path, capsys):
    stl = write(tmp_path, "reach.stl", REACH)
    assert main(["compile", str(stl), "-o", str(tmp_path / "out")]) == 0
    cap = capsys.readouterr()
    assert "reach: satisfied" in cap.out
    assert "chain `milp`" in cap.err  # a point mass: the exact MILP, chosen by capability
    assert main(["compile", str(stl), "-o", str(tmp_path / "out2"), "--backend", "nlp"]) == 0
    cap = capsys.readouterr()
    assert "chain `nlp` (forced)" in cap.err
    assert "iter" in cap.err and "exact" in cap.err


def test_unsatisfiable_mission_exits_3_and_still_reports(tmp_path, capsys):
    stl = write(tmp_path, "far.stl", FAR)
    out = tmp_path / "out"
    assert main(["compile", str(stl), "-o", str(out), "-q"]) == 3
    cap = capsys.readouterr()
    # even with -q the failure is explained: x ≥ 100 m in 3 s is proved impossible
    assert "far: no plan exists (proved; best attempt: exact ρ = -97.2500 < κ = 0)" in cap.out
    assert cap.err.count("no plan can satisfy mission `far`") == 1  # said once
    assert "error[STL504]: no plan can satisfy mission `far`: spec `go` cannot hold" in cap.err
    assert files(out) == OUTPUTS
    exact, sol = recheck(stl, out, "far")
    assert_contract(sol, "far", {"go"})
    assert sol["status"] == "infeasible" and sol["conflict"] == ["go"]
    assert sol["robustness"]["exact"] < 0
    assert exact == pytest.approx(sol["robustness"]["exact"], abs=1e-6)
    assert exact == pytest.approx(-97.25, abs=0.05)
    go = sol["specs"]["go"]
    assert go["satisfied"] is False and go["line"] == FAR_GO_LINE
    assert go["binding_predicate"].startswith("p.pos.x >= 100")
    assert go["tightest_time"] == pytest.approx(3.0)
    html = (out / "report.html").read_text(encoding="utf-8")
    # the report's failure banner names the spec, the time and the binding predicate
    banner = html[html.index('id="failure"'):]
    banner = banner[:banner.index("</section>")]
    assert "No plan exists" in banner and "`go`" in banner


def test_unsatisfiable_mission_as_a_process(tmp_path):
    write(tmp_path, "far.stl", FAR)
    env = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", "far.stl", "-o", "out", "-q"],
                       cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 3
    assert "Traceback" not in r.stderr
    assert "error[STL504]" in r.stderr
    assert files(tmp_path / "out") == OUTPUTS


def test_two_missions_without_mission_flag_write_a_directory_each(tmp_path, capsys):
    stl = write(tmp_path, "two.stl", TWO)
    out = tmp_path / "out"
    assert main(["compile", str(stl), "-o", str(out), "-q"]) == 0
    assert files(out) == {"east", "north"}
    for name in ("east", "north"):
        assert files(out / name) == OUTPUTS
        exact, sol = recheck(stl, out / name, name)
        assert sol["mission"] == name and sol["status"] == "satisfied"
        assert exact == pytest.approx(sol["robustness"]["exact"], abs=1e-6)
        assert 1.70 <= exact <= 1.75 + 1e-6  # 2.75 m reachable, 1 m required


def test_mission_flag_writes_only_that_mission_into_outdir(tmp_path):
    stl = write(tmp_path, "two.stl", TWO)
    out = tmp_path / "out"
    assert main(["compile", str(stl), "-o", str(out), "-q", "--mission", "north"]) == 0
    assert files(out) == OUTPUTS
    assert json.loads((out / "solution.json").read_text())["mission"] == "north"


def test_one_violated_mission_of_two_exits_3(tmp_path, capsys):
    stl = write(tmp_path, "mixed.stl", POINT_MASS + mission("ok", "eventually[0, 3] "
                "(p.pos.x >= 1 m)") + mission("bad", "eventually[0, 3] (p.pos.x >= 100 m)"))
    out = tmp_path / "out"
    assert main(["compile", str(stl), "-o", str(out), "-q"]) == 3
    assert files(out) == {"ok", "bad"}
    assert json.loads((out / "ok" / "solution.json").read_text())["status"] == "satisfied"
    assert json.loads((out / "bad" / "solution.json").read_text())["status"] == "infeasible"
    assert "spec `go`" in capsys.readouterr().err


TEAM_SMALL = (Path(__file__).parent / "missions" / "team_small.stl").read_text()

BAD_INPUTS = {
    "syntax": ("bad.stl", POINT_MASS + "mission m {\n  horizon = 3 s\n  require p.pos.x >=\n}\n",
               None, None),
    "unit": ("unit.stl", POINT_MASS.replace("(1, 1, 1) m/s", "(1, 1, 1) m"), None, "STL204"),
    "unknown_mission": ("reach.stl", REACH, "nope", "STL101"),
    "no_mission": (str(SPECS / "monitor_example.stl"), None, None, "STL109"),
    # 3 targets, 2 drones carrying one diverter each and no refilling station: no
    # assignment exists, a located STL503 before any trajectory is planned
    "no_assignment": ("team.stl", TEAM_SMALL.replace("capacity = 2", "capacity = 1")
                      .replace("  station s1", "  # s1").replace("  station s2", "  # s2"),
                      None, "STL212"),  # `exists s in stations` with none: at check time
    "missing_file": ("missing.stl", None, None, "STL601"),
}


@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_input_exits_1_and_writes_nothing(tmp_path, capsys, case):
    name, text, mission_name, code = BAD_INPUTS[case]
    path = write(tmp_path, name, text) if text is not None else (
        Path(name) if os.path.isabs(name) else tmp_path / name)
    work = tmp_path / "work"
    work.mkdir()
    out = work / "out"
    argv = ["compile", str(path), "-o", str(out)]
    if mission_name:
        argv += ["--mission", mission_name]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err
    assert "error[STL" in err
    if code:
        assert f"error[{code}]" in err
    assert list(work.iterdir()) == []  # no output, no temporary directory


def test_usage_error_exits_2(capsys):
    with pytest.raises(SystemExit) as e:
        main(["compile"])
    assert e.value.code == 2


# ---------------------------------------------------------------- stlc bench compile


def test_bench_compile_smoke(tmp_path, capsys):
    stl = write(tmp_path, "two.stl", TWO)
    assert main(["bench", "compile", str(stl), "--mission", "east", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    head = next(line for line in lines if line.startswith("mission "))
    for col in ("samples", "variables", "constraints", "build s", "guess s", "solve s",
                "total s", "iterations", "exact ρ", "smooth ρ", "energy J", "/ paper 660 s"):
        assert col in head, col
    rows = [line.split() for line in lines if line.startswith("east ")]
    # the summary, one row per solve stage (here: one robustness stage, then the point
    # mass's smoothing stage, ``nlp.smoothing``), the IPOPT split
    assert len(rows) == 4 and rows[2][1] == "smooth"
    stage = rows[1]
    assert stage[1].startswith("robustness") and stage[5] in ("yes", "no") and int(stage[3]) > 0
    assert int(stage[6]) >= 0  # iterations with Hessian regularisation
    assert "converged" in out and "regularised" in out and "CPU s" in head
    assert rows[0][1] == "31"  # samples: 3 s at 0.1 s
    assert int(rows[0][2]) >= 6 * 31 + 3 * 30  # variables: states, inputs, aux
    assert float(rows[0][10]) > 0  # exact robustness
    assert "hess_l" in out and "rest (lin. alg. + IPOPT)" in out
    assert "north" not in out


def test_bench_compile_bad_input_exits_1(tmp_path, capsys):
    from stlc import bench

    stl = write(tmp_path, "reach.stl", REACH)
    assert bench.main(["compile", str(stl), "--mission", "nope", "--repeats", "1"]) == 1
    assert bench.main(["compile", str(SPECS / "monitor_example.stl")]) == 1


def test_bench_monitor_still_works(capsys):
    from stlc import bench

    assert bench.main(["monitor", "--samples", "500", "--repeats", "20"]) == 0
    assert "exact monitor" in capsys.readouterr().out


# ---------------------------------------------------------------- the threshold contract


def test_margin_short_of_the_threshold_is_not_satisfied(tmp_path, capsys):
    """``satisfied`` means exact robustness ≥ κ.  The shelf of hexa_climb.stl is 0.4 m tall
    (half-width 0.2 m), so κ = 0.3 m cannot be met: the plan is reported violated (exit 3),
    solution.json says so and why, and stderr names the spec whose margin fell short."""
    text = CLIMB.read_text(encoding="utf-8").replace("step = 0.1 s",
                                                     "step = 0.1 s\n  threshold = 0.3")
    stl = write(tmp_path, "climb_k.stl", text)
    out = tmp_path / "out"
    assert main(["compile", str(stl), "-o", str(out), "-q"]) == 3
    sol = json.loads((out / "solution.json").read_text(encoding="utf-8"))
    exact = sol["robustness"]["exact"]
    # the relaxation (a double integrator with the hexarotor's acceleration box) proves it
    assert sol["status"] == "infeasible" and exact < 0.3 and sol["conflict"] == ["reach"]
    assert sol["smoothing"]["threshold"] == 0.3
    assert all(s["satisfied"] == (s["robustness"] >= 0.3) for s in sol["specs"].values())
    assert isinstance(sol["solver"]["converged"], bool)
    err = capsys.readouterr().err
    assert "error[STL504]" in err and "spec `reach` cannot hold with margin κ = 0.3" in err
    if exact >= 0:
        assert any("margin fell short" in n for n in sol["notes"])
