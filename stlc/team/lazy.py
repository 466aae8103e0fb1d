"""The arc formulation of the task assignment (paper B eq. 7) with lazy cuts — measured
against the route formulation (``stlc.team.colgen``) and kept for what that one does not
take (a makespan weight, instances whose trips are too many to enumerate).

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

Solver and budget.  Every round is solved by HiGHS through ``stlc.solvers.highs`` (highspy).
The loop has a wall-time budget (``BUDGET_S``); when it is still running after
``WARM_AFTER_S`` the heuristic of ``stlc.team.local`` (greedy start, local search, own
station per drone) is computed and handed to HiGHS as the starting incumbent of every
later round — it satisfies every row, lazy ones included.  Past the budget the answer is
the best feasible assignment known (HiGHS's incumbent if it violates no lazy row, else the
heuristic's), not optimal, with the stopped round's dual bound as a lower bound of the
optimum (``AssignStats.bound``).  Measured: 2×7 and 4×11 finish in 0.1 s / ≈3 s (cold),
3×9 with a refill in 14.6 s (10 rounds, 301 cuts); 6×16 does not (6 rounds, ≈460 cuts in
30 s; the heuristic's Σ within 14 % of the bound) — the route formulation proves all of
them optimal (README, team table).  ``lazy_solve`` is the loop; ``stlc.team.milp.assign``
picks the formulation and owns the budget.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse as sp

from stlc.team import AssignmentError, TeamScenario
from stlc.team.arcs import Arc
from stlc.team.cuts import cuts_for, segments, station_shared
from stlc.solvers.highs import Result, solve_binary
from stlc.solvers.status import SolverStatus

#: options passed to HiGHS; presolve off: on these small models it costs more than it saves
#: (4×11 mission: 2.3 s instead of 3.5 s CPU over the lazy rounds)
HIGHS_OPTIONS: dict[str, object] = {"presolve": "off"}
Node = tuple[str, int]  # ("D", drone) | ("T", target) | ("S", station) | ("E", 0)


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

    def solve(self, time_limit: float | None = None, start: np.ndarray | None = None):
        """One round: ``highs.Result`` (status, best x, objective, dual bound)."""
        nd = len(self.sc.drones)
        cost, n = self.cost, self.n
        ub = list(self.ub)
        integer = np.ones(n, dtype=bool)
        if self.w > 0:  # makespan column m ≥ every drone's time, weight w
            cost = np.concatenate([cost, [self.w]])
            integer = np.concatenate([integer, [False]])
            for d in range(nd):
                row = {k: float(c) for k, c in enumerate(self.cost) if self.drone_of[k] == d}
                row[n] = -1.0
                ub.append((row, 0.0))
            n += 1
        a_eq, b_eq = self._matrix(self.eq, n)
        a_ub, b_ub = self._matrix(ub, n) if ub else (None, None)
        if start is not None and self.w > 0:
            times = [float(self.cost[(self.drone_of == d)] @ start[:self.n][self.drone_of == d])
                     for d in range(nd)]
            start = np.concatenate([start[:self.n], [max(times)]])
        return solve_binary(cost, integer, a_eq, b_eq, a_ub, b_ub, time_limit=time_limit,
                            start=start, options=HIGHS_OPTIONS)

    def vector(self, routes: dict[str, list[str]]) -> np.ndarray | None:
        """The 0/1 vector of given routes (arcs and station-usage columns), or None when a
        route uses an arc the model does not have."""
        sc, nd = self.sc, len(self.sc.drones)
        index = {(a.drone, a.tail, a.head): k for k, a in enumerate(self.arcs)}
        node = {b.name: ("T", j) for j, b in enumerate(sc.targets)}
        node |= {b.name: ("S", j) for j, b in enumerate(sc.stations)}
        x = np.zeros(self.n)
        for d, dr in enumerate(sc.drones):
            prev: Node = ("D", d)
            for name in routes.get(dr.name, []):
                k = index.get((d, prev, node.get(name)))
                if k is None:
                    return None
                x[k] = 1.0
                prev = node[name]
                if prev[0] == "S" and self.n > len(self.arcs):
                    x[len(self.arcs) + d + prev[1] * nd] = 1.0
        return x


def route(sc: TeamScenario, d: int, chosen: list[Arc]) -> list[str]:
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


def _violated(model: _Model, arcs: list[Arc], xv: np.ndarray) -> list:
    """Lazy rows the incumbent ``xv`` violates (sub-tour, capacity, shared station)."""
    cuts = []
    for d in range(len(model.sc.drones)):
        cuts += cuts_for(model, d, [a for k, a in enumerate(arcs) if xv[k] and a.drone == d])
    if model.station_rows and station_shared(arcs, xv):
        cuts += model.station_rows
        model.station_rows = []
    return cuts


def lazy_solve(sc: TeamScenario, arcs: list[Arc], limit: float | None, w: float,
               stats, max_rounds: int, deadline: float = math.inf,
                start_routes=None, warm_at: float = math.inf
                ) -> tuple[np.ndarray, float] | None:
    """The lazy-cut loop.  ``start_routes`` is a callable giving the warm-start routes (or
    None); it is called once the loop is still running at wall time ``warm_at`` (the round
    then running is stopped there and solved again with the start)."""
    model = _Model(sc, arcs, limit, w)
    start = None
    rounds = 0
    while rounds < max_rounds:
        now = time.perf_counter()
        left = deadline - now
        if left <= 0:
            raise Budget(None, -math.inf)
        cold = start is None and start_routes is not None and now < warm_at
        if start is None and start_routes is not None and not cold:
            routes = start_routes()
            start = model.vector(routes) if routes else None
            start_routes = None
        cap = min(left, warm_at - now) if cold else left
        res: Result = model.solve(cap if math.isfinite(cap) else None, start)
        if res.status == SolverStatus.MAX_TIME and cold and cap < left:
            continue  # the warm start is due: solve this round again with it
        rounds += 1
        stats.rounds += 1
        if res.status == SolverStatus.MAX_TIME:  # the best so far, if it breaks no lazy row
            ok = res.x is not None and not _violated(model, arcs, res.x)
            raise Budget(res.x if ok else None, res.bound)
        if res.status != SolverStatus.OPTIMAL or res.x is None:
            return None
        xv, obj = res.x, res.objective
        cuts = _violated(model, arcs, xv)
        if not cuts:
            return xv, obj
        stats.cuts += len(cuts)
        model.ub += cuts
    raise AssignmentError(f"the assignment did not converge in {max_rounds} lazy-cut rounds",
                          reason="capacity")


class Budget(Exception):
    """The MILP exceeded its time budget: its best full-feasible solution (or None) and the
    dual bound of the round that was stopped (a lower bound of the optimum)."""

    def __init__(self, x: np.ndarray | None, bound: float) -> None:
        super().__init__("time budget")
        self.x, self.bound = x, bound
