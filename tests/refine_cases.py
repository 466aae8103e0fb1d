"""Synthetic team scenarios and straight-line seeds for the refinement tests and benchmark.

``straight_seed`` is a stand-in for the team helper's motion-primitive seed: every transit
is a straight rest-to-rest minimum-jerk (quintic) move to the region's centre, timed so
that the per-axis velocity and acceleration bounds hold, then a dwell of the required
length; a final ``home`` dwell lasts until the horizon.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.team import Box, Drone, TeamPlan, TeamScenario, Visit


def cube(name: str, centre, size: float) -> Box:
    c = np.asarray(centre, dtype=float)
    return Box(name, tuple(c - size / 2), tuple(c + size / 2))


def _duration(delta: np.ndarray, vmax, amax) -> float:
    # quintic s(u) = 10u³ − 15u⁴ + 6u⁵: peak speed 15/8 Δ/T, peak acc 10/√3 Δ/T²
    t = 0.0
    for dj, v, a in zip(np.abs(delta), vmax, amax, strict=True):
        t = max(t, 15 / 8 * dj / v, math.sqrt(10 / math.sqrt(3) * dj / a))
    return t


def straight_seed(sc: TeamScenario, routes: dict[str, list[tuple[str, str]]],
                  wait: dict[str, float] | None = None) -> TeamPlan:
    """routes: drone -> [(kind, region), …]; ``wait`` delays a drone's departure (s)."""
    n = int(round(sc.horizon / sc.step)) + 1
    times = np.arange(n) * sc.step
    boxes = {b.name: b for b in (*sc.targets, *sc.stations)}
    pos, vel, acc, visits = {}, {}, {}, []
    for drone in sc.drones:
        p = np.tile(np.asarray(drone.start, dtype=float), (n, 1))
        v, a = np.zeros((n, 3)), np.zeros((n, 3))
        here, t = np.asarray(drone.start, dtype=float), (wait or {}).get(drone.name, 0.0)
        for i, (kind, region) in enumerate(routes.get(drone.name, [])):
            box = boxes[region]
            goal = 0.5 * (np.array(box.lo) + np.array(box.hi))
            dur = _duration(goal - here, drone.vel_max, drone.acc_max)
            sel = times >= t
            u = np.clip((times[sel] - t) / dur, 0, 1)
            s = 10 * u**3 - 15 * u**4 + 6 * u**5
            ds = (30 * u**2 - 60 * u**3 + 30 * u**4) / dur
            dds = (60 * u - 180 * u**2 + 120 * u**3) / dur**2
            p[sel] = here + np.outer(s, goal - here)
            v[sel] = np.outer(ds, goal - here)
            a[sel] = np.outer(dds, goal - here)
            start = t + dur
            last = i == len(routes[drone.name]) - 1
            need = {"install": sc.install_time, "refill": sc.refill_time}.get(kind, 0.0)
            end = sc.horizon if (kind == "home" and last) else start + need
            if end > sc.horizon + 1e-9:
                raise ValueError(f"route of {drone.name} does not fit the horizon")
            visits.append(Visit(drone.name, kind, region, start, end))
            here, t = goal, end
        pos[drone.name], vel[drone.name], acc[drone.name] = p, v, a
    visits.sort(key=lambda v: (v.drone, v.start))
    route = {d: [r for _, r in rs] for d, rs in routes.items()}
    return TeamPlan(times, pos, vel, acc, visits, route)


def _drone(name, start, vmax=3.1, amax=3.1, cap=2) -> Drone:
    return Drone(name, tuple(float(x) for x in start), (vmax,) * 3, (amax,) * 3, cap)


def head_on() -> tuple[TeamScenario, dict]:
    """Two drones whose straight paths cross at the origin at the same time."""
    sc = TeamScenario(
        drones=(_drone("a", (-10, 0, 5)), _drone("b", (0, -10, 5))),
        targets=(cube("ta", (10, 0, 5), 1.0), cube("tb", (0, 10, 5), 1.0)),
        stations=(cube("sa", (10, -6, 1), 2.0), cube("sb", (-6, 10, 1), 2.0)),
        obstacles=(), workspace=Box("ws", (-15, -15, 0), (15, 15, 10)),
        install_time=2.0, refill_time=4.0, horizon=30.0, step=0.05, separation=3.0)
    routes = {"a": [("install", "ta"), ("home", "sa")],
              "b": [("install", "tb"), ("home", "sb")]}
    return sc, routes


def line_scenario(drones: int, targets: int, stations: int, horizon: float,
                  install: float = 5.0, refill: float = 12.0) -> TeamScenario:
    """A power line along x like paper B's mock-up (towers, two cables, targets under the
    cables staggered across them, ground stations), scaled with the number of targets."""
    half = 2.5 * (targets + 1) + 5
    ws = Box("ws", (-half - 5, -10, 0), (half + 5, 10, 15))
    obstacles = (Box("tower1", (-half - 1, -3, 0), (-half + 1, 3, 15)),
                 Box("tower2", (half - 1, -3, 0), (half + 1, 3, 15)),
                 Box("cable_a", (-half + 1, -2.6, 14.5), (half - 1, -2.4, 14.7)),
                 Box("cable_b", (-half + 1, 2.4, 14.5), (half - 1, 2.6, 14.7)))
    xs = np.linspace(-half + 5, half - 5, targets)
    tgts = tuple(cube(f"tr{i + 1}", (x, -2.5 if i % 2 == 0 else 2.5, 13.5), 1.0)
                 for i, x in enumerate(xs))
    sx = np.linspace(-half + 5, half - 5, stations)
    sts = tuple(cube(f"rs{i + 1}", (x, -7, 1), 2.0) for i, x in enumerate(sx))
    ds = tuple(_drone(f"uav{i + 1}", (x, -3 if i % 2 == 0 else 3, 0.5), cap=2 + i % 3)
               for i, x in enumerate(np.linspace(-half + 8, half - 8, drones)))
    return TeamScenario(ds, tgts, sts, obstacles, ws, install, refill, horizon, 0.05, 3.0)


def chunk_routes(sc: TeamScenario) -> dict[str, list[tuple[str, str]]]:
    """Contiguous blocks of targets along x per drone; refill and home at the drone's own
    station (the nearest unused one), so no two drones share a station."""
    n = len(sc.drones)
    blocks = np.array_split(np.arange(len(sc.targets)), n)
    free = list(sc.stations)
    routes = {}
    for drone, block in zip(sc.drones, blocks, strict=True):
        own = min(free, key=lambda s: abs(s.lo[0] - drone.start[0]))
        free.remove(own)
        r, load = [], drone.capacity
        for q in block:
            if load == 0:
                r.append(("refill", own.name))
                load = drone.capacity
            r.append(("install", sc.targets[q].name))
            load -= 1
        r.append(("home", own.name))
        routes[drone.name] = r
    return routes
