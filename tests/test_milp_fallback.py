"""An exact MILP that stops without a satisfying plan (its time limit, no incumbent) hands
the mission to the general `nlp` chain (``strategy._fallback``): a point-mass mission too
large for the MILP's budget is still planned, the better verified plan is kept, and the
record says what ran.  A forced `--backend milp` never falls back."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from stlc import pipeline
from stlc.backends.milp import backend as milp_backend
from stlc.solvers.highs import Result
from stlc.solvers.status import SolverStatus

MISSION = Path(__file__).parent.parent / "specs" / "benchmarks" / "reach_avoid.stl"


def _stopped(self, low, problem):
    """What HiGHS returns when its time limit ends the search before any incumbent."""
    return Result(SolverStatus.MAX_TIME, None, float("inf"), -float("inf"), float("inf"), 0, 0.0,
                  "Time limit reached")


def _load():
    program = pipeline.load(str(MISSION)).program
    return program, next(iter(program.missions.values()))


def test_an_unconverged_exact_chain_falls_back_to_the_nlp(monkeypatch):
    monkeypatch.setattr(milp_backend.ExactMilp, "solve", _stopped)
    program, mission = _load()
    _, sol = pipeline.plan(program, mission)
    chain = sol.solver["chain"]
    assert chain["name"] == "nlp" and chain["fallback_from"]["name"] == "milp"
    assert chain["fallback_from"]["stages"][0]["converged"] is False
    # the kept plan is judged by the exact monitor, as every plan
    assert sol.status == "satisfied" and sol.robustness_exact >= mission_threshold(mission)
    assert any("local, not a global optimum" in n for n in sol.notes)


def test_a_forced_exact_chain_never_falls_back(monkeypatch):
    monkeypatch.setattr(milp_backend.ExactMilp, "solve", _stopped)
    program, mission = _load()
    _, sol = pipeline.plan(program, mission, backend="milp")
    assert sol.solver["chain"]["name"] == "milp" and "fallback_from" not in sol.solver["chain"]
    assert sol.status != "satisfied"


def test_a_converged_exact_chain_is_kept():
    program, mission = _load()
    _, sol = pipeline.plan(program, mission)
    assert sol.solver["chain"]["name"] == "milp" and "fallback_from" not in sol.solver["chain"]
    assert np.isclose(sol.robustness_exact, 0.5, atol=1e-6)  # ReachAvoid's optimum (by hand)


def mission_threshold(m) -> float:
    return float(m.threshold)
