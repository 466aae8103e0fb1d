"""A greedy task assignment: the starting point of the heuristic (``stlc.team.local``) that
stands in when the exact MILP (``stlc.team.milp``) exceeds its time budget on a large
team, and the last resort without stations.  Not optimal, but every target is served
once, capacities and refills are respected, each drone ends at a station (its own one when
there are enough), and every route is checked against the horizon with the MILP's own
cost model (``milp.route_time``).

Rule: repeatedly, the (drone, target) pair with the earliest finishing time is chosen — a
drone's clock is its route time so far, and a drone that is empty first flies to the
station nearest to its position (a refill) — until every target is served; then each
drone, the busiest first, flies to the nearest station not yet taken as a home (or the
nearest one when there are fewer stations than drones).
"""

from __future__ import annotations

import numpy as np

from stlc.team import AssignmentError, TeamScenario, centre


def greedy_routes(sc: TeamScenario, leg, dwell: tuple[float, float]) -> dict[str, list[str]]:
    """``leg(p0, p1, drone) -> s`` is the travel time; ``dwell`` = (install, refill) s."""
    ins, rs = dwell
    pos = {d.name: np.asarray(d.start, dtype=float) for d in sc.drones}
    clock = {d.name: 0.0 for d in sc.drones}
    load = {d.name: d.capacity for d in sc.drones}
    routes: dict[str, list[str]] = {d.name: [] for d in sc.drones}
    homes: set[str] = set()
    open_targets = list(sc.targets)

    def nearest_station(p: np.ndarray, drone, exclude: set[str] = frozenset()):
        cands = [s for s in sc.stations if s.name not in exclude] or list(sc.stations)
        return min(cands, key=lambda s: leg(p, centre(s), drone))

    while open_targets:
        best = None
        for d in sc.drones:
            if d.capacity == 0:
                continue
            p, t = pos[d.name], clock[d.name]
            via = None
            if load[d.name] == 0:
                if not sc.stations:
                    continue
                via = nearest_station(p, d)
                t += leg(p, centre(via), d) + rs
                p = centre(via)
            for q in open_targets:
                finish = t + leg(p, centre(q), d) + ins
                if best is None or finish < best[0]:
                    best = (finish, d, q, via)
        if best is None:
            raise AssignmentError("no assignment of the targets to the drones exists "
                                  "(capacities and refilling stations)", reason="capacity")
        finish, d, q, via = best
        if via is not None:
            routes[d.name].append(via.name)
            load[d.name] = d.capacity
        routes[d.name].append(q.name)
        load[d.name] -= 1
        clock[d.name], pos[d.name] = finish, centre(q)
        open_targets.remove(q)
    if sc.stations:
        order = sorted(sc.drones, key=lambda d: -clock[d.name])  # the busiest choose first
        for d in order:
            exclude = homes if len(sc.stations) >= len(sc.drones) else set()
            home = nearest_station(pos[d.name], d, exclude)
            homes.add(home.name)
            routes[d.name].append(home.name)
    return routes
