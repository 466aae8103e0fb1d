"""The ``nlp`` chain's seed backend: the MILP seed path (``milp.seed.plan``) smoothed by the
kinematic NLP, or a proof that no plan exists (``milp.conflict``).

When the seed's MILP finds no path within its inner bounds (the vehicles' guess limits, the
box inside every speed ball) and nothing proves the mission impossible, a path is looked
for once more with those bounds relaxed (``plan(relaxed=True)``: twice the guess limits,
the box around every speed ball): still a seed, never a proof — the NLP with the vehicle's
own model decides what can be flown, and the exact monitor judges it.
"""

from __future__ import annotations

import time

import numpy as np

from stlc.planning import effort
from stlc.backends.base import SolverStatus
from stlc.backends.nlp.backend import KinematicGuess
from stlc.backends.nlp.kinematic import build_in_thread
from stlc.backends.milp.backend import HIGHS_STATUS_MAP
from stlc.backends.milp.seed import conjuncts, plan, seed_formula


class MilpPathSeed(KinematicGuess):
    """The ``nlp`` chain's seed: the MILP seed path, else the kinematic guess.  When no seed
    path reaches κ, the sound relaxation of ``milp.conflict`` is asked for a proof at once
    (before the NLP spends its λ schedule on an impossible mission); with a proof the
    Solution is ``infeasible`` and ``run_chain`` stops there."""

    name = "milp seed"
    NEXT_LABEL = "the next-best MILP seed (its choices for the violated specs excluded)"

    def __init__(self, quiet: bool = True, exclude: tuple = (), smooth: bool = True,
                 given: tuple | None = None, free: bool | str = True):
        self.quiet, self.smooth, self.given, self.free = quiet, smooth, given, free
        self.exclude = tuple(exclude)  # earlier seeds' choices (no-good cuts)
        self.choices = None  # this seed's, after ``invert``
        # smooth=False: the MILP's path (with ``free``, after the MILP with its choices free
        # has looked for a better class; "later": that search is left to the seed given the
        # path, as ``resume``); given: (paths, record[, resume]) found before (no MILP)
        self.resume = None

    def solve(self, lowered, problem):
        from stlc import apart
        from stlc.backends.nlp import schedule

        t0 = time.perf_counter()
        builds = []  # the kinematic NLP, built in a thread while HiGHS runs
        if self.given is not None:  # (paths, record[, its search for a better class])
            paths, rec = self.given[0], dict(self.given[1])
            resume = self.given[2] if len(self.given) > 2 else None
        else:
            paths, rec, resume = plan(
                problem, exclude=self.exclude, defer_free=True,
                on_solve=(lambda: builds.append(build_in_thread(problem))) if self.smooth
                else None)
        if paths is None and self.given is None and rec.get("phases") and \
                rec["phases"][0][1] == "Infeasible":  # none within the inner bounds
            loose, loose_rec, loose_resume = plan(problem, exclude=self.exclude,
                                                  defer_free=True, relaxed=True)
            if loose is not None:
                effort.say(f"{problem.name}: the MILP seed found no path within its inner "
                           "bounds; a path with them relaxed seeds the NLP", self.quiet)
                loose_rec["inner_phases"] = rec["phases"]  # the search that found none
                paths, rec, resume = loose, loose_rec, loose_resume
        proof = None  # (a given path's record was asked for a proof when it was found)
        if self.given is None and rec.get("phases") and (
                rec["phases"][0][1] == "Infeasible"
                or rec.get("bound", np.inf) < problem.threshold):
            # no seed path reaches κ: HiGHS proved it, or the encoding's bound on ρ̂ is
            # below κ already (its feasibility phase then finds a path at that bound)
            from stlc.backends.milp.conflict import prove_infeasible

            proof = prove_infeasible(problem)  # HiGHS only: beside the build, too
            rec["proof_s"] = time.perf_counter() - t0 - rec.get("total_s", 0.0)
        nlp = builds[0]() if builds else None  # joined before this thread uses CasADi
        if proof is None:  # the kinematic NLP, from the seed path when there is one,
            # while the MILP with its choices free looks for a better class apart (rarely
            # found on a handover: then the kinematic NLP runs again from that class)
            if not self.smooth and paths is not None:
                if self.free == "later":  # the search for a better class is handed on
                    self.resume = resume  # (``solve`` ran in-process: ``knots.timed``)
                elif self.free and resume is not None:  # the MILP with its choices free
                    better, more = resume()  # looks for a better class, here
                    if more:
                        rec["phases"] += [list(p) for p in more]
                    if better is not None:
                        paths, rec = better
                return (paths, rec, None), time.perf_counter() - t0
            t1 = time.perf_counter()
            free = apart.start(resume) if resume is not None else None

            def smooth(path):
                if path is not None and nlp is not None:
                    return nlp.solve(path)
                return schedule.kinematic_guess(problem, path=path)

            kin = smooth(paths)
            better, more = free()[0] if free is not None else (None, [])
            if more:
                rec["phases"] += [list(p) for p in more]
            if better is not None:
                paths, rec = better
                kin = smooth(paths)
            paths = kin
            rec["kinematic_s"] = time.perf_counter() - t1
            if "robustness" not in rec:
                rec["fallback"] = "kinematic guess"
                effort.say(f"{problem.name}: the MILP seed found no path ({rec.get('status')}, "
                           f"budget {rec.get('budget_s', 0):.1f} s); the seed is the local "
                           "kinematic guess", self.quiet)
        return (paths, rec, proof), time.perf_counter() - t0

    def next_seed(self, problem, channels) -> MilpPathSeed | None:
        """A seed that leaves out this one's choices for the conjuncts of the seed formula
        that the plan ``channels`` violates (exact monitor, κ): the next-best discrete
        choice, or None when this seed chose nothing."""
        from stlc.analysis import monitor

        if not self.choices:
            return None
        f = seed_formula(problem)
        bad = {i for i, c in enumerate(conjuncts(f)) if i in self.choices and
               float(monitor.robustness(c, problem.grid.dt, channels, problem.params))
               < problem.threshold}
        cut = {i: self.choices[i] for i in (bad or self.choices)}
        return MilpPathSeed(self.quiet, self.exclude + (cut,))

    def invert(self, raw, inverse, problem):
        (paths, rec, proof), dt_s, cpu_s, waited_s = raw
        self.choices = rec.pop("choices", None)
        if proof is not None:
            from stlc.backends.milp.conflict import mark
            from stlc.planning.fallback import hover_solution

            sol = hover_solution(problem, "no plan exists", why="the mission is proved "
                                 "infeasible, so no trajectory was planned: the plan shown is "
                                 "every vehicle hovering at its start")
            mark(problem, sol, proof)
            sol.smoothing = {"method": problem.smoothing.method,
                             "lambda": problem.smoothing.lam,
                             "lambda_final": problem.smoothing.lam,
                             "threshold": problem.threshold}
        else:
            sol = super().invert((paths, dt_s, cpu_s, waited_s), inverse, problem)
        ok = "fallback" not in rec
        status = rec.get("status")
        sol.solver = sol.solver if proof is not None else {}
        sol.solver.update({
            "name": rec["name"] if ok else "kinematic guess (after the MILP seed)",
            "status": str(SolverStatus.INFEASIBLE if proof is not None else
                          HIGHS_STATUS_MAP.get(str(status), SolverStatus.FAILED)),
            "return_status": "infeasible" if proof is not None else str(status),
            "converged": status == "Optimal", "seed": rec})
        sol.timing.update({"guess_s": dt_s, "guess_cpu_s": cpu_s, "guess_wait_s": waited_s})
        return sol
