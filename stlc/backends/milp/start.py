"""A coarse-grid start for the exact MILP: the first backend of the ``milp`` chain.

The exact MILP of a long mission on a fine grid has thousands of binaries; HiGHS may search
for its whole budget without finding any plan (the 60 s patrol at 0.2 s: 19 k binaries, no
incumbent in 120 s).  The same mission on a coarse grid (``milp.seed.seed_factor``: every
window of the formula still falls on its samples, at most 61 of them) is a MILP of a few
hundred binaries that HiGHS solves in seconds.

``CoarseStart`` solves that coarse MILP (``milp.seed.plan``: double integrators with the
vehicles' own speed and acceleration bounds, ρ̂ ≥ κ, then the most robust path of its
homotopy class; every region the formula keeps the vehicle out of inflated by
``milp.seed.clearance``, so that the path between coarse samples cannot cut its corners)
in a forked child while the exact backend builds its model, and hands the path to the
exact MILP as a seed ``Solution``.  For a vehicle whose linear model is the double
integrator (the point mass), the coarse path with its acceleration held over each coarse
step is a trajectory of the fine model, so the exact backend sets its input columns to the
seed's inputs, fills every term and choice on that trajectory (``Encoder.complete``), frees
the inputs with those choices fixed (LPs) and starts HiGHS from the result
(``ExactMilp._seed_start``).  The start changes only where the search begins: the exact
backend's result is still HiGHS's (optimal, or its incumbent with the gap at the time
limit), judged by the exact monitor.

On a grid of at most ``MAX_SAMPLES`` samples (the exact MILP is then about as small as the
coarse one), or when the coarse MILP finds nothing, no start is given and the exact backend
runs as before.  Measured (the 60 s patrol at 0.2 s, κ = 0.05): without the clearance the
1 s path scored ρ̂ 0.039 on the fine grid and 0.12 after the LPs; with it, 0.40 — the start
HiGHS keeps until its 20 s budget ends (bound 0.5).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from stlc import vehicles
from stlc.backends.base import Backend, SolverStatus
from stlc.backends.nlp.backend import pad
from stlc.backends.milp.backend import HIGHS_STATUS_MAP, ExactMilp
from stlc.backends.milp.seed import MAX_SAMPLES, plan, seed_factor
from stlc.planning.problem import PlanningProblem
from stlc.planning.solution import Solution, Verdict

#: the coarse MILP's wall limit: None scales it with its binaries and the machine's load
#: (``effort.seed_budget``; the 60 s patrol: 8.5 s at load 5)
TIME_LIMIT_S: float | None = None


class CoarseStart(Backend):
    name = "coarse MILP start"
    capabilities = ExactMilp.capabilities
    STATUS_MAP = HIGHS_STATUS_MAP

    def __init__(self, quiet: bool = True, time_limit: float | None = TIME_LIMIT_S):
        self.quiet = quiet
        self.time_limit = time_limit

    def accepts(self, problem: PlanningProblem) -> list:
        return []  # the exact backend after it states what the chain cannot plan

    def lower(self, problem: PlanningProblem):
        return None, None

    def solve(self, lowered, problem: PlanningProblem):
        t0 = time.perf_counter()
        if problem.grid.n <= MAX_SAMPLES or seed_factor(problem.grid, problem.requirement) <= 1:
            return None, {"status": "not needed (a small grid: the exact MILP starts itself)"}
        paths, rec = plan(problem, time_limit=self.time_limit, rounds=0, keep_clear=True,
                          best_blocks=True)  # the exact MILP's incumbent starts in its class
        rec.pop("choices", None)
        rec["total_s"] = time.perf_counter() - t0
        return paths, rec

    def start(self, lowered, problem: PlanningProblem):
        """The coarse MILP runs in a forked child while the exact backend builds."""
        from stlc import apart

        wait = apart.start(self.solve, lowered, problem)

        def result():
            return wait()[0]

        result.cancel = wait.cancel
        return result

    def invert(self, raw, inverse, problem: PlanningProblem) -> Solution:
        paths, rec = raw
        n, dt = problem.grid.n, problem.grid.dt
        ch: dict[str, np.ndarray] = {}
        for v in problem.vehicles():
            if not paths or v.name not in paths:
                ch = {}
                break
            vm = vehicles.model_of(v)
            P, V, A = paths[v.name]
            X, U = vm.guess(v, P, V, A, dt)
            ch.update({c: X[i] for i, c in enumerate(vm.state_channels(v))})
            ch.update({c: pad(U, n)[j] for j, c in enumerate(vm.input_channels(v))})
        ok = bool(ch)
        status = rec.get("status")
        if not ok and "budget_s" in rec and not self.quiet:
            print(f"{problem.name}: the coarse MILP start found no path ({status}, budget "
                  f"{rec['budget_s']:.1f} s); the exact MILP starts on its own",
                  file=sys.stderr, flush=True)
        return Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                        robustness_exact=float("nan"),
                        robustness_smooth=float(rec.get("robustness", float("nan"))),
                        specs={}, energy=0.0, times=problem.grid.times(), channels=ch,
                        timing={"guess_s": float(rec.get("total_s", 0.0))},
                        solver={"name": self.name,
                                "status": str(HIGHS_STATUS_MAP.get(str(status),
                                                                   SolverStatus.NOT_RUN)),
                                "return_status": str(status), "converged": ok,
                                "seed": rec})
