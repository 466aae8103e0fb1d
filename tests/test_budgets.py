"""Budgets before allocation (issue 23, item 2): input files are read with a size limit,
quantifier expansion is bounded, and a planning problem's size is estimated from the
checked program and refused (STL606, located, with the estimate, the limit and what to
change) before anything is built.  Every refusal here answers in seconds."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest

from stlc import limits
from stlc.cli import main

ROOT = Path(__file__).resolve().parent.parent


def env() -> dict[str, str]:
    e = {k: v for k, v in os.environ.items() if k != "STLC_DEBUG"}
    e["PYTHONPATH"] = str(ROOT) + os.pathsep + e.get("PYTHONPATH", "")
    return e


def run_capped(args: list[str], cwd: Path, mem: int = 1 << 30, timeout: float = 120):
    """``python -m stlc ARGS`` with an address-space cap (an allocation past it fails
    instead of growing until the OOM killer) and a time limit."""
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (mem + (2 << 30), mem + (2 << 30)))

    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "stlc", *args], cwd=cwd, env=env(),
                       capture_output=True, text=True, timeout=timeout, preexec_fn=cap)
    return r, time.monotonic() - t0


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
  spec go = eventually[0, 3] (p.pos.x >= 1 m)
  require go
  minimize -robustness
}
"""


@pytest.mark.parametrize("cmd", ["check", "monitor", "compile", "simulate"])
def test_a_symlink_to_dev_zero_is_stl601_at_once(tmp_path, cmd):
    (tmp_path / "zero.stl").symlink_to("/dev/zero")
    (tmp_path / "zero.csv").symlink_to("/dev/zero")
    (tmp_path / "ok.stl").write_text(POINT)
    args = {"check": ["check", "zero.stl"], "compile": ["compile", "zero.stl"],
            "monitor": ["monitor", "ok.stl", "--trace", "zero.csv"],
            "simulate": ["simulate", "zero.stl", "--disturb", "1:1,0,0"]}[cmd]
    r, dt = run_capped(args, tmp_path)
    assert r.returncode == 1, r.stderr
    assert "error[STL601]" in r.stderr and "larger than the limit" in r.stderr
    assert r.stderr.startswith("zero.")  # located: file:1:1
    assert dt < 30 and "Traceback" not in r.stderr


def test_a_huge_sparse_file_is_refused_after_reading_the_limit(tmp_path, capsys):
    big = tmp_path / "big.stl"
    with open(big, "wb") as fh:
        fh.truncate(1 << 30)  # 1 GB (sparse)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    assert main(["check", str(big)]) == 1
    err = capsys.readouterr().err
    assert f"{big}:1:1: error[STL601]" in err and "4 MB" in err
    # the process grew by about the limit, not the file (ru_maxrss is in kB)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 64 << 10


def test_read_limited_reads_exactly_up_to_the_limit(tmp_path):
    f = tmp_path / "f"
    f.write_bytes(b"x" * 100)
    assert limits.read_limited(str(f), 100, "file", "") == b"x" * 100
    with pytest.raises(limits.StlcError):
        limits.read_limited(str(f), 99, "file", "")


def quantified(n: int, depth: int = 4) -> str:
    vehicles = "".join(f"vehicle v{i} : point_mass {{\n  vel_max = (1, 1, 1) m/s\n"
                       f"  acc_max = (2, 2, 2) m/s^2\n  start {{ pos = ({i}, 0, 0) m }}\n}}\n"
                       for i in range(n))
    names = "abcdefgh"[:depth]
    body = " + ".join(f"dist({a}.pos, {b}.pos)" for a, b in zip(names[::2], names[1::2]))
    quant = "".join(f"forall {x} in team: " for x in names)
    return (vehicles + "mission m {\n  vehicles = [" + ", ".join(f"v{i}" for i in range(n))
            + "]\n  horizon = 2 s\n  step = 0.1 s\n"
            + f"  spec s = {quant}always[0, 1] ({body} >= 0 m)\n  require s\n"
            + "  minimize -robustness\n}\n")


def test_quantifier_explosion_is_stl606_in_seconds(tmp_path):
    (tmp_path / "q.stl").write_text(quantified(60))  # 60^4 ≈ 13 million instances
    r, dt = run_capped(["check", "q.stl"], tmp_path)
    assert r.returncode == 1 and "error[STL606]" in r.stderr, r.stderr
    assert "q.stl:" in r.stderr.splitlines()[0] and "limit 50,000" in r.stderr
    assert dt < 60


def test_quantifier_instances_below_the_limit_still_expand(tmp_path, capsys):
    (tmp_path / "q.stl").write_text(quantified(6, 2))  # 36 instances
    assert main(["check", str(tmp_path / "q.stl")]) == 0
