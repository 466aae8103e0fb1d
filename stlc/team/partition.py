"""Task assignment as set partitioning over trips (paper B §IV-B eq. 7, re-formulated).

Columns are the trips of ``stlc.team.trips`` (a drone, a start — its depot or a station —,
a set of at most ``c̄_d`` targets in its best order, an end station), so capacity and
sub-tours among targets are settled by construction and the LP bound is the strong one of
set partitioning.  Rows, for drones ``d``, targets ``j`` and stations ``q``:

* every target in exactly one trip; every drone exactly one trip from its depot;
* station balance: trips of ``d`` ending at ``q`` − trips of ``d`` leaving ``q`` =
  ``h_dq`` ∈ [0, 1], the drone's home (the trips of a drone then form a walk from the depot
  to its home, given connectivity below);
* connectivity of the station-level walk (a trip may leave ``q`` only if the drone got
  there): a single-commodity flow per drone from the depot over the station pairs used by
  its trips, each trip leaving ``q`` consuming one unit at ``q``, arc capacity
  ``F · (trips of d on that pair)`` with ``F`` = the number of station trips ``d`` could
  fly — a component of trips the drone never reaches receives no flow;
* route time: ``Σ cost · y ≤ T_N − (n_rs+1)·Δt`` per drone (the final refilling dwell);
* when there are at least as many stations as drones, each station is used by one drone
  at most (usage binaries ``u_dq``; ``Σ_d u_dq ≤ 1``): two drones cannot share a 2 m
  station Γ_dis apart — the rule of the arc formulation (``stlc.team.milp``);
* objective ``Σ cost · y`` (+ ``w · max_d time_d`` when ``makespan_weight = w > 0``).

One HiGHS solve (``highs.solve_mip``, highspy) with a time limit; a known feasible
assignment (the heuristic's) can be its MIP start.  ``solve`` returns the routes, or None
when HiGHS proves the model infeasible; ``TimeUp`` carries the incumbent and bound when the
time limit ends the search first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from stlc.team import TeamScenario
from stlc.team.arcs import Arc
from stlc.solvers.highs import Result, solve_mip
from stlc.team.trips import Trips, best_order, enumerate_trips


@dataclass
class Outcome:
    routes: dict[str, list[str]] | None  # None: no feasible assignment known
    times: dict[str, float]  # route time per drone (the trips' costs), s
    objective: float
    bound: float  # dual bound (= objective when optimal)
    status: str  # a ``SolverStatus``: optimal | max_time | infeasible | failed
    columns: int  # trips in the model


class _Layout:
    """Column indices of the model's variable blocks."""

    def __init__(self, trips: Trips, nd: int, ns: int, exclusive: bool, w: float) -> None:
        self.m = len(trips.cost)
        col = self.m
        self.home = {}
        for d in range(nd):
            for q in range(ns):
                self.home[d, q], col = col, col + 1
        # station-level arcs used by some trip: (d, a, q), a = -1 depot or a station
        pairs = sorted({(int(d), int(s), int(e)) for d, s, e in
                        zip(trips.drone, trips.start, trips.end, strict=True)
                        if e >= 0 and (s >= 0 or ns > 0)})
        self.flow = {}
        if ns:
            for p in pairs:
                self.flow[p], col = col, col + 1
        self.use = {}
        if exclusive:
            for d in range(nd):
                for q in range(ns):
                    self.use[d, q], col = col, col + 1
        self.span = None
        if w > 0:
            self.span, col = col, col + 1
        self.n = col


def build(sc: TeamScenario, trips: Trips, limit: float, w: float = 0.0, supply: bool = True):
    """The MILP: (cost, integer, upper, A (csc), row_lo, row_hi, layout)."""
    nd, nt, ns = len(sc.drones), len(sc.targets), len(sc.stations)
    exclusive = 1 < nd <= ns
    lay = _Layout(trips, nd, ns, exclusive, w)
    rows: list[tuple[list[int], list[float], float, float]] = []
    m = lay.m
    by_target: list[list[int]] = [[] for _ in range(nt)]
    for t, mem in enumerate(trips.members):
        for j in mem:
            by_target[j].append(t)
    for j in range(nt):
        rows.append((by_target[j], [1.0] * len(by_target[j]), 1.0, 1.0))
    for d in range(nd):
        mine = np.flatnonzero(trips.drone == d)
        dep = mine[trips.start[mine] < 0]
        rows.append((dep.tolist(), [1.0] * len(dep), 1.0, 1.0))
        rows.append((mine.tolist(), trips.cost[mine].tolist(), -math.inf, limit))
        if lay.span is not None:
            rows.append((mine.tolist() + [lay.span], trips.cost[mine].tolist() + [-1.0],
                         -math.inf, 0.0))
        from_st = mine[trips.start[mine] >= 0]
        big = float(max(1, min(len(from_st), nt)))
        for q in range(ns):
            into = mine[trips.end[mine] == q]
            out = mine[trips.start[mine] == q]
            rows.append((into.tolist() + out.tolist() + [lay.home[d, q]],
                         [1.0] * len(into) + [-1.0] * len(out) + [-1.0], 0.0, 0.0))
            # flow balance at q: inflow - outflow - (trips leaving q) = 0
            fin = [c for (e, a, b), c in lay.flow.items() if e == d and b == q]
            fout = [c for (e, a, b), c in lay.flow.items() if e == d and a == q]
            rows.append((fin + fout + out.tolist(),
                         [1.0] * len(fin) + [-1.0] * len(fout) + [-1.0] * len(out), 0.0, 0.0))
            if exclusive:
                u = lay.use[d, q]
                rows.append((into.tolist() + [u], [1.0] * len(into) + [-(big + 1.0)],
                             -math.inf, 0.0))
                rows.append(([lay.home[d, q], u], [1.0, -1.0], -math.inf, 0.0))
            if ns and supply:  # a trip leaving q with j needs an arrival at q without j
                for j in range(nt):
                    lv = [t for t in out if j in trips.members[t]]
                    ar = [t for t in into if j not in trips.members[t]]
                    if lv:
                        rows.append((lv + ar, [1.0] * len(lv) + [-1.0] * len(ar),
                                     -math.inf, 0.0))
                    ai = [t for t in into if j in trips.members[t]]
                    lo_ = [t for t in out if j not in trips.members[t]]
                    if ai:
                        rows.append((ai + lo_ + [lay.home[d, q]],
                                     [1.0] * len(ai) + [-1.0] * len(lo_) + [-1.0],
                                     -math.inf, 0.0))
        for (e, a, b), c in lay.flow.items():  # flow only on station arcs in use
            if e != d:
                continue
            on = mine[(trips.start[mine] == a) & (trips.end[mine] == b)]
            rows.append(([c] + on.tolist(), [1.0] + [-big] * len(on), -math.inf, 0.0))
    if exclusive:
        for q in range(ns):
            cols = [lay.use[d, q] for d in range(nd)]
            rows.append((cols, [1.0] * nd, -math.inf, 1.0))
    ri, ci, va, lo, hi = [], [], [], [], []
    for r, (cols, vals, a, b) in enumerate(rows):
        ri += [r] * len(cols)
        ci += cols
        va += vals
        lo.append(a)
        hi.append(b)
    a = sp.csc_matrix((va, (ri, ci)), shape=(len(rows), lay.n))
    cost = np.zeros(lay.n)
    cost[:m] = trips.cost
    if lay.span is not None:
        cost[lay.span] = w
    integer = np.zeros(lay.n, dtype=bool)
    integer[:m] = True
    integer[list(lay.use.values())] = True
    upper = np.ones(lay.n)
    for c in lay.flow.values():
        upper[c] = np.inf
    if lay.span is not None:
        upper[lay.span] = np.inf
    return cost, integer, upper, a, np.asarray(lo), np.asarray(hi), lay


def routes_of(sc: TeamScenario, arcs: list[Arc], trips: Trips, x: np.ndarray):
    """Ordered region names per drone from a 0/1 trip vector (depot trip first, then an
    Euler trail over the station trips ending at the home station) and the route times."""
    chosen = np.flatnonzero(np.round(x[:len(trips.cost)]) > 0.5)
    routes, times = {}, {}
    for d, dr in enumerate(sc.drones):
        mine = [t for t in chosen if trips.drone[t] == d]
        times[dr.name] = float(sum(trips.cost[t] for t in mine))
        out_of: dict[int, list[int]] = {}
        first = None
        for t in mine:
            if trips.start[t] < 0:
                first = t
            else:
                out_of.setdefault(int(trips.start[t]), []).append(t)
        order: list[int] = []
        stack = [(int(trips.end[first]), first)]
        while stack:  # Hierholzer: an Euler trail of the station-level walk
            v, t = stack[-1]
            if out_of.get(v):
                nxt = out_of[v].pop()
                stack.append((int(trips.end[nxt]), nxt))
            else:
                stack.pop()
                order.append(t)
        names: list[str] = []
        for t in order[::-1]:
            seq = best_order(sc, arcs, d, int(trips.start[t]), trips.members[t],
                             int(trips.end[t]))
            names += [sc.targets[j].name for j in seq]
            if trips.end[t] >= 0:
                names.append(sc.stations[int(trips.end[t])].name)
        routes[dr.name] = names
    return routes, times


def vector(sc: TeamScenario, trips: Trips, lay: _Layout, routes: dict[str, list[str]]):
    """The full column vector of given routes (trips, homes, flows, usage, span), or None
    when a route has a trip the model does not hold (pruned or over capacity)."""
    tix = {b.name: j for j, b in enumerate(sc.targets)}
    six = {b.name: q for q, b in enumerate(sc.stations)}
    index = {(int(d), int(s), mem, int(e)): t for t, (d, s, e, mem) in
             enumerate(zip(trips.drone, trips.start, trips.end, trips.members, strict=True))}
    x = np.zeros(lay.n)
    spans = []
    for d, dr in enumerate(sc.drones):
        start, mem, legs = -1, [], []
        for name in routes.get(dr.name, []):
            if name in tix:
                mem.append(tix[name])
            else:
                legs.append((start, tuple(sorted(mem)), six[name]))
                start, mem = six[name], []
        if mem or not legs:
            if sc.stations:
                return None
            legs.append((start, tuple(sorted(mem)), -1))
        total = 0.0
        reached = set()
        for s, mem_t, e in legs:
            t = index.get((d, s, mem_t, e))
            if t is None:
                return None
            x[t] = 1.0
            total += trips.cost[t]
            if e >= 0:
                reached.add(e)
        if sc.stations:
            x[lay.home[d, legs[-1][2]]] = 1.0
            # flow: every trip leaving a station is supplied along the walk's order
            for i, (s, _, e) in enumerate(legs):
                x[lay.flow[d, s, e]] += len(legs) - 1 - i
            for q in reached:
                if (d, q) in lay.use:
                    x[lay.use[d, q]] = 1.0
        spans.append(total)
    if lay.span is not None:
        x[lay.span] = max(spans)
    return x


def solve(sc: TeamScenario, arcs: list[Arc], limit: float, time_limit: float, *,
          makespan_weight: float = 0.0, start_routes: dict[str, list[str]] | None = None,
          trips: Trips | None = None) -> Outcome:
    """The set-partitioning MILP of the scenario within ``time_limit`` seconds."""
    from stlc.team.arcs import dwell_times

    if trips is None:
        trips = enumerate_trips(sc, arcs, limit, dwell_times(sc)[0])
    nt = len(sc.targets)
    covered = {j for mem in trips.members for j in mem}
    if len(covered) < nt or not all((trips.drone[trips.start < 0] == d).any()
                                    for d in range(len(sc.drones))):
        return Outcome(None, {}, math.inf, math.inf, "infeasible", len(trips.cost))
    cost, integer, upper, a, lo, hi, lay = build(sc, trips, limit, makespan_weight)
    start = vector(sc, trips, lay, start_routes) if start_routes else None
    res: Result = solve_mip(cost, integer, upper, a, lo, hi, time_limit=time_limit,
                            start=start)
    if res.x is None:
        return Outcome(None, {}, math.inf, res.bound, res.status, len(trips.cost))
    routes, times = routes_of(sc, arcs, trips, res.x)
    obj = float(trips.cost @ np.round(res.x[:len(trips.cost)]))
    return Outcome(routes, times, obj, obj if res.status == "optimal" else res.bound,
                   res.status, len(trips.cost))
