"""Lower bounds of the route times of any assignment, for the horizon diagnostic (STL503).

A too-short horizon is reported from a *bound*, never from a second exact solve without
the horizon (which is exponential in the targets and had no time budget).  Both bounds
hold for every assignment that serves every target, whatever the horizon, and use the
assignment's own arc costs (``stlc.team.arcs``: travel rounded to steps, install dwell on
arcs into a target, refill dwell on arcs out of a station):

* **reach** — a target ``j`` is served by some drone ``d`` whose route walks from its depot
  through ``j`` to a station (or the sink); that walk costs at least the shortest walk
  depot → ``j`` plus the shortest walk ``j`` → any end over ``d``'s arcs (Dijkstra).  So the
  longest route is at least ``max_j min_d`` of that;
* **work** — the routes together enter every target once (each entry at least the cheapest
  arc into it), at least ``R = ⌈(targets − Σ capacities) / max capacity⌉`` of those entries
  come from a station (each at least the cheapest station arc into it, refill dwell
  included), and every drone ends with an arc into a station; the longest route is at least
  the total divided by the number of drones.

The final refilling dwell at home (``tail``) is added to both, as the horizon check does.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from stlc.team import TeamScenario
from stlc.team.arcs import Arc

Node = tuple[str, int]


def _dijkstra(edges: dict[Node, list[tuple[Node, float]]], sources: dict[Node, float]):
    dist = dict(sources)
    heap = [(c, v) for v, c in sources.items()]
    heapq.heapify(heap)
    while heap:
        dv, v = heapq.heappop(heap)
        if dv > dist.get(v, math.inf):
            continue
        for u, c in edges.get(v, []):
            if dv + c < dist.get(u, math.inf):
                dist[u] = dv + c
                heapq.heappush(heap, (dist[u], u))
    return dist


def route_bounds(sc: TeamScenario, arcs: list[Arc], tail: float) -> tuple[float, float]:
    """``(reach, work)`` lower bounds (s) of the longest route time plus ``tail``."""
    nd, nt = len(sc.drones), len(sc.targets)
    reach = 0.0
    best_in = np.full(nt, math.inf)  # cheapest arc into j from the depot or a target
    best_st = np.full(nt, math.inf)  # cheapest arc into j from a station
    ends = np.full(nd, math.inf)
    serve = np.full(nt, math.inf)
    for d in range(nd):
        fwd: dict[Node, list[tuple[Node, float]]] = {}
        bwd: dict[Node, list[tuple[Node, float]]] = {}
        for a in arcs:
            if a.drone != d:
                continue
            fwd.setdefault(a.tail, []).append((a.head, a.cost))
            bwd.setdefault(a.head, []).append((a.tail, a.cost))
            if a.head[0] == "T":
                j = a.head[1]
                if a.tail[0] == "S":
                    best_st[j] = min(best_st[j], a.cost)
                else:
                    best_in[j] = min(best_in[j], a.cost)
            else:
                ends[d] = min(ends[d], a.cost)
        to = _dijkstra(fwd, {("D", d): 0.0})
        back = _dijkstra(bwd, {v: 0.0 for a in arcs if a.drone == d
                               for v in [a.head] if v[0] in "SE"})
        for j in range(nt):
            serve[j] = min(serve[j], to.get(("T", j), math.inf) + back.get(("T", j), math.inf))
    if nt:
        reach = float(serve.max())
    spare = nt - sum(min(max(d.capacity, 0), nt) for d in sc.drones)
    cmax = max((d.capacity for d in sc.drones), default=0)
    refills = math.ceil(spare / cmax) if spare > 0 and cmax > 0 else 0
    entry = np.minimum(best_in, best_st)
    extra = np.sort(best_st - entry)  # what entering from a station adds (>= 0)
    work = float(entry.sum() + extra[:refills].sum() + ends.sum()) / max(nd, 1)
    return reach + tail, work + tail
