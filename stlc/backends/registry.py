"""The name → backend table (``registry()``) holding every backend behind the interface
``stlc.backends.base.Backend``.

``stlc.backends.strategy`` chooses a chain of them for a problem by their capabilities (or
the one a user forces with ``--backend NAME`` or a mission's ``backend = NAME``); the
replanning backends (``segment``, ``takeover``) are run by the simulation on each event's
problem.  See the README, "Adding a backend".
"""

from __future__ import annotations


def registry() -> dict[str, type]:
    from stlc.backends.replan.takeover import TakeoverBackend
    from stlc.backends.nlp.backend import CasadiNlp, KinematicGuess
    from stlc.backends.knots.backend import KnotNlp
    from stlc.backends.knots.timed import TimedNlp
    from stlc.backends.milp.backend import ExactMilp
    from stlc.backends.milp.path_seed import MilpPathSeed
    from stlc.backends.milp.start import CoarseStart
    from stlc.backends.replan.segment import SegmentBackend
    from stlc.backends.team.backend import MilpSeed, TeamRefine

    return {"milp": ExactMilp, "milp-start": CoarseStart, "kinematic": KinematicGuess,
            "seed-milp": MilpPathSeed, "casadi": CasadiNlp, "knots": KnotNlp,
            "timed": TimedNlp,
            "team-milp": MilpSeed, "team-refine": TeamRefine,
            # replanning backends, run by the simulation on an event's problem (no chain)
            "segment": SegmentBackend, "takeover": TakeoverBackend}
