"""Warnings on the command line: exit 0 and ``warning[STLWxx]`` on stderr; with
``--deny-warnings`` they are errors (exit 1); ``monitor`` warns about vacuous implications
on a trace (the fixture's hand-built log hovers on the gate's face from t = 0.5 s)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

FIX = Path(__file__).parent / "diagnostics"


def _run(*args):
    return subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True, timeout=120)


def test_check_warns_and_deny_makes_errors():
    f = str(FIX / "warn_precedence.stl")
    r = _run("check", f)
    assert r.returncode == 0 and "warning[STLW01]" in r.stderr and "1 warning" in r.stderr
    r = _run("check", "--deny-warnings", f)
    assert r.returncode == 1 and "error[STLW01]" in r.stderr


def test_monitor_warns_on_a_vacuous_implication():
    r = _run("monitor", str(FIX / "warn_vacuous_implication.stl"), "--trace",
             str(FIX / "warn_vacuous_implication.csv"))
    assert r.returncode == 0
    assert "warning[STLW02]" in r.stderr and "t = 0.5 s" in r.stderr
