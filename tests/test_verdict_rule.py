"""One verdict rule (``stlc.analysis.verdict``): satisfied iff ρ ≥ κ, κ the mission's
threshold, 0 for a spec outside a mission; ``monitor`` says which κ it used and
``--fail-on-violation`` applies the same rule as ``compile``."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from stlc.analysis import verdict
from stlc.analysis.risk import violation_drivers
from stlc.analysis.risk_measures import p_violation

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REACH = os.path.join(ROOT, "specs", "benchmarks", "reach_avoid.stl")


def _stlc(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=120)


def _hover_trace(path, x):
    """The robot hovers at (x, 8.5, 1) for 16 s: with goal x ∈ [7, 8], reach's ρ = 8 − x
    for 7.5 ≤ x ≤ 8 (by hand), inside ρ = 1 (z), avoid ρ = x − 5."""
    with open(path, "w") as fh:
        fh.write("t,robot.pos.x,robot.pos.y,robot.pos.z\n")
        for k in range(16):
            fh.write(f"{k},{x!r},8.5,1\n")


def test_rule_is_closed_at_kappa():
    assert verdict.satisfied(0.0) and verdict.satisfied(0.1, 0.1)
    assert not verdict.satisfied(0.0999, 0.1) and not verdict.satisfied(-1e-15)
    assert verdict.judge(float("nan")) is None and not verdict.satisfied(float("nan"))
    assert list(verdict.violated([-1.0, 0.0, 0.05, 0.1, math.nan], 0.1)) == \
        [True, True, True, False, True]
    for bad in (-0.1, math.inf, math.nan, "x"):
        with pytest.raises(ValueError, match="ρ ≥ κ"):
            verdict.satisfied(1.0, bad)


def test_monitor_uses_the_missions_threshold(tmp_path):
    trace = tmp_path / "ra.csv"
    _hover_trace(trace, 7.95)  # ρ = 0.05, 0 < ρ < κ = 0.1
    r = _stlc("monitor", REACH, "--trace", str(trace), "--json")
    assert r.returncode == 0, r.stderr
    specs = json.loads(r.stdout)["specs"]
    assert specs["reach_avoid"]["kappa"] == 0.1
    assert specs["reach_avoid"]["robustness"] == pytest.approx(0.05, abs=1e-12)
    assert specs["reach_avoid"]["satisfied"] is False
    assert specs["inside"]["satisfied"] is True
    r = _stlc("monitor", REACH, "--trace", str(trace), "--fail-on-violation")
    assert r.returncode == 3 and "κ" in r.stdout
    _hover_trace(trace, 7.85)  # ρ = 0.15 ≥ κ
    r = _stlc("monitor", REACH, "--trace", str(trace), "--fail-on-violation",
              "--mission", "reach_avoid")
    assert r.returncode == 0, r.stdout + r.stderr


def test_boundary_of_a_top_level_spec_is_satisfied(tmp_path):
    """A spec outside a mission has κ = 0 and ρ = 0 satisfies it, as ``compile`` does."""
    spec = tmp_path / "s.stl"
    spec.write_text("signal x\nspec low = always[0, 1] (x <= 1)\n")
    trace = tmp_path / "t.csv"
    trace.write_text("t,x\n0,0.5\n0.5,1\n1,1\n")
    r = _stlc("monitor", str(spec), "--trace", str(trace), "--json", "--fail-on-violation")
    assert r.returncode == 0, r.stdout + r.stderr
    low = json.loads(r.stdout)["specs"]["low"]
    assert low == {"robustness": 0.0, "satisfied": True, "kappa": 0.0}


def test_risk_counts_violations_below_kappa():
    rho = np.array([-0.2, 0.0, 0.05, 0.1, 0.3])
    assert p_violation(rho, 0.05)["count"] == 1  # κ = 0: only ρ < 0
    assert p_violation(rho, 0.05, 0.1)["count"] == 3
    d = violation_drivers(rho, {"a": rho, "b": rho + 1}, 0.1)
    assert d["a"]["count"] == 3 and d["b"]["count"] == 0
