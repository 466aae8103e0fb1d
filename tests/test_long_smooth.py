"""The exact MILP's plan is the smoothest of its most robust plans (``backends.milp.jerk``): the
same exact robustness as the MILP's vertex plan, and no more jerk (L1 of the acceleration's
changes) — both measured on the written plans, by the exact monitor and by hand."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stlc import pipeline
from stlc.backends.milp import jerk

ROOT = Path(__file__).resolve().parent.parent


def _jerk(sol, name: str) -> float:
    A = np.array([sol.channels[f"{name}.acc.{a}"] for a in "xyz"])[:, :-1]
    return float(np.abs(np.diff(A, axis=1)).sum())


def test_least_jerk_keeps_robustness_and_smooths(monkeypatch):
    program = pipeline.load(str(ROOT / "specs" / "benchmarks" / "reach_avoid.stl")).program
    mission = next(iter(program.missions.values()))
    _, smooth = pipeline.plan(program, mission, backend="milp")
    monkeypatch.setattr(jerk, "least_jerk", lambda low, res, phases=None: res)
    _, vertex = pipeline.plan(program, mission, backend="milp")
    assert smooth.status == vertex.status == "satisfied"
    assert smooth.robustness_exact == pytest.approx(vertex.robustness_exact, abs=1e-7)
    name = mission.vehicles[0]
    assert _jerk(smooth, name) <= _jerk(vertex, name) + 1e-6
    assert _jerk(smooth, name) < 0.9 * _jerk(vertex, name)  # measurably smoother
