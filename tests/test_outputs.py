"""The output-directory contract of ``stlc compile`` (issue 9, item 1) and Ctrl-C (item 2).

stlc writes only its own files into ``-o DIR``, never removes anything else, checks DIR
before solving (STL605, exit 1), replaces its files atomically, and concurrent runs on one
DIR end with one complete set.  Ctrl-C during a solve exits 130 within 2 s and leaves the
previous outputs as they were.  Missions are tiny point masses (a solve takes ~0.1 s).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import pytest

from stlc.cli import main
from stlc.diagnostics import Span, StlcError
from stlc.output import directory
from stlc.schemas import schema

ROOT = Path(__file__).resolve().parent.parent
OWN = {"report.html", "solution.json", "trajectory.csv", directory.MANIFEST}
FLIGHT = set(directory.FLIGHT_DIRS)  # the flight-stack folders (stlc.flight.export)
VEHICLE = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
"""


def mission(name: str, axis: str) -> str:
    return f"""
mission {name} {{
  vehicles = [p]
  horizon = 3 s
  step = 0.1 s
  spec go = eventually[0, 3] (p.pos.{axis} >= 1 m)
  require go
  minimize -robustness
}}
"""


TWO = VEHICLE + mission("east", "x") + mission("north", "y")


def env() -> dict[str, str]:
    e = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    e["PYTHONPATH"] = str(ROOT) + os.pathsep + e.get("PYTHONPATH", "")
    return e


@pytest.fixture
def two(tmp_path) -> Path:
    p = tmp_path / "two.stl"
    p.write_text(TWO, encoding="utf-8")
    return p


def test_unrelated_files_in_the_output_directory_survive(two, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "sub").mkdir()
    (out / "sub" / "deep.txt").write_text("also mine")
    assert main(["compile", str(two), "--mission", "east", "-o", str(out), "-q"]) == 0
    assert {p.name for p in out.iterdir()} == OWN | FLIGHT | {"notes.txt", "sub"}
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "sub" / "deep.txt").read_text() == "also mine"


def test_output_to_the_current_directory_keeps_the_mission_file(two, tmp_path):
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", "two.stl", "--mission", "east",
                        "-o", ".", "-q"], cwd=tmp_path, env=env(), capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert {p.name for p in tmp_path.iterdir()} == OWN | FLIGHT | {"two.stl"}
    assert two.read_text() == TWO


def test_stale_risk_outputs_of_an_earlier_run_are_removed_but_nothing_else(tmp_path):
    out = tmp_path / "out"
    stage = tmp_path / "stage"
    out.mkdir()
    stage.mkdir()
    for name in ("risk.json", "solution.json", "keep.json"):
        (out / name).write_text("old")
    (out / directory.MANIFEST).write_text('{"files": ["risk.json", "solution.json"]}')
    (stage / "solution.json").write_text("new")
    assert directory.publish(str(stage), str(out)) == ["solution.json"]
    assert {p.name: p.read_text() for p in out.iterdir()
            if p.name != directory.MANIFEST} == {"solution.json": "new", "keep.json": "old"}


@pytest.mark.parametrize("case", ["empty", "file", "inside_file", "owned_is_dir", "proc"])
def test_unusable_output_directory_is_stl605_before_solving(two, tmp_path, case, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    target = {"empty": "", "file": str(blocker), "inside_file": str(blocker / "sub"),
              "owned_is_dir": str(tmp_path / "o"), "proc": "/proc/stlc-cannot-create"}[case]
    if case == "owned_is_dir":
        (tmp_path / "o" / "report.html").mkdir(parents=True)
    one = ["--mission", "east"] if case == "owned_is_dir" else []  # else DIR/<mission>/
    t0 = time.process_time()
    rc = main(["compile", str(two), *one, "-o", target, "-q"])
    err = capsys.readouterr().err
    assert rc == 1 and "error[STL605]" in err
    assert f"{two}:" in err.splitlines()[0]  # located at the mission in the file
    assert time.process_time() - t0 < 2.0  # no solve happened
    assert blocker.read_text() == "x"


def test_preflight_creates_nothing(tmp_path):
    target = tmp_path / "a" / "b"
    directory.preflight(str(target), Span("f.stl", 1, 1, 1, 2))
    assert not (tmp_path / "a").exists()
    with pytest.raises(StlcError) as e:
        directory.preflight("", Span("f.stl", 3, 1, 3, 2))
    assert e.value.diagnostics[0].span.line == 3


def test_concurrent_compiles_to_one_directory_end_with_one_complete_set(two, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("keep")
    procs = [subprocess.Popen([sys.executable, "-m", "stlc", "compile", str(two), "--mission",
                               m, "-o", str(out), "-q"], env=env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
             for m in ("east", "north", "east", "north")]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    assert {p.name for p in out.iterdir()} == OWN | FLIGHT | {"keep.txt"}
    sol = json.loads((out / "solution.json").read_text())
    header = (out / "trajectory.csv").read_text().splitlines()[0]
    html = (out / "report.html").read_text()
    # one set: the trajectory is the plan of the mission solution.json names
    from stlc.analysis.trace import read_trace

    tr = read_trace(out / "trajectory.csv")
    axis = {"east": "p.pos.x", "north": "p.pos.y"}[sol["mission"]]
    assert header.startswith("t,")
    assert tr.channels[axis].max() == pytest.approx(1 + sol["robustness"]["exact"], abs=1e-6)
    assert sol["mission"] in html


def _interrupted_in_a_solve(tmp_path, out, *options):
    """``stlc compile`` of a long, slow solve, sent SIGINT at its first IPOPT progress line;
    returns (process after it ended, stderr before, stderr after, seconds it took to end)."""
    # hexa_climb stretched to 8 s at 0.05 s: a solve that lasts many seconds after its
    # first progress line (the 3 s original could finish before the signal arrived)
    long = tmp_path / "hexa_long.stl"
    long.write_text((ROOT / "tests" / "missions" / "hexa_climb.stl").read_text()
                    .replace("horizon = 3 s", "horizon = 8 s")
                    .replace("step = 0.1 s", "step = 0.05 s")
                    .replace("always[0, 3]", "always[0, 8]")
                    .replace("eventually[0, 2] always[0, 1]", "eventually[0, 7] always[0, 1]")
                    .replace("minimize 0.5 * energy - robustness", "maximize robustness"))
    # the robustness stage first (no energy objective: not the energy stage straight from
    # the seed), and a slow one: limited-memory Hessian, tol 1e-12, no acceptable exit —
    # its 200 iterations last ~9 s (with the exact Hessian it converged in 18, ~1 s, and a
    # loaded run ended before the signal came); no later stage may run
    slow = {"STLC_IPOPT": '{"ipopt.hessian_approximation": "limited-memory", '
                          '"ipopt.tol": 1e-12, "ipopt.acceptable_iter": 0}'}
    p = subprocess.Popen([sys.executable, "-m", "stlc", "compile", str(long), "-o", str(out),
                          *options], env={**env(), **slow}, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    seen = []
    for line in p.stderr:  # progress lines: interrupt inside IPOPT's iterations
        seen.append(line)
        if "] iter" in line:
            break
    assert any("] iter" in s for s in seen), "".join(seen)
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    rest = p.stderr.read()
    p.wait(timeout=60)
    return p, "".join(seen), rest, time.monotonic() - t0


def test_ctrl_c_during_a_solve_exits_130_at_once_and_keeps_old_outputs(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    old = {name: f"previous {name}" for name in OWN - {directory.MANIFEST}}
    for name, text in old.items():
        (out / name).write_text(text)
    p, seen, rest, elapsed = _interrupted_in_a_solve(tmp_path, out)
    assert p.returncode == 130, seen + rest
    assert elapsed < 2.0
    assert "interrupted" in rest and "energy" not in rest  # no later stage ran
    assert {q.name: q.read_text() for q in out.iterdir()} == old


def test_ctrl_c_with_keep_on_interrupt_writes_the_best_verified_plan(tmp_path):
    """``--keep-on-interrupt``: the first Ctrl-C stops the search as a time limit does; the
    best verified plan is written (judged by the exact monitor, saying it was interrupted)
    and the command exits 130.  The same slow solve as above."""
    out = tmp_path / "out"
    p, seen, rest, elapsed = _interrupted_in_a_solve(tmp_path, out, "--no-risk",
                                                     "--keep-on-interrupt")
    assert p.returncode == 130, seen + rest
    assert elapsed < 15.0
    assert "the best verified plan found is in" in rest and "energy:" not in rest
    sol = json.loads((out / "solution.json").read_text())
    assert any(n.startswith("stopped by Ctrl-C") for n in sol["notes"])
    assert sol["solver"]["stopped_by"] == "interrupted" and sol["solver"]["converged"] is False
    assert not any("time limit" in n for n in sol["notes"])
    jsonschema.validate(sol, schema("solution"))
    jsonschema.validate({**sol, "status": "stopped"}, schema("solution"))  # a stopped run
    # what is written is what the exact monitor says of the written trajectory
    r = subprocess.run([sys.executable, "-m", "stlc", "monitor", str(tmp_path / "hexa_long.stl"),
                        "--trace", str(out / "trajectory.csv"), "--mission", "climb", "--json"],
                       env=env(), capture_output=True, text=True, timeout=60)
    specs = json.loads(r.stdout)["specs"]
    assert specs["climb"]["robustness"] == pytest.approx(sol["robustness"]["exact"], abs=1e-9)
