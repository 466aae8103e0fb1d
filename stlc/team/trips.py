"""Trips of the set-partitioning assignment (``stlc.team.partition``): enumeration and costs.

A drone's route (see ``stlc.team.milp``) is a chain of *trips*: the first leaves its depot,
every later one leaves a refilling station; each visits at most ``c̄_d`` targets in some
order and ends at a station (or at the virtual sink when the mission has no stations).  A
trip is kept as ``(drone, start, targets A, end)`` with the cost of the *best* order of
``A`` — any other order of the same set between the same ends costs more and serves the
same targets, so it can never be in an optimal assignment.

Costs are sums of the arc costs of ``stlc.team.arcs.build_arcs`` (the same numbers as the
arc MILP, the heuristic and the seed): ``start → first`` (+ refill dwell when the start is
a station, + install), ``i → j`` (+ install), ``last → end``.  The best order through
every set of up to ``K`` targets for every (first, last) pair is a Held–Karp table built
size by size with numpy (``paths``); the trip cost of every (start, set, end) is then a
min-plus product with the entry and exit arcs.

Pruning (valid for every feasible route, so exactness is kept): a trip that starts at a
station ``s`` can only be flown after the drone reached ``s``; ``reach[d][s]`` is the
shortest walk from the depot to ``s`` over the arcs (Dijkstra, a lower bound of every
route prefix), and a trip with ``reach + cost > limit`` is dropped.  ``count_estimate``
says how many columns the enumeration would make before anything is built, so the caller
can refuse an instance too large for it (and use the arc formulation instead).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from stlc.team import TeamScenario
from stlc.team.arcs import Arc

Node = tuple[str, int]


@dataclass
class Trips:
    """Columns of one scenario: parallel arrays over the trips."""

    drone: np.ndarray  # (m,) drone index
    start: np.ndarray  # (m,) -1 = depot, s >= 0 = station s
    end: np.ndarray  # (m,) station index, or -1 = the sink (no stations)
    members: list[tuple[int, ...]]  # targets of each trip (sorted)
    cost: np.ndarray  # (m,) seconds


def max_run(sc: TeamScenario, d: int, limit: float, ins: float) -> int:
    """Largest number of targets one trip of drone ``d`` can hold (capacity, targets,
    and the horizon: every install costs at least the install dwell)."""
    k = min(sc.drones[d].capacity, len(sc.targets))
    if ins > 0 and math.isfinite(limit):
        k = min(k, int(math.floor(limit / ins + 1e-9)))
    return max(k, 0)


def count_estimate(sc: TeamScenario, limit: float, ins: float) -> int:
    """Upper bound of the number of trip columns (before pruning): per drone, every set of
    up to ``max_run`` targets from every start (depot, stations) to every end."""
    nt, ns = len(sc.targets), len(sc.stations)
    ends = max(ns, 1)
    total = 0
    for d in range(len(sc.drones)):
        k = max_run(sc, d, limit, ins)
        total += ends * (1 + (1 + ns) * sum(math.comb(nt, j) for j in range(1, k + 1)))
    return total


def _matrices(sc: TeamScenario, arcs: list[Arc], d: int):
    """Arc costs of drone ``d`` as matrices: entry (1 + ns, nt) from the depot / station,
    inner (nt, nt), exit (nt, ne) to a station / the sink, and depot → end (ne,)."""
    nt, ns = len(sc.targets), len(sc.stations)
    ne = max(ns, 1)
    ent = np.full((1 + ns, nt), np.inf)
    inner = np.full((nt, nt), np.inf)
    ext = np.full((nt, ne), np.inf)
    direct = np.full(ne, np.inf)
    for a in arcs:
        if a.drone != d:
            continue
        t, h = a.tail, a.head
        if t[0] in "DS" and h[0] == "T":
            ent[0 if t[0] == "D" else 1 + t[1], h[1]] = a.cost
        elif t[0] == "T" and h[0] == "T":
            inner[t[1], h[1]] = a.cost
        elif t[0] == "T":
            ext[t[1], h[1] if h[0] == "S" else 0] = a.cost
        else:
            direct[h[1] if h[0] == "S" else 0] = a.cost
    return ent, inner, ext, direct


def paths(inner: np.ndarray, kmax: int) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Held–Karp over the target sets of each size ``k ≤ kmax``: ``{k: (combos (m, k),
    H (m, k, k))}`` with ``H[r, f, l]`` the cheapest path through ``combos[r]`` from its
    ``f``-th to its ``l``-th member (sum of the inner arc costs; ``inf`` when ``f == l``
    for ``k > 1``)."""
    nt = inner.shape[0]
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    if kmax < 1 or nt == 0:
        return out
    out[1] = (np.arange(nt).reshape(-1, 1), np.zeros((nt, 1, 1)))
    for k in range(2, kmax + 1):
        combos = np.array(list(combinations(range(nt), k)), dtype=int).reshape(-1, k)
        prev_c, prev_h = out[k - 1]
        index = {tuple(c): r for r, c in enumerate(prev_c.tolist())}
        h = np.full((len(combos), k, k), np.inf)
        for j in range(k):  # position of the last member
            keep = [i for i in range(k) if i != j]
            sub = combos[:, keep]
            rows = np.fromiter((index[tuple(c)] for c in sub.tolist()), dtype=int,
                               count=len(sub))
            # H[r, f, j] = min_i Hprev[sub, f, i] + inner[sub_i, last]
            step = inner[sub, combos[:, j][:, None]]  # (m, k-1)
            best = np.min(prev_h[rows] + step[:, None, :], axis=2)  # (m, k-1) over f
            h[:, keep, j] = best
        out[k] = (combos, h)
    return out


def reach(ent: np.ndarray, inner: np.ndarray, ext: np.ndarray, direct: np.ndarray,
          ns: int) -> np.ndarray:
    """Shortest walk (s) from the depot to every station over the drone's arcs: a lower
    bound of the time at which the drone can first be at each station."""
    nt = inner.shape[0]
    # nodes: 0 = depot, 1..nt = targets, nt+1.. = stations
    dist = np.full(1 + nt + ns, np.inf)
    dist[0] = 0.0
    heap = [(0.0, 0)]
    while heap:
        dv, v = heapq.heappop(heap)
        if dv > dist[v]:
            continue
        if v == 0 or v > nt:
            row = ent[0 if v == 0 else v - nt]
            nxt = [(1 + j, row[j]) for j in range(nt)]
            if v == 0:
                nxt += [(1 + nt + s, direct[s]) for s in range(ns)]
        else:
            nxt = [(1 + j, inner[v - 1, j]) for j in range(nt)]
            nxt += [(1 + nt + s, ext[v - 1, s]) for s in range(ns)]
        for u, c in nxt:
            if math.isfinite(c) and dv + c < dist[u]:
                dist[u] = dv + c
                heapq.heappush(heap, (dist[u], u))
    return dist[1 + nt:]


def enumerate_trips(sc: TeamScenario, arcs: list[Arc], limit: float, ins: float) -> Trips:
    """Every trip that can be part of a route within ``limit`` (see the module docstring)."""
    ns = len(sc.stations)
    drone, start, end, members, cost = [], [], [], [], []
    cache: dict[bytes, dict] = {}
    for d in range(len(sc.drones)):
        ent, inner, ext, direct = _matrices(sc, arcs, d)
        ready = reach(ent, inner, ext, direct, ns) if ns else np.zeros(0)
        offset = np.concatenate([[0.0], ready])  # depot, stations
        kmax = max_run(sc, d, limit, ins)
        key = inner.tobytes() + bytes([kmax])
        if key not in cache:
            cache[key] = paths(inner, kmax)
        table = cache[key]
        for e in range(direct.shape[0]):  # the route that serves nothing
            if direct[e] <= limit + 1e-9:
                drone.append(d), start.append(-1), end.append(e if ns else -1)
                members.append(()), cost.append(float(direct[e]))
        for k, (combos, h) in table.items():
            # best over first f: entry[s, c_f] + H[f, l]  -> (m, starts, k_l)
            e_in = ent[:, combos].transpose(1, 0, 2)  # (m, starts, k)
            g = np.min(e_in[:, :, :, None] + h[:, None, :, :], axis=2)
            e_out = ext[combos]  # (m, k, ne)
            t = np.min(g[:, :, :, None] + e_out[:, None, :, :], axis=2)  # (m, starts, ne)
            ok = np.isfinite(t) & (t + offset[None, :, None] <= limit + 1e-9)
            r, s, e = np.nonzero(ok)
            drone += [d] * len(r)
            start += (s - 1).tolist()
            end += (e if ns else np.full(len(e), -1)).tolist()
            members += [tuple(c) for c in combos[r].tolist()]
            cost += t[r, s, e].tolist()
    return Trips(np.asarray(drone, dtype=int), np.asarray(start, dtype=int),
                 np.asarray(end, dtype=int), members, np.asarray(cost, dtype=float))


def best_order(sc: TeamScenario, arcs: list[Arc], d: int, start: int, members: tuple,
               end: int) -> list[int]:
    """The cheapest visiting order of ``members`` on a trip of drone ``d`` (the order whose
    cost ``enumerate_trips`` charged), by a small Held–Karp with back-pointers."""
    if len(members) <= 1:
        return list(members)
    ent, inner, ext, _ = _matrices(sc, arcs, d)
    mem = list(members)
    k = len(mem)
    e_in = ent[start + 1, mem]
    e_out = ext[mem, max(end, 0)]
    best: dict[tuple[int, int], tuple[float, int]] = {}
    for i in range(k):
        best[(1 << i, i)] = (e_in[i], -1)
    for mask in range(1, 1 << k):
        for last in range(k):
            if (mask, last) not in best:
                continue
            c0 = best[(mask, last)][0]
            for nxt in range(k):
                if mask & (1 << nxt):
                    continue
                c = c0 + inner[mem[last], mem[nxt]]
                key = (mask | (1 << nxt), nxt)
                if c < best.get(key, (math.inf, -1))[0]:
                    best[key] = (c, last)
    full = (1 << k) - 1
    last = min(range(k), key=lambda i: best.get((full, i), (math.inf,))[0] + e_out[i])
    order, mask = [], full
    while last >= 0:
        order.append(mem[last])
        prev = best[(mask, last)][1]
        mask &= ~(1 << last)
        last = prev
    return order[::-1]
