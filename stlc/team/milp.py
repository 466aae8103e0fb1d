"""Task assignment (paper B, §IV-B, eq. 7): capacitated multi-depot routing, solved exactly.

Graph and costs (``stlc.team.arcs``): each drone leaves its depot (start position), installs
targets (region centres) in runs of at most its capacity, refills at stations between runs
and ends at a station (a virtual sink when there are none); costs are the seed's times in
seconds (rest-to-rest travel rounded up to whole steps, ``(n+1)``-step dwells); each route
plus a final refilling dwell fits the horizon ``T_N``; when there are at least as many
stations as drones a station serves one drone.  Objective: the total route time (eq. 7a, in
time so that installs and refills count), plus ``w · max_d time_d`` if ``makespan_weight``.

Formulations (measured, see the README's team table):

* **routes** (default) — set partitioning over whole routes by column generation, exact
  pricing over trips, a rounded refill-count row, and closing by reduced-cost enumeration
  (``stlc.team.colgen`` over ``stlc.team.trips``).  Its LP bound is within 0.2 % of the
  optimum on the shipped missions; 3×9 with a refill and 4×11 are proved optimal in about
  a second, 6×16 in seconds.
* **trips** — a compact model over trips with station flows (``stlc.team.partition``):
  6–8 % LP gap (a drone's fractional trips may reuse a target across trips), 60 s without
  closing 3×9; kept to prove a model infeasible when the route formulation cannot.
* **arcs** — the directed arc model with lazy sub-tour / capacity cuts
  (``stlc.team.lazy``), the formulation of earlier versions: 14 s on 3×9, no close on 6×16
  in 30 s.  Used for a makespan weight and when the trips are too many to enumerate
  (``MAX_TRIPS``).

Budget.  Everything runs under one wall budget (``BUDGET_S``), every HiGHS solve has a time
limit.  Past it the answer is the best feasible assignment known — the route model's
incumbent, else the heuristic of ``stlc.team.local`` — reported as not optimal with the
lower bound.  A horizon too short is answered from lower bounds of the route times
(``stlc.team.horizon``) or from a model proved infeasible, never from an unbudgeted solve.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from stlc.team import AssignmentError, TeamScenario
from stlc.team.arcs import (  # noqa: F401  (re-exported: the MILP's cost model)
    Arc,
    precheck,
    build_arcs,
    dwell_times,
    leg_time,
    route_time,
)
from stlc.team.lazy import Budget, lazy_solve, route
from stlc.team.paths import router_for

BUDGET_S = 30.0  # wall seconds for the exact assignment before the best known one is used
WARM_AFTER_S = 10.0  # arcs model: wall seconds before the heuristic warm-starts HiGHS
HEURISTIC_S = 2.0  # wall seconds the local search may run past the exhausted budget
MAX_TRIPS = 400_000
PROOF_TRIPS = 20_000  # trips up to which the trip model may prove infeasibility  # trip columns the route model enumerates at most (else: arcs model)


@dataclass
class AssignStats:
    cpu_s: float = 0.0  # process time of the whole assignment
    wall_s: float = 0.0
    rounds: int = 0  # MILP solves (1 + lazy-cut rounds)
    cuts: int = 0  # lazy cuts added
    objective: float = 0.0
    drone_time: dict[str, float] = field(default_factory=dict)  # route time per drone, s
    #: "milp" (optimal) or "greedy" (the MILP exceeded its time budget: the best feasible
    #: assignment known, not optimal — see ``incumbent``)
    method: str = "milp"
    #: where a not-optimal assignment came from: "milp" (HiGHS's incumbent, warm-started
    #: from the heuristic), "heuristic" (stlc.team.local) or "greedy" (the bare rule)
    incumbent: str = ""
    #: lower bound of the optimal objective (= objective when optimal; the stopped
    #: round's dual bound otherwise; -inf if unknown)
    bound: float = -math.inf
    formulation: str = ""  # "routes" | "arcs"
    columns: int = 0  # route columns in the master (routes model)


def _leg(sc: TeamScenario):
    router = router_for(sc)
    return lambda p0, p1, d: leg_time(p0, p1, d.vel_max, d.acc_max, sc.step, router)


def heuristic_routes(sc: TeamScenario, limit: float, deadline: float = math.inf
                     ) -> dict[str, list[str]] | None:
    """Greedy start + local search (``stlc.team.local``, stopped at ``deadline``); None
    without stations or when the result does not fit the horizon limit."""
    from stlc.team.greedy import greedy_routes
    from stlc.team.local import local_routes

    if not sc.stations:
        return None
    try:
        routes = local_routes(sc, _leg(sc), dwell_times(sc), limit,
                              greedy_routes(sc, _leg(sc), dwell_times(sc)), deadline=deadline)
    except AssignmentError:
        return None
    ok = all(route_time(sc, d, routes[dr.name]) <= limit + 1e-9
             for d, dr in enumerate(sc.drones))
    return routes if ok else None


def assign(scenario: TeamScenario, *, makespan_weight: float = 0.0,
           max_rounds: int = 200, budget_s: float = BUDGET_S, warm_start: bool = True,
           warm_after: float = WARM_AFTER_S, formulation: str = "auto"
           ) -> tuple[dict[str, list[str]], AssignStats]:
    """Route of every drone (ordered target and station names, ending at its home station
    when there are stations) and the solve statistics.  Raises ``AssignmentError`` when no
    assignment exists (capacity, reachability, horizon) or none was found in the budget.

    ``formulation``: "routes", "arcs" or "auto" (routes unless a makespan weight is asked
    or the trips are more than ``MAX_TRIPS``).  Past ``budget_s`` the result is the best
    feasible assignment known with ``stats.method == "greedy"`` (not optimal),
    ``stats.incumbent`` saying where it came from and ``stats.bound`` a lower bound."""
    from stlc.team import colgen
    from stlc.team.horizon import route_bounds
    from stlc.team.trips import count_estimate, enumerate_trips

    c0, w0 = time.process_time(), time.perf_counter()
    stats = AssignStats()
    sc = scenario
    arcs = build_arcs(sc)
    precheck(sc, arcs)
    tail = dwell_times(sc)[1] if sc.stations else 0.0
    limit = sc.horizon - tail
    _check_bounds(sc, route_bounds(sc, arcs, tail))
    deadline = w0 + budget_s
    ins = dwell_times(sc)[0]
    use_routes = formulation == "routes" or (
        formulation == "auto" and makespan_weight == 0
        and count_estimate(sc, limit, ins) <= MAX_TRIPS and len(sc.targets) <= 62)
    heur: list = []  # computed at most once, when first needed

    def heuristic():
        if not heur:
            # the local search gets what is left of the budget, at least HEURISTIC_S
            heur.append(heuristic_routes(sc, limit, max(deadline, time.perf_counter()
                                                        + HEURISTIC_S)))
        return heur[0]

    if use_routes:
        stats.formulation = "routes"
        trips = enumerate_trips(sc, arcs, limit, ins)
        uncovered = set(range(len(sc.targets))) - {j for m in trips.members for j in m}
        if uncovered:
            name = sc.targets[min(uncovered)].name
            raise AssignmentError(
                f"no assignment fits the horizon of {sc.horizon:g} s: no drone can reach "
                f"target {name}, install it and get to a station in time", reason="horizon",
                subject=name)
        res = colgen.solve(sc, arcs, trips, limit, deadline)
        stats.rounds, stats.columns = res.rounds, res.columns
        if res.routes is not None:
            stats.drone_time = dict(res.times)
            stats.objective = res.objective
            stats.bound = res.bound
            if res.status != "optimal":
                stats.method, stats.incumbent = "greedy", "milp"
            return _done(res.routes, stats, c0, w0)
        if time.perf_counter() < deadline and len(trips.cost) <= PROOF_TRIPS:
            # can the model be proved infeasible?  (the trip model: its build is not
            # under HiGHS's time limit, so only where it is small)
            from stlc.team import partition

            out = partition.solve(sc, arcs, limit, deadline - time.perf_counter(),
                                  trips=trips)
            if out.status == "infeasible":
                raise _horizon_error(sc, route_bounds(sc, arcs, tail), proved=True)
        return _fallback(sc, arcs, stats, limit, c0, w0, heuristic(), Budget(None, res.bound))
    stats.formulation = "arcs"
    try:
        res = lazy_solve(sc, arcs, limit, makespan_weight, stats, max_rounds, deadline,
                         heuristic if warm_start else None, w0 + warm_after)
    except Budget as b:
        return _fallback(sc, arcs, stats, limit, c0, w0, heuristic(), b)
    if res is None:
        raise _horizon_error(sc, route_bounds(sc, arcs, tail), proved=True)
    xv, obj = res
    routes = _routes(sc, arcs, xv, stats)
    stats.objective = stats.bound = obj
    return _done(routes, stats, c0, w0)


def _done(routes, stats: AssignStats, c0: float, w0: float):
    stats.cpu_s = time.process_time() - c0
    stats.wall_s = time.perf_counter() - w0
    return routes, stats


def _horizon_error(sc: TeamScenario, bounds: tuple[float, float], *, proved: bool):
    reach, work = bounds
    lb = max(b for b in bounds if math.isfinite(b)) if any(map(math.isfinite, bounds)) else 0
    why = (f"the longest route needs at least {lb:.1f} s (a lower bound from travel, "
           f"{sc.install_time:g} s per install, {sc.refill_time:g} s per refill and at home)")
    if proved:
        why = "the assignment model with it is infeasible; " + why.replace("needs", "needs, "
                                                                         "without it,")
    return AssignmentError(f"no assignment fits the horizon of {sc.horizon:g} s: {why}",
                           reason="horizon")


def _check_bounds(sc: TeamScenario, bounds: tuple[float, float]) -> None:
    """Raise the horizon error at once when a lower bound of the longest route exceeds it."""
    if any(math.isfinite(b) and b > sc.horizon + 1e-9 for b in bounds):
        raise _horizon_error(sc, bounds, proved=False)


def _routes(sc: TeamScenario, arcs: list[Arc], xv: np.ndarray, stats: AssignStats):
    routes: dict[str, list[str]] = {}
    for d, dr in enumerate(sc.drones):
        chosen = [a for k, a in enumerate(arcs) if xv[k] and a.drone == d]
        routes[dr.name] = route(sc, d, chosen)
        stats.drone_time[dr.name] = float(sum(a.cost for a in chosen))
    return routes


def _fallback(sc: TeamScenario, arcs: list[Arc], stats: AssignStats, limit: float, c0: float,
              w0: float, heur: dict[str, list[str]] | None, budget: Budget):
    from stlc.team.greedy import greedy_routes

    names = [d.name for d in sc.drones]
    if budget.x is not None:
        routes, stats.incumbent = _routes(sc, arcs, budget.x, stats), "milp"
    elif heur is not None:
        routes, stats.incumbent = heur, "heuristic"
    else:
        routes, stats.incumbent = greedy_routes(sc, _leg(sc), dwell_times(sc)), "greedy"
    for name, r in routes.items():
        t = route_time(sc, names.index(name), r)
        if t > limit + 1e-9:
            raise AssignmentError(f"the {stats.incumbent} assignment (the MILP exceeded its "
                                  f"time budget) does not fit the horizon: {name} needs "
                                  f"{t:.1f} s", reason="horizon", subject=name)
        stats.drone_time[name] = t
    stats.method = "greedy"
    stats.objective = sum(stats.drone_time.values())
    stats.bound = budget.bound
    return _done(routes, stats, c0, w0)
