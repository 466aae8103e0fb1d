"""The cost model of the task assignment (paper B §IV-B): arcs, leg and dwell times.

Shared by the exact MILP (``stlc.team.milp``), the heuristic (``stlc.team.local``) and the
seed (``stlc.team.seed``), so that the three agree to the sample: a leg costs the seed's
obstacle-aware rest-to-rest travel time (``stlc.team.paths``; detours included, each
sub-leg rounded up to whole mission steps), a visit ``(n+1)`` steps of dwell.  See the
docstring of ``stlc.team.milp`` for which arcs exist and what each is charged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stlc.team import AssignmentError, TeamScenario, centre, samples_for
from stlc.team.paths import leg_steps, router_for
from stlc.team.primitives import min_duration

Node = tuple[str, int]  # ("D", drone) | ("T", target) | ("S", station) | ("E", 0)


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


def precheck(sc: TeamScenario, arcs: list[Arc]) -> None:
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
