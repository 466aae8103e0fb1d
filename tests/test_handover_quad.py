"""An underactuated quadrotor handover (``tests/missions/handover_quad.stl``: the operator
moved and turned 90°, the start beside the no-fly region behind the operator, the
visibility box on the far side, a mast on the way): the ``timed`` chain plans it from its
MILP seed (its timing kept) to a plan the exact monitor finds satisfied, with the dynamics
met."""

from __future__ import annotations

from pathlib import Path

from stlc import pipeline

MISSION = Path(__file__).parent / "missions" / "handover_quad.stl"


def test_the_quadrotor_handover_is_planned_satisfied():
    program = pipeline.load(str(MISSION)).program
    mission = program.missions["quad_turned"]
    _, sol = pipeline.plan(program, mission)
    stages = sol.solver["chain"]["stages"]
    assert [s["backend"] for s in stages] == ["timed nlp"]
    assert stages[0]["seed"]["status"] == "Optimal"  # the MILP seed's path
    assert sol.status == "satisfied" and sol.feasible
    assert sol.robustness_exact >= mission.threshold
    assert all(s.satisfied for s in sol.specs.values())
