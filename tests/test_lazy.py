"""Checking a file does not import CasADi (issue 21: "no CasADi import until a plan is
asked for"): the vehicle models hold it through ``stlc.lazy``, and a plan loads it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

PROBE = """
import sys
import stlc
program = stlc.load("specs/handover.stl")
print("after load:", "casadi.casadi" in sys.modules)
import casadi
print("after use:", casadi.SX.sym("x").is_symbolic(), "casadi.casadi" in sys.modules)
"""


def test_load_does_not_import_casadi_and_a_use_does():
    r = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, capture_output=True,
                       text=True, timeout=120, env={"PYTHONPATH": str(ROOT),
                                                    "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    assert "after load: False" in r.stdout
    assert "after use: True True" in r.stdout


def test_lazy_of_a_missing_module_fails_as_an_import():
    import pytest

    from stlc.lazy import lazy

    with pytest.raises(ModuleNotFoundError):
        lazy("stlc_no_such_module_x")
