"""Heuristic task assignment for large teams: station split + local search (not optimal).

Used when the exact MILP (``stlc.team.milp``) exceeds its time budget.  The result respects
every rule the MILP has — each target once, a drone never carries more than its capacity
(it refills at a station between runs), each drone ends at a station, every route fits the
horizon with the MILP's own cost model (``milp.route_time``: the seed's obstacle-aware leg
times, dwells of ``n + 1`` steps) — and one more that the seed needs for separation:

* **Station exclusivity.**  With at least as many stations as drones each drone gets its own
  station (an optimal assignment of drones to stations by travel time from the start,
  ``scipy.optimize.linear_sum_assignment``), where it refills and which is its home; no
  other drone ever enters it, so two drones are never in one station at once.  With fewer
  stations every drone may use every station (and the separation is left to the
  refinement).

Search space: per drone an ordered list of targets.  The refills are not searched: for a
given order, ``split`` places them optimally by dynamic programming over (targets served,
station) — runs of at most ``capacity`` targets, a refill dwell before each later run.

Objective: ``Σ_d T_d + max_d T_d`` (route times, s) — the MILP's total plus the makespan, so
that the work is spread and the refinement gets slack — with ``1000 ×`` the excess over the
horizon limit added.  Search: the greedy routes (``stlc.team.greedy``) as the start, then
best-improvement local search with three moves (relocate a target to any position of any
drone, swap two targets, reverse a stretch of one drone's order), then ``kicks`` rounds of
a deterministic perturbation (a random swap-pair, seeded) each followed by local search,
keeping the best.  Everything is deterministic.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.optimize import linear_sum_assignment

from stlc.team import AssignmentError, TeamScenario, centre

PENALTY = 1000.0  # s of objective per s of route beyond the horizon limit


class Costs:
    """Leg-time tables: per drone, node 0 = its start, 1..nt = targets, nt+1.. = stations."""

    def __init__(self, sc: TeamScenario, leg) -> None:
        self.sc = sc
        self.nt, self.ns = len(sc.targets), len(sc.stations)
        pts = [centre(b) for b in sc.targets] + [centre(b) for b in sc.stations]
        self.t = []
        for d in sc.drones:
            allp = [np.asarray(d.start, dtype=float), *pts]
            m = np.array([[0.0 if i == j else leg(a, b, d) for j, b in enumerate(allp)]
                          for i, a in enumerate(allp)])
            self.t.append(m)


def homes(sc: TeamScenario, costs: Costs) -> list[list[int]] | None:
    """Allowed stations per drone (indices): its own one when stations ≥ drones, else all."""
    nd, ns, nt = len(sc.drones), len(sc.stations), len(sc.targets)
    if ns < nd:
        return None
    c = np.array([[costs.t[d][0, 1 + nt + s] for s in range(ns)] for d in range(nd)])
    rows, cols = linear_sum_assignment(np.where(np.isfinite(c), c, 1e9))
    out = [[0] for _ in range(nd)]
    for r, s in zip(rows, cols, strict=True):
        out[r] = [int(s)]
    return out


def split(costs: Costs, d: int, seq: list[int], cap: int, stations: list[int],
          ins: float, rs: float) -> tuple[float, list[tuple[str, int]]]:
    """Least route time of drone ``d`` serving targets ``seq`` in that order (refills placed
    optimally, ending at a station of ``stations``) and the route as (kind, index) pairs."""
    t, nt, n = costs.t[d], costs.nt, len(seq)
    if n and cap <= 0:
        return math.inf, []
    S = [1 + nt + s for s in stations]
    T = [1 + j for j in seq]
    # run[i][L]: time from the first target seq[i] through seq[i+L-1] (installs included)
    f = [dict.fromkeys(stations, math.inf) for _ in range(n + 1)]
    back: list[dict] = [{} for _ in range(n + 1)]
    for si, s in zip(stations, S, strict=True):
        f[0][si] = t[0, s] if n == 0 else math.inf
    for i in range(0, n):
        # start a run at seq[i]: from the depot (i == 0) or after a refill at station s
        origins = [(None, 0, 0.0)] if i == 0 else [
            (si, s, f[i][si] + rs) for si, s in zip(stations, S, strict=True)
            if f[i][si] < math.inf]
        for o, onode, base in origins:
            acc = base + t[onode, T[i]] + ins
            for L in range(1, min(cap, n - i) + 1):
                if L > 1:
                    acc += t[T[i + L - 2], T[i + L - 1]] + ins
                last = T[i + L - 1]
                for si, s in zip(stations, S, strict=True):
                    v = acc + t[last, s]
                    if v < f[i + L][si]:
                        f[i + L][si] = v
                        back[i + L][si] = (i, o)
    best = min(stations, key=lambda s: f[n][s])
    total = f[n][best]
    if not math.isfinite(total):
        return math.inf, []
    route: list[tuple[str, int]] = []
    k, s = n, best
    while True:
        route.append(("S", s))
        if k == 0:
            break
        i, o = back[k][s]
        route += [("T", j) for j in reversed(seq[i:k])]
        if o is None:
            break
        k, s = i, o
    return total, route[::-1]


class Search:
    def __init__(self, sc: TeamScenario, costs: Costs, limit: float, ins: float, rs: float,
                 deadline: float = math.inf):
        self.sc, self.costs, self.limit, self.ins, self.rs = sc, costs, limit, ins, rs
        self.deadline = deadline  # wall time (perf_counter) at which improving stops
        allowed = homes(sc, costs)
        self.allowed = allowed or [list(range(len(sc.stations)))] * len(sc.drones)
        self.caps = [d.capacity for d in sc.drones]

    def time(self, d: int, seq: list[int]) -> float:
        return split(self.costs, d, seq, self.caps[d], self.allowed[d], self.ins, self.rs)[0]

    def score(self, times: list[float]) -> float:
        over = sum(max(0.0, x - self.limit) for x in times)
        return sum(times) + max(times) + PENALTY * over

    def improve(self, seqs: list[list[int]]) -> tuple[list[list[int]], list[float]]:
        times = [self.time(d, s) for d, s in enumerate(seqs)]
        cur = self.score(times)
        nd = len(seqs)
        while time.perf_counter() < self.deadline:
            best = None
            for a in range(nd):
                for ia, j in enumerate(seqs[a]):
                    rest = seqs[a][:ia] + seqs[a][ia + 1:]
                    ta = self.time(a, rest)
                    for b in range(nd):
                        base = rest if b == a else seqs[b]
                        for k in range(len(base) + 1):
                            if b == a and k == ia:
                                continue
                            new = base[:k] + [j] + base[k:]
                            cand = list(times)
                            if b == a:
                                cand[a] = self.time(a, new)
                            else:
                                cand[a], cand[b] = ta, self.time(b, new)
                            sc = self.score(cand)
                            if sc < cur - 1e-9 and (best is None or sc < best[0]):
                                best = (sc, {a: rest, b: new} if b != a else {a: new}, cand)
                    for b in range(a + 1, nd):
                        for ib in range(len(seqs[b])):
                            na, nb = list(seqs[a]), list(seqs[b])
                            na[ia], nb[ib] = nb[ib], na[ia]
                            cand = list(times)
                            cand[a], cand[b] = self.time(a, na), self.time(b, nb)
                            sc = self.score(cand)
                            if sc < cur - 1e-9 and (best is None or sc < best[0]):
                                best = (sc, {a: na, b: nb}, cand)
                s = seqs[a]
                for i in range(len(s)):
                    for k in range(i + 2, len(s) + 1):
                        new = s[:i] + s[i:k][::-1] + s[k:]
                        cand = list(times)
                        cand[a] = self.time(a, new)
                        sc = self.score(cand)
                        if sc < cur - 1e-9 and (best is None or sc < best[0]):
                            best = (sc, {a: new}, cand)
            if best is None:
                return seqs, times
            cur, change, times = best
            seqs = [change.get(d, s) for d, s in enumerate(seqs)]
        return seqs, times  # the deadline: the best so far


def local_routes(sc: TeamScenario, leg, dwell: tuple[float, float], limit: float,
                 start: dict[str, list[str]], kicks: int = 30, seed: int = 0,
                 deadline: float = math.inf) -> dict[str, list[str]]:
    """Routes (target and station names, ending at the home station) from the start routes
    ``start`` (e.g. the greedy ones; stations in them are ignored) — see the module doc."""
    ins, rs = dwell
    costs = Costs(sc, leg)
    search = Search(sc, costs, limit, ins, rs, deadline)
    tidx = {b.name: j for j, b in enumerate(sc.targets)}
    seqs = [[tidx[r] for r in start.get(d.name, []) if r in tidx] for d in sc.drones]
    for d, dr in enumerate(sc.drones):  # a drone that cannot carry hands its targets over
        if dr.capacity <= 0 and seqs[d]:
            to = max(range(len(sc.drones)), key=lambda e: sc.drones[e].capacity)
            seqs[to] += seqs[d]
            seqs[d] = []
    seqs, times = search.improve(seqs)
    best = (search.score(times), seqs, times)
    rng = np.random.default_rng(seed)
    nd = len(seqs)
    for _ in range(kicks if nd > 1 else 0):
        if time.perf_counter() >= deadline:
            break
        cur = [list(s) for s in best[1]]
        for _ in range(2):
            a, b = rng.choice(nd, 2, replace=False)
            if cur[a] and cur[b]:
                ia, ib = rng.integers(len(cur[a])), rng.integers(len(cur[b]))
                cur[a][ia], cur[b][ib] = cur[b][ib], cur[a][ia]
            elif cur[a]:
                cur[b].append(cur[a].pop(rng.integers(len(cur[a]))))
        cur, times = search.improve(cur)
        sc_ = search.score(times)
        if sc_ < best[0] - 1e-9:
            best = (sc_, cur, times)
    _, seqs, times = best
    if any(not math.isfinite(x) for x in times):
        raise AssignmentError("no assignment of the targets to the drones exists "
                              "(capacities and refilling stations)", reason="capacity")
    out = {}
    for d, dr in enumerate(sc.drones):
        _, route = split(costs, d, seqs[d], dr.capacity, search.allowed[d], ins, rs)
        out[dr.name] = [sc.targets[i].name if k == "T" else sc.stations[i].name
                        for k, i in route]
    return out
