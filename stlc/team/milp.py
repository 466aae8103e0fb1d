"""Task assignment (paper B, §IV-B, eq. 7): capacitated multi-depot routing as a MILP.

Graph.  Nodes are each drone's depot (its start position), the targets (region centres)
and the refilling stations (centres).  Per drone ``d`` there is one binary variable per
directed arc: depot→target, depot→station (the drone serves nothing), target→target,
target→station (refill or end), station→target (leave after a refill).  Without stations
the routes end at a virtual sink (arcs target→sink, depot→sink).  Compared with the
paper's undirected ``z ∈ {0,1,2}`` formulation this directed one gives the visiting order
directly, allows a station to be used several times, and the same cuts apply.

Constraints.  Every target is entered exactly once by the team (7b); a drone leaves every
target it enters (7c); each drone leaves its depot once (7d); each drone ends at one
station (per station: entries ≥ exits; over all stations: entries − exits = 1); when
there are at least as many stations as drones, no two drones share a home station (two
drones parked in one 2 m station cannot keep Γ_dis = 3 m apart); each drone's route time
fits the horizon (below).  The initial cut pool holds the 2-target sub-tour cuts
``Σ_d (x_dij + x_dji) ≤ 1``.  Eq. (7e) is added lazily: after each solve
the incumbent is decomposed per drone, and for every violation a cut is added and the MILP
re-solved, until none is violated:

* a component of a drone's arcs not connected to its depot (a cycle of targets, or a
  closed tour through a station the drone never reaches), targets ``S`` and stations
  ``R_C``:  for each ``j ∈ S``, arcs of ``d`` entering ``S ∪ R_C`` ≥ arcs of ``d`` entering
  ``j``; for a target-only cycle also ``Σ_d Σ_{i,j∈S} x_dij ≤ |S| − 1`` (DFJ);
* a segment (depot or station → targets → station) longer than the capacity ``c̄_d``:
  for every window ``W`` of it longer than the capacity and every drone ``e`` with
  ``c̄_e < |W|``: ``Σ_{i≠j∈W} x_eij ≤ |W| − ⌈|W|/c̄_e⌉`` (each run between stations holds
  ≤ ``c̄_e`` targets), the fractional form ``Σ_{i≠j∈W} x_eij ≤ (1 − 1/c̄_e)·(targets of e
  in W)``, and team-wide ``Σ_e Σ_{i≠j∈W} x_eij ≤ |W| − ⌈|W|/max_e c̄_e⌉``; all are valid
  for every feasible route, so the solver cannot move the violation to another drone.

Costs are times, in seconds, exactly those of the seed trajectory (``stlc.team.seed``):
travel = the rest-to-rest primitive's minimum duration between the points (per-axis
``v̄``, ``ā``), rounded up to whole mission steps; dwell = ``(n+1)`` steps per visit
(``n = ⌈T/Δt⌉``: the payload rule's dwell plus one sample of margin), charged on arcs into
a target (install) and on arcs out of a station (refill).  Horizon: each drone's route
time plus a final refilling dwell at home must be ≤ ``T_N`` (conservative: the refill
requirement then holds whatever the drone carries when it gets home).

Objective: ``Σ_d time_d`` — the paper's total (eq. 7a), in time rather than distance so
that installs and refills count — plus ``w · max_d time_d`` if ``makespan_weight = w > 0``.
The default is ``w = 0``: the horizon is already a hard per-drone constraint, and the max
term weakens the LP bound so much that even the 2×7 mission did not solve in 5 minutes.
With ``w = 0`` a drone whose help does not pay for its travel goes straight home.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from stlc.team import AssignmentError, TeamScenario, centre, samples_for
from stlc.team.cuts import cuts_for, segments, station_shared
from stlc.team.paths import leg_steps, router_for
from stlc.team.primitives import min_duration

#: options passed to HiGHS; presolve off: on these small models it costs more than it saves
#: (4×11 mission: 2.3 s instead of 3.5 s CPU over the lazy rounds)
HIGHS_OPTIONS: dict[str, object] = {"presolve": "off"}
BUDGET_S = 30.0  # wall seconds for the exact MILP before the greedy fallback
Node = tuple[str, int]  # ("D", drone) | ("T", target) | ("S", station) | ("E", 0)


@dataclass
class AssignStats:
    cpu_s: float = 0.0  # process time of the whole assignment
    wall_s: float = 0.0
    rounds: int = 0  # MILP solves (1 + lazy-cut rounds)
    cuts: int = 0  # lazy cuts added
    objective: float = 0.0
    drone_time: dict[str, float] = field(default_factory=dict)  # route time per drone, s
    #: "milp" (optimal) or "greedy" (the MILP exceeded its time budget: the heuristic of
    #: ``stlc.team.local`` — greedy start, local search — feasible, not optimal)
    method: str = "milp"


@dataclass(frozen=True, slots=True)
class Arc:
    drone: int
    tail: Node
    head: Node
    cost: float


def leg_time(p0, p1, vel_max, acc_max, step: float, router=None) -> float:
    """Rest-to-rest travel time rounded up to whole steps (``inf`` if impossible); with a
    ``stlc.team.paths.Router``, the time of the seed's obstacle-aware leg (detours included,
    each sub-leg rounded up on its own)."""
    if router is not None:
        return step * sum(leg_steps(router.path(p0, p1, vel_max, acc_max), vel_max, acc_max,
                                    step))
    t = min_duration(p0, p1, vel_max, acc_max)
    return math.inf if math.isinf(t) else step * samples_for(t, step)


def dwell_times(scenario: TeamScenario) -> tuple[float, float]:
    """Planned dwell at a target and at a station: ``(n + 1)`` steps each."""
    s = scenario.step
    return (
        s * (samples_for(scenario.install_time, s) + 1),
        s * (samples_for(scenario.refill_time, s) + 1),
    )


def build_arcs(sc: TeamScenario) -> list[Arc]:
    """All finite-cost arcs of every drone (costs in seconds, see the module docstring)."""
    ins, rs = dwell_times(sc)
    tc = [centre(b) for b in sc.targets]
    scen = [centre(b) for b in sc.stations]
    router = router_for(sc)
    arcs: list[Arc] = []
    for d, dr in enumerate(sc.drones):

        def leg(a, b, dr=dr):
            return leg_time(a, b, dr.vel_max, dr.acc_max, sc.step, router)

        start = np.asarray(dr.start, dtype=float)
        can = dr.capacity > 0
        cand: list[tuple[Node, Node, float]] = []
        for j, cj in enumerate(tc):
            if can:
                cand.append((("D", d), ("T", j), leg(start, cj) + ins))
                if dr.capacity > 1:  # a drone carrying one diverter refills after each
                    cand += [(("T", i), ("T", j), leg(ci, cj) + ins)
                             for i, ci in enumerate(tc) if i != j]
                cand += [(("S", s), ("T", j), rs + leg(cs, cj) + ins)
                         for s, cs in enumerate(scen)]
                cand += [(("T", j), ("S", s), leg(cj, cs)) for s, cs in enumerate(scen)]
                if not scen:
                    cand.append((("T", j), ("E", 0), 0.0))
        cand += [(("D", d), ("S", s), leg(start, cs)) for s, cs in enumerate(scen)]
        if not scen:
            cand.append((("D", d), ("E", 0), 0.0))
        arcs += [Arc(d, t, h, c) for t, h, c in cand if math.isfinite(c)]
    return arcs


def _precheck(sc: TeamScenario, arcs: list[Arc]) -> None:
    nt = len(sc.targets)
    if not sc.drones:
        raise AssignmentError("the mission has no drones", reason="capacity")
    total = sum(max(d.capacity, 0) for d in sc.drones)
    if nt and total == 0:
        raise AssignmentError(
            f"{nt} target(s) to install but every drone has capacity 0", reason="capacity")
    if not sc.stations and nt > total:
        raise AssignmentError(
            f"{nt} targets to install but the drones carry only {total} diverters in total "
            "and there is no refilling station", reason="no-station")
    for d, dr in enumerate(sc.drones):
        if sc.stations and not any(a.drone == d and a.head[0] == "S" for a in arcs):
            raise AssignmentError(
                f"drone {dr.name} cannot reach any refilling station within its velocity and "
                "acceleration bounds", reason="unreachable", subject=dr.name)
    for j, t in enumerate(sc.targets):
        if not any(a.head == ("T", j) for a in arcs):
            raise AssignmentError(
                f"no drone can reach target {t.name} (capacity and velocity/acceleration "
                "bounds)", reason="unreachable", subject=t.name)


class _Model:
    """The MILP rows (sparse) plus the lazily added cuts."""

    def __init__(self, sc: TeamScenario, arcs: list[Arc], horizon_limit: float | None,
                 makespan_weight: float) -> None:
        self.sc, self.arcs, self.w = sc, arcs, makespan_weight
        n = len(arcs)
        eq: list[tuple[dict[int, float], float]] = []
        ub: list[tuple[dict[int, float], float]] = []
        nd, nt, ns = len(sc.drones), len(sc.targets), len(sc.stations)
        for d in range(nd):
            eq.append(({k: 1.0 for k, a in enumerate(arcs) if a.tail == ("D", d)}, 1.0))
            for j in range(nt):
                row = {k: 1.0 for k, a in enumerate(arcs) if a.drone == d and a.head == ("T", j)}
                for k, a in enumerate(arcs):
                    if a.drone == d and a.tail == ("T", j):
                        row[k] = row.get(k, 0.0) - 1.0
                eq.append((row, 0.0))
            if ns:
                tot: dict[int, float] = {}
                for s in range(ns):
                    row = {}
                    for k, a in enumerate(arcs):
                        if a.drone == d and a.head == ("S", s):
                            row[k] = -1.0
                        elif a.drone == d and a.tail == ("S", s):
                            row[k] = 1.0
                    ub.append((row, 0.0))  # exits - entries <= 0
                    for k, v in row.items():
                        tot[k] = tot.get(k, 0.0) - v
                eq.append((tot, 1.0))
            else:
                eq.append(({k: 1.0 for k, a in enumerate(arcs)
                            if a.drone == d and a.head == ("E", 0)}, 1.0))
            if horizon_limit is not None:
                ub.append(({k: a.cost for k, a in enumerate(arcs) if a.drone == d},
                           horizon_limit))
        for j in range(nt):
            eq.append(({k: 1.0 for k, a in enumerate(arcs) if a.head == ("T", j)}, 1.0))
        # initial cut pool: no 2-cycles between targets (sub-tour cuts with |S| = 2)
        self.inner_arcs = [k for k, a in enumerate(arcs) if a.tail[0] == a.head[0] == "T"]
        pair: dict[frozenset, dict[int, float]] = {}
        for k in self.inner_arcs:
            pair.setdefault(frozenset((arcs[k].tail[1], arcs[k].head[1])), {})[k] = 1.0
        ub += [(row, 1.0) for row in pair.values()]
        if 0 < nd <= ns:  # one drone per home station (entries - exits = 1 there)
            for s in range(ns):
                row = {}
                for k, a in enumerate(arcs):
                    if a.head == ("S", s):
                        row[k] = row.get(k, 0.0) + 1.0
                    elif a.tail == ("S", s):
                        row[k] = row.get(k, 0.0) - 1.0
                ub.append((row, 1.0))
            # ... and no drone refills at another drone's home: a station is used by one
            # drone at most (usage binaries y[d, s] after the arc variables), so no two
            # drones ever share a 2 m station that cannot keep them Γ_dis apart
            # (added lazily, like eq. 7e: most instances never put two drones in a station)
            shared: list[tuple[dict[int, float], float]] = []
            for s in range(ns):
                ys = []
                for d in range(nd):
                    y = n + len(ys) + s * nd
                    ys.append(y)
                    for k, a in enumerate(arcs):
                        if a.drone == d and a.head == ("S", s):
                            shared.append(({k: 1.0, y: -1.0}, 0.0))
                shared.append(({y: 1.0 for y in ys}, 1.0))
            n_extra = nd * ns
        else:
            n_extra, shared = 0, []
        self.station_rows = shared
        self.seen: set[frozenset] = set()
        self.n, self.eq, self.ub = n + n_extra, eq, ub
        self.cost = np.concatenate([[a.cost for a in arcs], np.zeros(n_extra)])
        self.drone_of = np.concatenate([[a.drone for a in arcs], -np.ones(n_extra, dtype=int)])

    @staticmethod
    def _matrix(rows: list[tuple[dict[int, float], float]], n: int):
        data, ri, ci = [], [], []
        for r, (row, _) in enumerate(rows):
            for c, v in row.items():
                ri.append(r)
                ci.append(c)
                data.append(v)
        a = sp.csr_matrix((data, (ri, ci)), shape=(len(rows), n))
        return a, np.array([b for _, b in rows])

    def solve(self, time_limit: float | None = None):
        x = cp.Variable(self.n, boolean=True)
        a_eq, b_eq = self._matrix(self.eq, self.n)
        cons = [a_eq @ x == b_eq]
        if self.ub:
            a_ub, b_ub = self._matrix(self.ub, self.n)
            cons.append(a_ub @ x <= b_ub)
        obj = self.cost @ x
        if self.w > 0:
            m = cp.Variable()
            for d in range(len(self.sc.drones)):
                cons.append(m >= (self.cost * (self.drone_of == d)) @ x)
            obj = obj + self.w * m
        prob = cp.Problem(cp.Minimize(obj), cons)
        opts = dict(HIGHS_OPTIONS)
        if time_limit is not None:
            opts["time_limit"] = float(time_limit)
        with warnings.catch_warnings():  # a time-limited solve is judged by its status
            warnings.simplefilter("ignore", UserWarning)
            prob.solve(solver=cp.HIGHS, **opts)
        if prob.status == "user_limit" or (time_limit is not None and x.value is None
                                           and prob.status not in ("infeasible",)):
            return "time"
        if prob.status not in ("optimal", "optimal_inaccurate") or x.value is None:
            return None
        return np.round(x.value).astype(int), float(prob.value)


def _route(sc: TeamScenario, d: int, chosen: list[Arc]) -> list[str]:
    """Ordered region names of drone ``d`` (an Euler trail over the runs, from the depot)."""
    segs = segments(chosen)
    first = next(s for s in segs if s[0] == ("D", d))
    out_of: dict[Node, list[tuple[Node, list[int], Node]]] = {}
    for s in segs:
        if s[0][0] == "S":
            out_of.setdefault(s[0], []).append(s)
    order: list[tuple[Node, list[int], Node]] = []
    stack: list[tuple[Node, tuple | None]] = [(first[2], None)]
    while stack:
        v, seg = stack[-1]
        if out_of.get(v):
            nxt = out_of[v].pop()
            stack.append((nxt[2], nxt))
        else:
            stack.pop()
            if seg is not None:
                order.append(seg)
    names: list[str] = []
    for _, seq, end in [first] + order[::-1]:
        names += [sc.targets[j].name for j in seq]
        if end[0] == "S":
            names.append(sc.stations[end[1]].name)
    return names


def _lazy_solve(sc: TeamScenario, arcs: list[Arc], limit: float | None, w: float,
                stats: AssignStats, max_rounds: int, deadline: float = math.inf
                ) -> tuple[np.ndarray, float] | None:
    model = _Model(sc, arcs, limit, w)
    for _ in range(max_rounds):
        stats.rounds += 1
        left = deadline - time.perf_counter()
        if left <= 0:
            raise _Budget
        res = model.solve(left if math.isfinite(left) else None)
        if res == "time":
            raise _Budget
        if res is None:
            return None
        xv, obj = res
        cuts = []
        for d in range(len(sc.drones)):
            cuts += cuts_for(model, d, [a for k, a in enumerate(arcs) if xv[k] and a.drone == d])
        if model.station_rows and station_shared(arcs, xv):
            cuts += model.station_rows
            model.station_rows = []
        if not cuts:
            return xv, obj
        stats.cuts += len(cuts)
        model.ub += cuts
    raise AssignmentError(f"the assignment did not converge in {max_rounds} lazy-cut rounds",
                          reason="capacity")


class _Budget(Exception):
    """The MILP exceeded its time budget."""


def assign(scenario: TeamScenario, *, makespan_weight: float = 0.0,
           max_rounds: int = 200, budget_s: float = BUDGET_S
           ) -> tuple[dict[str, list[str]], AssignStats]:
    """Route of every drone (ordered target and station names, ending at its home station
    when there are stations) and the solve statistics.  Raises ``AssignmentError`` when no
    assignment exists (capacity, reachability, horizon).  When the lazy-cut loop exceeds
    ``budget_s`` seconds the routes come from the heuristic instead (``stlc.team.greedy``
    start, ``stlc.team.local`` search; ``stats.method == "greedy"``: feasible, not
    optimal)."""
    c0, w0 = time.process_time(), time.perf_counter()
    stats = AssignStats()
    sc = scenario
    arcs = build_arcs(sc)
    _precheck(sc, arcs)
    tail = dwell_times(sc)[1] if sc.stations else 0.0
    limit = sc.horizon - tail
    try:
        res = _lazy_solve(sc, arcs, limit, makespan_weight, stats, max_rounds,
                          w0 + budget_s)
    except _Budget:
        return _fallback(sc, stats, limit, c0, w0)
    if res is None:
        free = _lazy_solve(sc, arcs, None, makespan_weight, AssignStats(), max_rounds)
        if free is None:
            raise AssignmentError("no assignment of the targets to the drones exists "
                                  "(capacities and refilling stations)", reason="capacity")
        longest = max(sum(a.cost for k, a in enumerate(arcs) if free[0][k] and a.drone == d)
                      for d in range(len(sc.drones)))
        raise AssignmentError(
            f"no assignment fits the horizon of {sc.horizon:g} s: the best plan without it "
            f"has a route of {longest + tail:.2f} s (travel, {sc.install_time:g} s per "
            f"install, {sc.refill_time:g} s per refill and at home)", reason="horizon")
    xv, obj = res
    routes: dict[str, list[str]] = {}
    for d, dr in enumerate(sc.drones):
        chosen = [a for k, a in enumerate(arcs) if xv[k] and a.drone == d]
        routes[dr.name] = _route(sc, d, chosen)
        stats.drone_time[dr.name] = float(sum(a.cost for a in chosen))
    stats.objective = obj
    stats.cpu_s = time.process_time() - c0
    stats.wall_s = time.perf_counter() - w0
    return routes, stats


def _fallback(sc: TeamScenario, stats: AssignStats, limit: float, c0: float, w0: float):
    from stlc.team.greedy import greedy_routes
    from stlc.team.local import local_routes

    vm = {d.name: d for d in sc.drones}
    router = router_for(sc)

    def leg(p0, p1, d):
        return leg_time(p0, p1, d.vel_max, d.acc_max, sc.step, router)

    routes = greedy_routes(sc, leg, dwell_times(sc))
    if sc.stations:
        routes = local_routes(sc, leg, dwell_times(sc), limit, routes)
    names = [d.name for d in sc.drones]
    for name, r in routes.items():
        t = route_time(sc, names.index(name), r)
        if t > limit + 1e-9:
            raise AssignmentError(f"the heuristic assignment (the MILP exceeded its time "
                                  f"budget) does not fit the horizon: {name} needs {t:.1f} s",
                                  reason="horizon", subject=vm[name].name)
        stats.drone_time[name] = t
    stats.method = "greedy"
    stats.objective = sum(stats.drone_time.values())
    stats.cpu_s = time.process_time() - c0
    stats.wall_s = time.perf_counter() - w0
    return routes, stats


def route_time(scenario: TeamScenario, drone: int, route: list[str]) -> float:
    """The cost model applied to a given route (same numbers as the MILP's arcs)."""
    sc, dr = scenario, scenario.drones[drone]
    ins, rs = dwell_times(sc)
    regions = {b.name: ("T", b) for b in sc.targets} | {b.name: ("S", b) for b in sc.stations}
    p, prev, total = np.asarray(dr.start, dtype=float), "D", 0.0
    for name in route:
        kind, box = regions[name]
        c = centre(box)
        total += leg_time(p, c, dr.vel_max, dr.acc_max, sc.step, router_for(sc))
        total += ins if kind == "T" else 0.0
        total += rs if prev == "S" and kind == "T" else 0.0
        p, prev = c, kind
    return total
