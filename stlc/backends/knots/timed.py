"""A multirotor's mission on its own grid, planned with the seed's timing kept.

The ``nlp`` chain's NLP decides *when* as well as *where*: every ``eventually`` and
``until`` of the requirement is a smooth max over its whole window, a tree of auxiliary
variables that makes each IPOPT iteration dearer and the kinematic guess slower.  The MILP
seed has already chosen those times globally.  ``TimedNlp`` plans with them kept, as the
long-mission planner (``knots``) does, on the mission grid itself (no knots):

1. the MILP seed's path (``MilpPathSeed(smooth=False)``, run in this process), or its
   proof that no plan exists;
2. ``windows.fix_windows`` narrows every window needed at one sample to the seed's sample
   ± ``TIMING_SLACK_S`` (an ``or`` to its most robust operand): each rewrite keeps a subset
   of the terms of a max, so the narrowed formula is never more robust than the requirement;
3. the kinematic guess and the full-dynamics NLP on the narrowed formula, from that path:
   as in the ``nlp`` chain, the guess runs in a forked child while the NLP is built, and
   beside it the MILP with its choices free looks for a better class, from which the guess
   runs again (on a two-drone mission it swapped a crossing assignment for the direct one).

The slack lets the kinematic guess and the NLP still move each time a little, which keeps
the energy of the plan with the windows as written (closed on the seed's sample, paper A's
handovers used 0.07–0.45 % more energy).  The exact monitor judges the plan against the
requirement as written, as every plan.  A plan that misses κ is planned again by the ``nlp``
chain (``strategy``), which decides the times itself and tries further seeds.  Without a
MILP path that reaches κ there is no timing worth keeping: the plan is then the ``nlp``
chain's first plan (the formula as written from the seed), and the strategy tries only its
further seeds.
"""

from __future__ import annotations

from stlc.backends.base import Capabilities, ALL_FUNCTIONS, ALL_NODES
from stlc.backends.knots.backend import LONG_SAMPLES, KnotNlp
from stlc.diagnostics import Diagnostic
from stlc.planning.problem import PlanningProblem

TIMING_SLACK_S = 0.5  #: how far (s) a window may move from the seed's sample


class TimedNlp(KnotNlp):
    name = "timed nlp"
    capabilities = Capabilities(vehicle_models=frozenset({"multirotor"}),
                                nodes=ALL_NODES, functions=ALL_FUNCTIONS)
    SLACK = TIMING_SLACK_S
    FREE = "later"  #: the MILP's search for a better class runs beside the kinematic guess
    KEPT_NOTE = (f"planned with the seed's timing kept: every window needed at one sample "
                 f"narrowed to the seed's sample ± {TIMING_SLACK_S:g} s")

    def accepts(self, problem: PlanningProblem) -> list[Diagnostic]:
        from stlc.backends.base import unsupported

        diags = unsupported(self, problem)
        if diags:
            return diags
        if problem.grid.n > LONG_SAMPLES:
            return [Diagnostic("STL401", f"mission `{problem.name}` has {problem.grid.n} "
                               f"samples: planned on knots", problem.mission.span)]
        return []

    def factor(self, problem: PlanningProblem) -> int:
        return 1

    def keeps(self, problem: PlanningProblem, path) -> bool:
        """Only the timing of a MILP path that reaches κ: without one (no path, or a path
        at a bound below κ: a mission that is hard or impossible) the plan is the ``nlp``
        chain's, and the strategy tries its further seeds."""
        rec = path.solver.get("seed") or {}
        return "fallback" not in rec and rec.get("robustness", -1.0) >= problem.threshold
