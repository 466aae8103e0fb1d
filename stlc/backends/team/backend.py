"""Team backends (paper B): the task-assignment seed and the waypoint refinement.

* ``MilpSeed`` — the capacitated multi-depot routing MILP (HiGHS, lazy sub-tour and
  capacity cuts, warm-started from a heuristic, ``stlc.team.milp``) decides who installs
  which target in which order and where each drone refills and ends (past its time budget:
  the best feasible assignment known, reported as not optimal with its lower bound);
  rest-to-rest motion primitives with the dwells, detouring around obstacles
  (``stlc.team.seed``, ``stlc.team.paths``), turn the routes into a dynamically feasible
  trajectory sampled at the mission step.  This is paper B's "MILP only" plan.
* ``TeamRefine`` — keeps the assignment and order, and maximises the margin of the safety,
  separation and dwell predicates over knot positions/velocities with cubic Hermite
  segments sampled densely (``stlc.team.refine``), with the forward-speed term of eq. (9)
  when the objective has one.

Both return channels ``<d>.pos.*``, ``<d>.vel.*``, ``<d>.acc.*`` on the mission's dense grid
and the planned routes and dwells; the payload is *not* returned — verification recomputes
it from the positions (``stlc.team.payload``).
"""

from __future__ import annotations

import time

import numpy as np

from stlc.backends.base import ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities, SolverStatus
from stlc.backends.nlp.backend import IPOPT_STATUS_MAP
from stlc.diagnostics import Diagnostic, StlcError
from stlc.planning.solution import Comparison, Solution, Verdict
from stlc.planning.bounds import stated_bounds
from stlc.planning.record import Assignment
from stlc.planning.problem import PlanningProblem
from stlc.semantics.specs import reads_payload

_CAPS = Capabilities(vehicle_models=frozenset({"point_mass"}), nodes=ALL_NODES,
                     functions=ALL_FUNCTIONS, derived_signals=frozenset({"payload"}),
                     needs_signals=frozenset({"payload"}))


def is_team_mission(problem: PlanningProblem) -> bool:
    """A mission whose requirement reads a payload is planned by the team chain."""
    return reads_payload(problem.requirement)


def team_scenario(problem: PlanningProblem):
    from stlc.team import TeamError
    from stlc.team.seed import scenario_from_program

    sep = float(stated_bounds(problem.requirement).get("distance_min", 0.0))
    try:
        return scenario_from_program(problem.program, problem.mission, separation=sep)
    except TeamError as e:
        raise StlcError([_diag(problem, e)]) from None


def _diag(problem: PlanningProblem, e) -> Diagnostic:
    span = problem.mission.span
    subject = getattr(e, "subject", "")
    if subject in problem.program.vehicles:
        span = problem.program.vehicles[subject].span
    else:
        reg = problem.program.scenario.region(subject) if subject else None
        if reg is not None:
            span = reg.span
    hints = {"capacity": "add a refilling station or raise the drones' `capacity`",
             "horizon": "lengthen the mission's `horizon` or add drones",
             "unreachable": "check the drones' bounds and the region's position",
             "scenario": "team missions need point-mass drones with a `capacity`, "
                         "`install_time` and `refill_time`"}
    return Diagnostic("STL503", f"mission `{problem.mission.name}`: {e}", span,
                      hints.get(getattr(e, "reason", ""), None))


def forward_speed_target(problem: PlanningProblem):
    """v* of paper B: the mission's `forward_speed` if it gives one, else eq. 8 for every
    drone from its declared aerodynamic data (a dict per drone), else None."""
    from stlc.team.energy import optimal_forward_speed

    if problem.objective.forward_speed is not None:
        return problem.objective.forward_speed
    out = {}
    for v in problem.vehicles():
        aero = getattr(v, "aero", None)
        if aero is None or v.mass is None:
            return None
        rotors, disk, flat, kappa, rho = aero
        out[v.name] = optimal_forward_speed(v.mass, rotors, disk, flat, kappa, rho)
    return out or None


def plan_channels(plan) -> dict[str, np.ndarray]:
    ch: dict[str, np.ndarray] = {}
    for d in plan.pos:
        for f, arr in (("pos", plan.pos[d]), ("vel", plan.vel[d]), ("acc", plan.acc[d])):
            for i, a in enumerate("xyz"):
                ch[f"{d}.{f}.{a}"] = np.asarray(arr[:, i], dtype=float)
    return ch


def solution_plan(sol: Solution):
    """The ``TeamPlan`` carried by a team Solution (channels + routes + dwells)."""
    from stlc.team import TeamPlan

    drones = list(sol.routes)
    get = lambda d, f: np.stack([sol.channels[f"{d}.{f}.{a}"] for a in "xyz"], axis=1)  # noqa
    return TeamPlan(np.asarray(sol.times), {d: get(d, "pos") for d in drones},
                    {d: get(d, "vel") for d in drones}, {d: get(d, "acc") for d in drones},
                    list(sol.visits), {d: list(r) for d, r in sol.routes.items()})


def _gap(objective: float, bound: float) -> float | None:
    """Relative gap (objective − bound) / objective of a not-optimal assignment."""
    if not (np.isfinite(bound) and objective > 0):
        return None
    return max(0.0, (objective - bound) / objective)


class MilpSeed(Backend):
    name = "task-assignment MILP (HiGHS) + motion primitives"
    capabilities = _CAPS
    STATUS_MAP = {"optimal": SolverStatus.OPTIMAL, "optimal_inaccurate": SolverStatus.ACCEPTABLE,
                  "infeasible": SolverStatus.INFEASIBLE, "user_limit": SolverStatus.MAX_TIME}

    def __init__(self, budget_s: float | None = None):
        self.budget_s = budget_s  # wall seconds for the exact MILP (None: milp.BUDGET_S)

    def lower(self, problem: PlanningProblem):
        return team_scenario(problem), None

    def solve(self, scenario, problem: PlanningProblem):
        from stlc.team import TeamError
        from stlc.team.milp import BUDGET_S, assign
        from stlc.team.seed import seed_plan

        from stlc import deadline

        deadline.disarm()  # the MILP has a budget, each refinement solve a max_wall_time
        budget = BUDGET_S if self.budget_s is None else self.budget_s
        budget = max(0.1, min(budget, 0.4 * deadline.solve_remaining()))  # the run's limit
        try:
            routes, stats = assign(scenario, budget_s=budget)
        except TeamError as e:
            if getattr(e, "reason", "") == "horizon":  # the route model's bound, not a proof
                from stlc.planning.fallback import NoPlanFound

                raise NoPlanFound(f"{e} (by the planner's stop-and-go route model: travel "
                                  "between stops, rounded to steps — a faster trajectory "
                                  "may exist)", _diag(problem, e).span) from None
            raise StlcError([_diag(problem, e)]) from None
        t0 = time.perf_counter()
        plan = seed_plan(scenario, routes)
        return plan, stats, time.perf_counter() - t0

    def invert(self, raw, inverse, problem: PlanningProblem) -> Solution:
        plan, stats, seed_s = raw
        return Solution(
            mission=problem.mission.name, status=Verdict.VIOLATED,
            robustness_exact=float("nan"), robustness_smooth=float("nan"), specs={},
            energy=0.0, times=plan.times, channels=plan_channels(plan),
            timing={"milp_s": stats.wall_s, "seed_s": seed_s},
            solver={"name": self.name,
                    "status": str(SolverStatus.OPTIMAL if stats.method == "milp"
                                  else SolverStatus.MAX_TIME),
                    "assignment": Assignment(stats.method, stats.incumbent),
                    "milp_rounds": stats.rounds, "lazy_cuts": stats.cuts,
                    "objective_s": stats.objective, "milp_cpu_s": stats.cpu_s,
                    **({"incumbent": stats.incumbent, "lower_bound_s": stats.bound,
                        "gap": _gap(stats.objective, stats.bound)}
                       if stats.method != "milp" else {})},
            routes={d: list(r) for d, r in plan.route.items()}, visits=list(plan.visits))


class TeamRefine(Backend):
    name = "team refinement (casadi/ipopt, waypoints)"
    capabilities = _CAPS
    STATUS_MAP = IPOPT_STATUS_MAP

    def __init__(self, eta: float | None = None):
        self.eta = eta

    def lower(self, problem: PlanningProblem):
        return team_scenario(problem), None

    def solve(self, scenario, problem: PlanningProblem):
        from stlc.team.refine import refine

        if problem.seed is None:
            raise ValueError("team refinement needs a seed (run MilpSeed first)")
        obj = problem.objective
        eta = obj.forward_weight if self.eta is None else self.eta
        v_star = forward_speed_target(problem)
        if eta > 0 and v_star is None:
            raise StlcError([Diagnostic(
                "STL104", f"mission `{problem.mission.name}` minimises `forward_cost` but "
                "gives no forward speed v*", problem.mission.span,
                "write `forward_speed = 2.5 m/s` in the mission, or declare each drone's "
                "mass, rotors, disk_area, flat_plate_area and induced_factor (eq. 8)")])
        t0 = time.perf_counter()
        plan, stats = refine(scenario, solution_plan(problem.seed),
                             lam=problem.smoothing.lam, kappa=problem.threshold,
                             eta=eta, v_star=v_star)
        return plan, stats, time.perf_counter() - t0

    def invert(self, raw, inverse, problem: PlanningProblem) -> Solution:
        plan, stats, wall = raw
        code = str(stats.get("status", ""))
        status = self.status(code)
        sol = Solution(
            mission=problem.mission.name, status=Verdict.VIOLATED,
            robustness_exact=float("nan"), robustness_smooth=float(stats.get("r", np.nan)),
            specs={}, energy=0.0, times=plan.times, channels=plan_channels(plan),
            timing={"solve_s": wall, "build_s": float(stats.get("build_cpu_s", 0.0))},
            smoothing={"method": problem.smoothing.method, "lambda": problem.smoothing.lam,
                       "lambda_final": problem.smoothing.lam, "threshold": problem.threshold},
            solver={"name": self.name, "return_status": str(status), "ipopt_status": code,
                    "iterations": int(stats.get("iterations", 0)),
                    "rounds": len(stats.get("rounds", [])),
                    "forward_cost": stats.get("forward_cost")},
            problem_size={"samples": int(plan.times.size),
                          "variables": int(stats.get("variables", 0)),
                          "constraints": int(stats.get("constraints", 0))},
            routes={d: list(r) for d, r in plan.route.items()}, visits=list(plan.visits))
        standard = stats.get("standard")
        if standard is not None and standard is not plan:
            # the forward-speed stage started from the standard plan: a `compare` variant
            # without that term (paper B Fig. 11) is that plan, not a second solve
            for name, variant in problem.comparisons:
                if variant is not None and variant.forward_weight == 0:
                    sol.comparisons.append(Comparison(name, plan_channels(standard)))
        return sol
