"""The plan written when the run's time limit ran out before any solver produced one.

Every vehicle hovers at its start position for the whole horizon (level attitude, zero
velocity, hover rotor forces: the vehicle model's own guess from a constant path).  It is
what "the best plan found so far" is when nothing was found; the exact monitor judges it
like any plan, and the solver log says no solver finished (``stopped_by: time_limit``).
"""

from __future__ import annotations

import numpy as np

from stlc import deadline, vehicles
from stlc.planning.solution import Solution, Verdict
from stlc.planning.problem import PlanningProblem


def hover_solution(problem: PlanningProblem, reason: str, why: str | None = None) -> Solution:
    """Each vehicle of ``problem`` hovering at its start; ``reason`` (and ``why``, else:
    no solver produced a plan in time) go to the notes."""
    n, dt = problem.grid.n, problem.grid.dt
    ch: dict[str, np.ndarray] = {}
    energy = np.zeros(n)
    for v in problem.vehicles():
        vm = vehicles.model_of(v)
        P = np.tile(np.asarray(v.start_pos, dtype=float)[:, None], (1, n))
        X, U = vm.guess(v, P, np.zeros((3, n)), np.zeros((3, n - 1)), dt)
        for i, name in enumerate(vm.state_channels(v)):
            ch[name] = np.asarray(X[i], dtype=float).copy()
        U = np.asarray(U, dtype=float).reshape(len(vm.input_channels(v)), -1)
        Up = np.hstack([U, U[:, -1:]]) if U.shape[1] == n - 1 else U
        for i, name in enumerate(vm.input_channels(v)):
            ch[name] = Up[i].copy()
        ch.update(vm.derived_channels(v, vehicles.state_matrix(v, ch)))
        energy += vm.energy_profile(v, vehicles.state_matrix(v, ch), dt)
    sol = Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                   robustness_exact=float("nan"), robustness_smooth=float("nan"), specs={},
                   energy=float(energy.sum()), times=problem.grid.times(), channels=ch,
                   solver={"name": "none", "iterations": 0, "return_status": "max_time",
                           "converged": False, "stages": []},
                   energy_profile=energy, feasible=False)
    sol.notes.append(f"{reason}: " + (why or "no solver produced a plan in time, so the plan "
                                      "is every vehicle hovering at its start (not a planned "
                                      "trajectory)"))
    return sol


def fallback(problem: PlanningProblem) -> Solution:
    """The plan when the watchdog cut the build (``stlc.deadline``)."""
    return hover_solution(problem, f"the time limit of {deadline.limit():g} s ran out while "
                          "the problem was being built")


def judged_fallback(problem: PlanningProblem) -> Solution:
    """``fallback``, judged by the exact monitor and marked as stopped by the time limit:
    what is written when the watchdog cut the run outside a backend's own budget."""
    from stlc.planning.verify import verify

    sol = fallback(problem)
    verify(problem, sol)
    time_limited(sol)
    return sol


def time_limited(sol: Solution) -> None:
    """The run's time limit (``stlc.deadline``) stopped the search: the plan is the best
    verified one found so far, not converged; one that does not satisfy is ``stopped``."""
    stages = sol.solver.get("stages") or []
    if not deadline.active() or not (deadline.solve_expired() or
                                     any(s.get("status") == "max_time" for s in stages)):
        return
    limit = deadline.limit()
    if deadline.was_cut():
        sol.solver.update(stopped_by="interrupted", converged=False)
        sol.notes.append("stopped by Ctrl-C (--keep-on-interrupt): this is the best verified "
                         "plan found until then (the solver did not converge)")
    else:
        sol.solver.update(stopped_by="time_limit", time_limit_s=limit, converged=False)
        sol.solver["time_limit_default"] = deadline.is_default()
        why = (" (the default limit: no `--time-limit` or `time_limit` was given; raise it "
               "with either)" if deadline.is_default() else "")
        sol.notes.append(f"stopped by the time limit of {limit:g} s{why}: this is the best "
                         "verified plan found so far (the solver did not converge)")
    if sol.status != Verdict.SATISFIED:
        sol.status = Verdict.STOPPED


class NoPlanFound(Exception):
    """A planner's own model found no plan — a bound of that model (e.g. the team planner's
    stop-and-go routes), not a proof over every trajectory: the run ends with "no plan
    found" and the reason (``not_found``), never with "no plan exists"."""

    def __init__(self, reason: str, span=None):
        super().__init__(reason)
        self.reason, self.span = reason, span


def not_found(problem: PlanningProblem, e: NoPlanFound) -> Solution:
    """The plan written when a planner found none: the vehicles hovering at their start,
    the reason in the notes and an STL503 diagnostic (judged by the exact monitor as any
    plan; its verdict is not "infeasible")."""
    from stlc.diagnostics import Diagnostic

    sol = hover_solution(problem, "no plan found", f"{e.reason}; the plan shown is every "
                         "vehicle hovering at its start (not a planned trajectory)")
    sol.solver.update(name="none", return_status="no_plan_found")
    sol.diagnostics.append(Diagnostic(
        "STL503", f"mission `{problem.mission.name}`: no plan found: {e.reason}",
        e.span or problem.mission.span, "lengthen the mission's `horizon` or add drones; "
        "this is the planner's limit, not a proof that the mission is impossible"))
    return sol
