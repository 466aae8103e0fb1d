"""Task assignment as set partitioning over whole routes, by column generation (HiGHS).

A column is one drone's complete route: a chain of trips (``stlc.team.trips``: the depot
trip, then trips from station to station), with the targets ``S`` it serves, the stations
``U`` it enters and its cost (s, the sum of the trips').  The master problem:

    min Σ cost_r x_r   s.t.  Σ_{r ∋ j} x_r = 1 (every target j),  Σ_{r of d} x_r = 1
    (every drone d),  Σ_{r: q ∈ U_r} x_r ≤ 1 (every station q, when 1 < drones ≤ stations:
    a station serves one drone), x binary,

plus one artificial column per target (cost ``P``) so that every restricted LP is
feasible.  Its LP relaxation is the strong one of set partitioning (the trip-level models
of ``stlc.team.partition`` lose 6–8 % there, because fractional trips of one drone may
reuse a target across trips).

Pricing (exact).  With the LP duals π_j, σ_d, μ_q a route's reduced cost is
``cost − π(S) − σ_d − μ(U)``.  Per drone, labels ``(S, q, U)`` (targets served, station the
drone is at, stations entered) keep the cheapest prefix (at a fixed key cheaper is better in
time and reduced cost alike); every label is a route (the drone may end where it is).  A
label is extended by every trip from ``q`` disjoint from ``S`` within the horizon; it is
dropped when its reduced cost plus a completion bound — ``Σ_{j ∉ S} min(0, ρ_j)``, ``ρ_j``
the least reduced cost per target of any station trip holding ``j`` — cannot go below the
threshold.  The first rounds stop at ``HEURISTIC_LABELS`` labels; the LP bound is only
claimed after a round that explored everything.

Closing.  With ``LB`` the LP value (rounded up to a whole mission step: every cost is a
whole number of steps) and ``UB`` the best integer solution over the columns (HiGHS, time
limit), ``UB ≤ LB`` proves optimality.  Otherwise every route with reduced cost ≤ ``UB − LB
− Δt`` is enumerated with the same labels (threshold instead of 0) — no route outside that
set can be in an assignment better than UB — and the integer program over them is solved:
its optimum is the optimum.  A deadline bounds every stage; when it ends, the best integer
solution and ``LB`` are returned (not optimal, with the gap).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from stlc.team import TeamScenario
from stlc.team.arcs import Arc
from stlc.solvers.highs import IncrementalLp, Result, solve_mip
from stlc.team.pricing import EXACT_LABELS, DroneTrips, Labels, chain, labels
from stlc.team.trips import Trips, best_order

HEURISTIC_LABELS = 1000  # labels per drone in a heuristic pricing round
EPS = 1e-7
#: presolve off: on these set-partitioning models it costs 5x the search (3×9: 0.95 s vs
#: 0.18 s for the 671-column model)
IP_OPTIONS: dict[str, object] = {"presolve": "off"}
PER_ROUND = 60  # columns per drone added in a pricing round


@dataclass
class Column:
    drone: int
    trips: tuple[int, ...]  # trip indices in flying order
    targets: int  # bitmask
    stations: int  # bitmask of stations entered
    cost: float


@dataclass
class CGResult:
    routes: dict[str, list[str]] | None
    times: dict[str, float]
    objective: float
    bound: float  # lower bound of the optimum (-inf if none was proved)
    status: str  # "optimal" | "time" | "infeasible"
    columns: int = 0
    rounds: int = 0
    stages: dict[str, float] = field(default_factory=dict)


class _Master:
    """The restricted master LP (``highs.IncrementalLp``: columns added in place, warm
    simplex).  Rows:
    targets (= 1), drones (= 1), stations (≤ 1, when exclusive), and the rounded refill
    row ``Σ_r k_r x_r ≥ R`` (``k_r`` station trips of route r) when ``R > 0``."""

    def __init__(self, nt: int, nd: int, ns: int, exclusive: bool, big: float, refills: int,
                 refill_price: float):
        self.nt, self.nd, self.ns, self.ex, self.refills = nt, nd, ns, exclusive, refills
        self.lo = np.concatenate([np.ones(nt + nd), np.full(ns if exclusive else 0, -np.inf),
                                  [refills] if refills else []])
        self.hi = np.concatenate([np.ones(nt + nd), np.ones(ns if exclusive else 0),
                                  [np.inf] if refills else []])
        nrow = len(self.lo)
        self.lp = IncrementalLp(self.lo, self.hi)
        self.cols: list[Column] = []
        self.big, self.refill_price = big, refill_price
        # artificials (cost P): target j unserved, drone d without a route, a refill
        arts = list(range(nt + nd)) + ([nrow - 1] if refills else [])
        for r in arts:  # (the refill row's at the price of a route: a cheaper early γ)
            price = big if r < nt + nd else refill_price
            self.lp.add_cols([price], [0.0], [np.inf], [0], [r], [1.0])
        self.arts = arts
        self.n_art = len(arts)
        self.seen: set[tuple[int, int, int, int]] = set()
        self.col_rows: list[np.ndarray] = []
        self.col_vals: list[np.ndarray] = []
        self._mat = None

    def rows_of(self, c: Column) -> tuple[list[int], list[float]]:
        rows = [j for j in range(self.nt) if (c.targets >> j) & 1] + [self.nt + c.drone]
        if self.ex:
            rows += [self.nt + self.nd + q for q in range(self.ns) if (c.stations >> q) & 1]
        vals = [1.0] * len(rows)
        if self.refills and len(c.trips) > 1:
            rows.append(len(self.lo) - 1)
            vals.append(float(len(c.trips) - 1))
        return rows, vals

    def add(self, cols: list[Column]) -> int:
        new = []
        for c in cols:
            key = (c.drone, c.targets, c.stations, int(round(c.cost * 1e6)))
            if key not in self.seen:
                self.seen.add(key)
                new.append(c)
        if not new:
            return 0
        starts, index, vals = [], [], []
        for c in new:
            starts.append(len(index))
            r, v = self.rows_of(c)
            self.col_rows.append(np.asarray(r, dtype=np.int32))
            self.col_vals.append(np.asarray(v))
            index += r
            vals += v
        self.lp.add_cols([c.cost for c in new], np.zeros(len(new)), np.ones(len(new)), starts,
                         index, vals)
        self.cols += new
        self._mat = None
        return len(new)

    def solve_lp(self, deadline: float):
        return self.lp.solve(deadline - time.perf_counter())

    def matrix(self):
        """The constraint matrix (artificials first) and the cost vector."""
        if self._mat is None:
            n = self.n_art + len(self.cols)
            lens = [len(r) for r in self.col_rows]
            rows = np.concatenate([np.asarray(self.arts, dtype=np.int32)] + self.col_rows)
            cols = np.concatenate([np.arange(self.n_art),
                                   np.repeat(np.arange(self.n_art, n), lens)])
            vals = np.concatenate([np.ones(self.n_art)] + self.col_vals)
            a = sp.csc_matrix((vals, (rows, cols)), shape=(len(self.lo), n))
            cost = np.concatenate([[self.big if r < self.nt + self.nd else self.refill_price
                                    for r in self.arts], [c.cost for c in self.cols]])
            self._mat = (a, cost)
        return self._mat

    def reduced(self, y: np.ndarray) -> np.ndarray:
        """Reduced costs of all columns (artificials first) under the duals ``y``."""
        a, cost = self.matrix()
        return cost - a.T @ y

    def solve_ip(self, time_limit: float, start: np.ndarray | None = None,
                 keep: np.ndarray | None = None) -> Result:
        """The integer program over the columns ``keep`` (all by default); ``x`` comes back
        over all columns."""
        a, cost = self.matrix()
        n = a.shape[1]
        sel = np.arange(n) if keep is None else np.flatnonzero(keep)
        upper = np.concatenate([np.full(self.n_art, np.inf), np.ones(len(self.cols))])
        res = solve_mip(cost[sel], np.ones(len(sel), dtype=bool), upper[sel], a[:, sel],
                        self.lo, self.hi, time_limit=time_limit,
                        start=None if start is None else start[sel], options=IP_OPTIONS)
        if res.x is not None:
            x = np.zeros(n)
            x[sel] = np.round(res.x)
            res.x = x
        return res


def _column(lab: Labels, i: int, dr: DroneTrips, d: int) -> Column:
    seq = chain(lab, i, dr)
    ends = {int(dr.end[np.searchsorted(dr.idx, t)]) for t in seq}
    return Column(d, seq, int(lab.arrays()[0][i]), sum(1 << e for e in ends if e >= 0),
                  float(lab.arrays()[3][i]))


def _start_columns(sc: TeamScenario, trips: Trips, routes: dict[str, list[str]]):
    tix = {b.name: j for j, b in enumerate(sc.targets)}
    six = {b.name: q for q, b in enumerate(sc.stations)}
    index = {(int(d), int(s), mem, int(e)): t for t, (d, s, e, mem) in
             enumerate(zip(trips.drone, trips.start, trips.end, trips.members, strict=True))}
    out = []
    for d, dr in enumerate(sc.drones):
        start, mem, chain = -1, [], []
        for name in routes.get(dr.name, []):
            if name in tix:
                mem.append(tix[name])
            else:
                chain.append(index.get((d, start, tuple(sorted(mem)), six[name])))
                start, mem = six[name], []
        if mem or not chain or None in chain:
            return []
        out.append(Column(d, tuple(chain), sum(1 << j for t in chain for j in trips.members[t]),
                          sum(1 << int(trips.end[t]) for t in chain),
                          float(sum(trips.cost[t] for t in chain))))
    return out


def _price(drones, y, nt, nd, ns, exclusive, refills, limit, thr, cap, deadline, single,
           every=False):
    """Columns with reduced cost < ``thr`` (per drone the best ``PER_ROUND``, or ``every``
    one), whether every drone's labelling was complete, and each drone's least rc."""
    pi, sigma = y[:nt], y[nt:nt + nd]
    mu = y[nt + nd:nt + nd + ns] if exclusive else np.zeros(ns)
    gamma = float(y[-1]) if refills else 0.0
    found, complete, best = [], True, []
    for d, dr in enumerate(drones):
        lab, done = labels(dr, pi, mu, gamma, sigma[d], limit, thr, cap, deadline,
                            exclusive, single)
        complete &= done
        live = np.fromiter(lab.best.values(), dtype=int, count=len(lab.best))
        rcs = lab.arrays()[4][live] - sigma[d] if len(live) else np.zeros(0)
        best.append(float(min(rcs.min(), 0.0)) if len(rcs) else 0.0)
        sel = live[rcs < thr]
        sel = sel[np.argsort(rcs[rcs < thr])]
        found += [_column(lab, int(i), dr, d) for i in (sel if every else sel[:PER_ROUND])]
    return found, complete, best


def routes_of(sc: TeamScenario, arcs: list[Arc], trips: Trips, cols: list[Column]):
    routes, times = {}, {}
    for c in sorted(cols, key=lambda c: c.drone):  # in the drones' order
        dr = sc.drones[c.drone]
        names: list[str] = []
        for t in c.trips:
            seq = best_order(sc, arcs, c.drone, int(trips.start[t]), trips.members[t],
                             int(trips.end[t]))
            names += [sc.targets[j].name for j in seq]
            if trips.end[t] >= 0:
                names.append(sc.stations[int(trips.end[t])].name)
        routes[dr.name], times[dr.name] = names, c.cost
    return routes, times


def solve(sc: TeamScenario, arcs: list[Arc], trips: Trips, limit: float, deadline: float,
          start_routes: dict[str, list[str]] | None = None) -> CGResult:
    """Column generation, then closing (module docstring), until ``deadline`` (wall)."""
    nt, nd, ns = len(sc.targets), len(sc.drones), len(sc.stations)
    exclusive = 1 < nd <= ns
    single = exclusive and nd == ns  # every station is one drone's home, its only station
    step = sc.step
    masks = np.array([sum(1 << j for j in mem) for mem in trips.members], dtype=np.int64)
    member = np.zeros((len(trips.cost), nt))
    for t, mem in enumerate(trips.members):
        member[t, list(mem)] = 1.0
    drones = [DroneTrips(trips, d, masks, member) for d in range(nd)]
    big = 10.0 * nd * max(limit, 1.0) + 1000.0
    spare = nt - sum(min(max(d.capacity, 0), nt) for d in sc.drones)
    cmax = max((d.capacity for d in sc.drones), default=0)
    refills = math.ceil(spare / cmax) if spare > 0 and cmax > 0 and ns else 0
    master = _Master(nt, nd, ns, exclusive, big, refills, 2.0 * max(limit, 1.0))
    init = []  # one-trip routes: per drone and target set, the cheapest end station
    for d, dr in enumerate(drones):
        order = dr.dep[np.lexsort((dr.cost[dr.dep], dr.mask[dr.dep]))]
        first = np.ones(len(order), dtype=bool)
        first[1:] = dr.mask[order][1:] != dr.mask[order][:-1]
        init += [Column(d, (int(dr.idx[i]),), int(dr.mask[i]),
                        (1 << int(dr.end[i])) if dr.end[i] >= 0 else 0, float(dr.cost[i]))
                 for i in order[first]]
    known = _start_columns(sc, trips, start_routes) if start_routes else []
    master.add(init + known)
    res = CGResult(None, {}, math.inf, -math.inf, "time")
    cap, lb, y, exact = HEURISTIC_LABELS, -math.inf, None, False
    t0 = time.perf_counter()
    try:
        while True:
            ok, obj, y = master.solve_lp(deadline)
            if not ok:
                raise TimeoutError
            res.rounds += 1
            cols, complete, best = _price(drones, y, nt, nd, ns, exclusive, refills, limit, -EPS,
                                          cap, deadline, single)
            if complete:
                lb = max(lb, obj + sum(best))  # Lagrangian bound
            if master.add(cols):
                continue
            if complete:
                lb, exact = obj, True
                break
            if cap >= EXACT_LABELS:
                break  # too many labels to prove the LP bound
            cap = EXACT_LABELS
    except TimeoutError:
        pass
    res.stages["lp_s"] = time.perf_counter() - t0
    lbr = math.ceil(lb / step - 1e-6) * step if math.isfinite(lb) else lb
    res.bound = lbr
    left = deadline - time.perf_counter()
    if left <= 0:
        return _finish(res, sc, arcs, trips, master, None, known)
    start = None
    if known:
        start = np.zeros(master.n_art + len(master.cols))
        for c in known:
            start[master.n_art + master.cols.index(c)] = 1.0

    def price(thr):
        return _price(drones, y, nt, nd, ns, exclusive, refills, limit, thr, EXACT_LABELS,
                      deadline, single, every=True)

    keep = None
    if exact:  # first only the columns of small reduced cost (the rest is settled below)
        tau = max(0.02 * abs(obj), 10 * step)
        keep = master.reduced(y) <= tau
        keep[:master.n_art] = True
        if start is not None:
            keep |= start > 0.5
    ip = master.solve_ip(left, start, keep)
    ub = ip.objective if ip.x is not None else math.inf
    if ip.x is not None and ub < big and ub <= lbr + 1e-6:
        res.status = "optimal"
        x = _balance(master, ip.x, ub, obj, y, exact, price, deadline) if exact else ip.x
        return _finish(res, sc, arcs, trips, master, x, known)
    if exact and ip.x is not None and ub < big:
        # every column has reduced cost >= 0: only those with rc <= UB - Δt - LP can be in
        # a better assignment; enumerate them all, then solve over them and the incumbent
        thr = ub - step - obj + 1e-6
        try:
            cols, complete, _ = _price(drones, y, nt, nd, ns, exclusive, refills, limit, thr,
                                       EXACT_LABELS, deadline, single, every=True)
            if complete:
                master.add(cols)
                inc = _extend(ip.x, master)
                keep = (master.reduced(y) <= thr) | (inc > 0.5)
                keep[:master.n_art] = True
                res.stages["enumerated"] = int(keep.sum()) - master.n_art
                ip2 = master.solve_ip(max(deadline - time.perf_counter(), 1e-3), inc, keep)
                if ip2.status in ("optimal", "infeasible"):
                    res.status = "optimal"
                    if ip2.x is not None and ip2.objective < ub:
                        ip = ip2
                    res.bound = min(ub, ip2.objective)
                    x = _balance(master, ip.x, res.bound, obj, y, exact, price, deadline)
                    return _finish(res, sc, arcs, trips, master, x, known)
                if ip2.x is not None and ip2.objective <= ub:
                    ip = ip2
                res.bound = max(res.bound, ip2.bound)
        except TimeoutError:
            pass
    return _finish(res, sc, arcs, trips, master, ip.x, known)


def _balance(master: _Master, x, best: float, obj: float, y, exact: bool, price,
             deadline: float):
    """Among the assignments of optimal total ``best``, one of least makespan (a tie-break:
    equal totals, work spread over the drones): every column of reduced cost ≤ best − LP
    (all that an optimal assignment can use) is enumerated, then ``min M`` s.t. the rows,
    ``Σ cost·x ≤ best`` and ``cost_r x_r ≤ M``.  Keeps ``x`` when anything is missing."""
    if not exact or time.perf_counter() >= deadline:
        return x
    try:
        cols, complete, _ = price(best - obj + 1e-6)
    except TimeoutError:
        return x
    if not complete:
        return x
    master.add(cols)
    x = _extend(x, master)
    a, cost = master.matrix()
    keep = (master.reduced(y) <= best - obj + 1e-6) | (x > 0.5)
    keep[:master.n_art] = False
    sel = np.flatnonzero(keep)
    k = len(sel)
    sub, c = a[:, sel], cost[sel]
    rows = sp.vstack([sp.hstack([sub, sp.csc_matrix((sub.shape[0], 1))]),
                      sp.hstack([sp.csc_matrix(c[None, :]), sp.csc_matrix((1, 1))]),
                      sp.hstack([sp.diags(c), -sp.csc_matrix(np.ones((k, 1)))])]).tocsc()
    lo = np.concatenate([master.lo, [-np.inf], np.full(k, -np.inf)])
    hi = np.concatenate([master.hi, [best + 1e-6], np.zeros(k)])
    start = np.concatenate([x[sel], [float(np.max(c * x[sel]))]])
    res = solve_mip(np.concatenate([np.zeros(k), [1.0]]),
                    np.concatenate([np.ones(k, dtype=bool), [False]]),
                    np.concatenate([np.ones(k), [np.inf]]), rows, lo, hi,
                    time_limit=min(max(deadline - time.perf_counter(), 1e-3), 5.0),
                    start=start, options=IP_OPTIONS)
    if res.x is None or float(c @ np.round(res.x[:k])) > best + 1e-6:
        return x
    if float(np.max(c * np.round(res.x[:k]))) >= float(np.max(c * x[sel])) - 1e-9:
        return x  # no shorter makespan: keep the first optimum
    out = np.zeros_like(x)
    out[sel] = np.round(res.x[:k])
    return out


def _extend(x, master: _Master):
    if x is None:
        return None
    out = np.zeros(master.n_art + len(master.cols))
    out[:len(x)] = np.round(x)
    return out


def _finish(res: CGResult, sc, arcs, trips, master: _Master, x, known) -> CGResult:
    res.columns = len(master.cols)
    if x is not None and not np.any(np.round(x[:master.n_art]) > 0.5):
        chosen = [master.cols[k - master.n_art] for k in np.flatnonzero(np.round(x) > 0.5)
                  if k >= master.n_art]
        res.routes, res.times = routes_of(sc, arcs, trips, chosen)
        res.objective = float(sum(c.cost for c in chosen))
    elif known:
        res.routes, res.times = routes_of(sc, arcs, trips, known)
        res.objective = float(sum(c.cost for c in known))
    if res.routes is None:
        res.status = "time" if res.status != "infeasible" else res.status
    return res
