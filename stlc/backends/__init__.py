"""Solver backends behind one interface (``stlc.backends.base.Backend``).

``registry()`` is the name → backend table holding every backend; ``stlc.backends.select``
chooses a chain of them for a problem by their capabilities (or the one a user forces with
``--backend NAME`` or a mission's ``backend = NAME``); the replanning backends (``segment``,
``takeover``) are run by the simulation on each event's problem.  See the README, "Adding a
backend".
"""

from __future__ import annotations


def registry() -> dict[str, type]:
    from stlc.backends.backup import TakeoverBackend
    from stlc.backends.casadi_backend import CasadiNlp, KinematicGuess
    from stlc.backends.knots import KnotNlp
    from stlc.backends.milp_backend import ExactMilp
    from stlc.backends.milp_seed import MilpPathSeed
    from stlc.backends.milp_start import CoarseStart
    from stlc.backends.segment import SegmentBackend
    from stlc.backends.team_backend import MilpSeed, TeamRefine

    return {"milp": ExactMilp, "milp-start": CoarseStart, "kinematic": KinematicGuess,
            "seed-milp": MilpPathSeed, "casadi": CasadiNlp, "knots": KnotNlp,
            "team-milp": MilpSeed, "team-refine": TeamRefine,
            # replanning backends, run by the simulation on an event's problem (no chain)
            "segment": SegmentBackend, "takeover": TakeoverBackend}
