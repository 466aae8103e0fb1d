"""Ownership of the output directory by record (issue 23, item 1): a user's file whose
name looks like stlc's (``trajectory.final.csv``) survives ``-o .`` for compile, simulate
and risk; stale outputs are removed only when the previous run's manifest lists them; and
SIGTERM / SIGHUP get Ctrl-C's contract (exit 143 / 129, stage folder removed, the old
outputs intact).  Point-mass missions: each solve takes a fraction of a second."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from stlc.output import directory

ROOT = Path(__file__).resolve().parent.parent
ONE = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
mission east {
  vehicles = [p]
  horizon = 3 s
  step = 0.1 s
  spec go = eventually[0, 3] (p.pos.x >= 1 m)
  spec low = always[0, 3] (p.pos.z <= 1 m)
  require go and low
  minimize -robustness
  replan { keep = [low] }
}
"""
USER = {"trajectory.final.csv": "t,x\n0,1\n", "trajectory.backup.csv": "mine\n",
        "trajectory.p.csv.bak": "mine too\n", "notes.txt": "notes\n"}


def env() -> dict[str, str]:
    e = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    e["PYTHONPATH"] = str(ROOT) + os.pathsep + e.get("PYTHONPATH", "")
    return e


def stlc(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stlc", *args], cwd=cwd, env=env(),
                          capture_output=True, text=True, timeout=300)


def test_user_files_matching_the_per_drone_pattern_survive_dot_output(tmp_path):
    (tmp_path / "one.stl").write_text(ONE)
    for name, text in USER.items():
        (tmp_path / name).write_text(text)
    r = stlc("compile", "one.stl", "-o", ".", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = stlc("simulate", "one.stl", "-o", ".", "-q", "--disturb", "1:0.3,0,0", cwd=tmp_path)
    assert r.returncode in (0, 3), r.stderr
    assert (tmp_path / "replan.json").is_file()
    r = stlc("risk", "one.stl", "--trajectory", "trajectory.csv", "-o", ".", cwd=tmp_path)
    assert r.returncode in (0, 1), r.stderr  # no risk cases: a diagnostic, nothing removed
    r = stlc("compile", "one.stl", "-o", ".", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for name, text in USER.items():
        assert (tmp_path / name).read_text() == text, name
    names = {p.name for p in tmp_path.iterdir()}
    assert not [n for n in names if n.startswith(directory.STAGE_PREFIX)]
    # the recompile removed simulate's recorded files, and only those
    assert "replan.json" not in names and "executed.csv" not in names
    rec = json.loads((tmp_path / directory.MANIFEST).read_text())["files"]
    assert set(rec) == {"report.html", "solution.json", "trajectory.csv"}


def _publish(out: Path, tmp_path: Path, files: dict[str, str], complete=True) -> list[str]:
    stage = Path(os.path.join(tmp_path, f"stage{len(list(tmp_path.iterdir()))}"))
    stage.mkdir()
    for name, text in files.items():
        (stage / name).write_text(text)
    return directory.publish(str(stage), str(out), complete)


def test_stale_files_are_removed_only_when_the_manifest_records_them(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "trajectory.final.csv").write_text("user")
    (out / "risk.json").write_text("user's, no manifest")  # never recorded: kept
    team = {"solution.json": "team", "trajectory.csv": "t", "trajectory.uav1.csv": "1",
            "trajectory.uav2.csv": "2"}
    assert _publish(out, tmp_path, team) == sorted(team)
    assert (out / "risk.json").read_text() == "user's, no manifest"
    _publish(out, tmp_path, {"risk.json": "r", "risk_samples.npz": "s"}, complete=False)
    assert set(directory.recorded(str(out))) == set(team) | {"risk.json", "risk_samples.npz"}
    _publish(out, tmp_path, {"solution.json": "single", "trajectory.csv": "t"})
    assert {p.name for p in out.iterdir()} == {"solution.json", "trajectory.csv",
                                               "trajectory.final.csv", directory.MANIFEST}


def test_a_forged_manifest_cannot_remove_anything_but_stlc_names(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for name in ("notes.txt", "sub.stl", "trajectory.csv"):
        (out / name).write_text("user")
    (out / directory.MANIFEST).write_text(json.dumps(
        {"files": ["notes.txt", "../x", "/etc/passwd", "sub.stl", 3]}))
    _publish(out, tmp_path, {"solution.json": "s"})
    assert (out / "notes.txt").exists() and (out / "sub.stl").exists()
    (out / directory.MANIFEST).write_text("{not json")
    _publish(out, tmp_path, {"solution.json": "s"})
    assert (out / "trajectory.csv").read_text() == "user"


@pytest.mark.parametrize("sig,code", [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_sigterm_and_sighup_get_ctrl_c_contract(tmp_path, sig, code):
    out = tmp_path / "out"
    out.mkdir()
    old = {n: f"previous {n}" for n in ("report.html", "solution.json", "trajectory.csv")}
    for name, text in old.items():
        (out / name).write_text(text)
    long = tmp_path / "hexa_long.stl"
    long.write_text((ROOT / "tests" / "missions" / "hexa_climb.stl").read_text()
                    .replace("horizon = 3 s", "horizon = 8 s")
                    .replace("step = 0.1 s", "step = 0.05 s")
                    .replace("always[0, 3]", "always[0, 8]")
                    .replace("eventually[0, 2] always[0, 1]", "eventually[0, 7] always[0, 1]"))
    p = subprocess.Popen([sys.executable, "-m", "stlc", "compile", str(long), "-o", str(out)],
                         env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in p.stderr:
        seen.append(line)
        if "] iter" in line:
            break
    t0 = time.monotonic()
    p.send_signal(sig)
    rest = p.stderr.read()
    p.wait(timeout=30)
    assert p.returncode == code, "".join(seen) + rest
    assert time.monotonic() - t0 < 5.0  # ~1.5 s idle; 2.8 s measured at load average 26
    assert f"signal {int(sig)}" in rest and "Traceback" not in rest
    assert {q.name: q.read_text() for q in out.iterdir()} == old  # no stage folder either
