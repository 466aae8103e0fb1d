"""The backup drone's plan of a takeover (paper B §IV-C): MILP → seed → refinement.

``TakeoverBackend`` (registry name ``takeover``) is this planner behind the ``Backend``
interface; the takeover simulation (``stlc.replan.takeover``, which keeps the flight and
the event logic) runs it through ``run_chain`` on a ``PlanningProblem`` that says
everything: ``team`` the backup alone, ``window`` (t0, T_N), ``fixed_channels`` the other
drones' trajectories (the failed one parked), ``targets`` the pending targets,
``stations`` the refilling stations it may use, ``time_limit`` the MILP's budget, the
objective's forward weight the refinement's η.  Its ``Solution`` carries the backup's
channels on the window's samples, its route and the statistics (``solver["stats"]``).

Everything is the nominal team planner, called on a reduced problem; nothing here is a
second planner:

* the **time frame** is shifted: the backup plans on [t0, T_N] (t0 = t_fail + T_rep, on
  the mission grid) as a mission of horizon T_N − t0 starting at rest at its start;
* the **task assignment** is ``stlc.team.milp.assign`` on a scenario with the backup as
  the only drone, the pending targets as the only targets, every refilling station except
  the one the failed drone is parked in (``stlc.replan.takeover``), and the same dwell
  times, obstacles, workspace and Γ_dis; it re-orders the pending targets and places the
  refills and the home station;
* the **seed** is ``stlc.team.seed.seed_plan`` of that route;
* the **refinement** is ``stlc.team.refine.refine`` on the same scenario with the other
  drones added as ``stlc.team.nlp.FixedDrone`` members: their trajectories on [t0, T_N]
  are given, so they enter only the separation rows (Γ_dis against the backup), chosen by
  the refinement's own constraint generation; the backup's velocity and acceleration
  bounds, dwells and obstacle margins are the refinement's as for a nominal plan.

``plan_backup`` returns the backup's dense trajectory on [t0, T_N] (shifted back to mission
time by the caller) and the statistics: MILP and refinement wall/CPU times, iterations,
rounds, status. Mission errors of the reduced problem (no assignment fits the remaining
time, a route does not fit) are returned as an infeasible outcome, not raised: the takeover
is then reported as not accepted.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from stlc.backends.base import ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities, SolverStatus
from stlc.backends.nlp.backend import IPOPT_STATUS_MAP
from stlc.planning.problem import PlanningProblem
from stlc.planning.solution import Solution, Verdict
from stlc.planning.takeover import BackupPlan, Fixed
from stlc.team import Drone, TeamError, TeamPlan, TeamScenario
from stlc.team.nlp import FixedDrone


def plan_backup(base: TeamScenario, backup: Drone, pending: list[str], stations: list[str],
                fixed: list[Fixed], horizon: float, *, lam: float, kappa: float,
                eta: float = 0.0, v_star=None, milp_budget_s: float = 10.0) -> BackupPlan:
    """Plan ``backup`` over a segment of length ``horizon`` (s) to install ``pending``
    (target names, any order) using the refilling ``stations`` (names), with the ``fixed``
    drones' trajectories (on the segment grid, sample 0 = segment start) in the separation
    rows.  ``base`` is the mission's team scenario (regions, dwell times, Γ_dis, step)."""
    from stlc.team.milp import assign
    from stlc.team.refine import refine
    from stlc.team.seed import seed_plan

    stats: dict = {}
    targets = tuple(t for t in base.targets if t.name in set(pending))
    sc = replace(base, drones=(backup,), targets=targets,
                 stations=tuple(s for s in base.stations if s.name in set(stations)),
                 horizon=float(horizon))
    w0, c0 = time.perf_counter(), time.process_time()
    try:
        routes, mstats = assign(sc, budget_s=milp_budget_s)
    except TeamError as e:
        stats.update(milp_s=time.perf_counter() - w0, milp_cpu_s=time.process_time() - c0)
        return BackupPlan(SolverStatus.INFEASIBLE, stats=stats, message=f"task assignment: {e}")
    stats.update(milp_s=time.perf_counter() - w0, milp_cpu_s=time.process_time() - c0,
                 milp_method=mstats.method, milp_rounds=mstats.rounds)
    route = list(routes.get(backup.name, []))
    w1, c1 = time.perf_counter(), time.process_time()
    try:
        seed = seed_plan(sc, routes)
    except TeamError as e:
        stats.update(seed_s=time.perf_counter() - w1)
        return BackupPlan(SolverStatus.INFEASIBLE, route, stats=stats, message=f"seed: {e}")
    stats.update(seed_s=time.perf_counter() - w1, seed_cpu_s=time.process_time() - c1)
    n = len(seed.times)
    members: list[Drone] = [backup]
    pos, vel, acc = dict(seed.pos), dict(seed.vel), dict(seed.acc)
    for f in fixed:
        if f.pos.shape != (n, 3):
            raise ValueError(f"fixed drone {f.drone.name}: {f.pos.shape[0]} samples on a "
                             f"segment of {n}")
        members.append(FixedDrone(f.drone.name, tuple(map(float, f.pos[0])), f.drone.vel_max,
                                  f.drone.acc_max, f.drone.capacity, pos=f.pos, vel=f.vel,
                                  acc=f.acc))
        pos[f.drone.name], vel[f.drone.name], acc[f.drone.name] = f.pos, f.vel, f.acc
    sc_ref = replace(sc, drones=tuple(members))
    seed_ref = TeamPlan(seed.times, pos, vel, acc, list(seed.visits),
                        {backup.name: route} | {f.drone.name: [] for f in fixed})
    w2, c2 = time.perf_counter(), time.process_time()
    try:
        plan, rstats = refine(sc_ref, seed_ref, lam=lam, kappa=kappa, eta=eta, v_star=v_star)
    except ValueError as e:  # the seed's visits do not fit the knot grid of the segment
        stats.update(refine_s=time.perf_counter() - w2)
        return BackupPlan(SolverStatus.INFEASIBLE, route, stats=stats,
                          message=f"refinement: {e}")
    code = str(rstats.get("status", ""))
    status = IPOPT_STATUS_MAP.get(code, SolverStatus.FAILED)
    rounds = rstats.get("rounds", [])
    stats.update(refine_s=time.perf_counter() - w2, refine_cpu_s=time.process_time() - c2,
                 refine_iterations=int(rstats.get("iterations", 0)),
                 refine_rounds=len(rounds), ipopt_status=code,
                 refine_r=float(rstats.get("r", np.nan)),
                 sep_rows=int(rounds[-1]["sep_rows"]) if rounds else 0,
                 variables=int(rstats.get("variables", 0)))
    if mstats.method != "milp":  # the greedy fallback: feasible, not optimal
        stats["note"] = "the MILP stopped on its time budget: greedy route (not optimal)"
        status = SolverStatus.MAX_TIME
    b = backup.name
    return BackupPlan(status, route, plan.pos[b], plan.vel[b], plan.acc[b], stats)


class TakeoverBackend(Backend):
    """The backup drone's plan of a takeover (module docstring) as a backend."""

    name = "team milp + refinement (backup)"
    capabilities = Capabilities(vehicle_models=frozenset({"point_mass"}), nodes=ALL_NODES,
                                functions=ALL_FUNCTIONS, team=False,
                                derived_signals=frozenset({"payload"}),
                                needs_signals=frozenset({"payload"}), windows=True)
    STATUS_MAP = IPOPT_STATUS_MAP  # the refinement's IPOPT decides the status
    MILP_BUDGET_S = 10.0  # the task assignment's budget when the problem sets no time limit

    def accepts(self, problem: PlanningProblem) -> list:
        return []  # ``stlc.replan.takeover.validate`` checks the takeover before any work

    def lower(self, problem: PlanningProblem):
        """The mission's team scenario, the backup as a team ``Drone`` and the fixed drones
        on the window (in the order of ``problem.fixed_channels``)."""
        from stlc.planning.bounds import stated_bounds
        from stlc.team.seed import scenario_from_program

        base = scenario_from_program(problem.program, problem.mission, separation=float(
            stated_bounds(problem.requirement).get("distance_min", 0.0)))
        (b,) = problem.team
        v = problem.program.vehicles[b]
        start = problem.start_state(b)[:3]  # a point mass: position first
        backup = Drone(b, tuple(map(float, start)), tuple(map(float, v.vel_max)),
                       tuple(map(float, v.acc_max)), int(v.capacity))
        k0 = int(round(problem.window[0] / problem.grid.dt))
        drones = {d.name: d for d in base.drones}
        fixed = []
        for name in dict.fromkeys(c.split(".")[0] for c in problem.fixed_channels):
            ch = problem.fixed_channels
            arr = [np.stack([np.asarray(ch[f"{name}.{f}.{a}"], dtype=float)[k0:]
                             for a in "xyz"], 1) for f in ("pos", "vel", "acc")]
            fixed.append(Fixed(drones[name], *arr))
        return (base, backup, fixed), None

    def solve(self, lowered, problem: PlanningProblem) -> BackupPlan:
        from stlc.backends.team.backend import forward_speed_target

        base, backup, fixed = lowered
        t0, t_end = problem.window
        eta = float(problem.objective.forward_weight)
        v_star = forward_speed_target(problem) if eta > 0 else None
        budget = problem.time_limit if problem.time_limit is not None else self.MILP_BUDGET_S
        return plan_backup(base, backup, list(problem.targets or ()),
                           list(problem.stations or ()), fixed, float(t_end - t0),
                           lam=problem.smoothing.lam, kappa=problem.threshold,
                           eta=eta if v_star is not None else 0.0, v_star=v_star,
                           milp_budget_s=float(budget))

    def invert(self, bp: BackupPlan, inverse, problem: PlanningProblem) -> Solution:
        (b,) = problem.team
        k0 = int(round(problem.window[0] / problem.grid.dt))
        ch: dict[str, np.ndarray] = {}
        for f, arr in (("pos", bp.pos), ("vel", bp.vel), ("acc", bp.acc)):
            if arr is not None:
                ch.update({f"{b}.{f}.{a}": np.asarray(arr[:, i]) for i, a in enumerate("xyz")})
        status = SolverStatus(bp.status)
        return Solution(
            mission=problem.name,
            status=Verdict.VIOLATED if bp.pos is not None else Verdict.SOLVER_FAILED,
            robustness_exact=float("nan"), robustness_smooth=float("nan"), specs={},
            energy=0.0, times=problem.grid.times()[k0:], channels=ch,
            solver={"name": self.name, "status": str(status),
                    "return_status": str(bp.stats.get("ipopt_status", status)),
                    "converged": status.converged, "stats": dict(bp.stats),
                    "message": bp.message},
            routes={b: list(bp.route)})

