"""Seed trajectories for the team (paper B §IV-B) and the adapter from a checked program.

``seed_plan(scenario, route)`` flies every drone along its route with rest-to-rest motion
primitives (:mod:`stlc.team.primitives`) between region centres, on the dense grid
``t_k = k·Δt``, ``k = 0..N``, ``N = T_N/Δt``:

* each leg lasts its minimum feasible time rounded up to whole steps (the primitive is
  stretched to that duration, so every arrival and departure falls on a sample); a leg
  whose direct primitive would come close to an obstacle detours through via points
  (``stlc.team.paths``), each sub-leg rounded to whole steps on its own;
* at a target the drone stays at the centre for ``n_ins + 1`` steps, at a refilling
  station (not the last one) for ``n_rs + 1`` steps: the ``n + 1`` samples the payload rule
  needs plus one sample of margin (``Visit`` spans exactly those steps);
* the route's last station is home: the drone stays there until the horizon
  (``Visit(kind="home", end=T_N)``); a route without a station ends hovering at its last
  region;
* a drone with no route element stays at its start.

These are exactly the times the MILP's cost model charges (``milp.route_time``).  A route
that does not fit the horizon raises ``TeamError(reason="horizon")``.

``scenario_from_program(program, mission, ...)`` builds the ``TeamScenario`` from the
checked ``stlc.semantics.model`` objects: point-mass vehicles with a ``capacity``; regions of kind
``target``, ``station``, ``obstacle`` and ``workspace`` (world frame).  Install / refill
times come from ``mission.install_time`` / ``mission.refill_time`` when the model has those
fields and they are set, otherwise from the keyword arguments of the same name (the
fallback, e.g. ``install_time=5.0, refill_time=12.0`` for paper B); if neither gives a
value a ``ScenarioError`` says so.  ``separation`` (Γ_dis) is a parameter (default 0).
"""

from __future__ import annotations

import math

import numpy as np

from stlc import vehicles
from stlc.semantics import model
from stlc.team import (
    Box,
    Drone,
    ScenarioError,
    TeamError,
    TeamPlan,
    TeamScenario,
    Visit,
    centre,
    samples_for,
)
from stlc.team.paths import leg_steps, router_for
from stlc.team.primitives import rest_to_rest


def _fly(sc: TeamScenario, dr: Drone, route: list[str], n: int, times: np.ndarray):
    regions = {b.name: ("T", b) for b in sc.targets} | {b.name: ("S", b) for b in sc.stations}
    pos = np.empty((n + 1, 3))
    vel = np.zeros((n + 1, 3))
    acc = np.zeros((n + 1, 3))
    visits: list[Visit] = []
    n_ins = samples_for(sc.install_time, sc.step) + 1
    n_rs = samples_for(sc.refill_time, sc.step) + 1
    router = router_for(sc)
    p = np.asarray(dr.start, dtype=float)
    pos[:] = p
    k = 0
    last_station = max((i for i, r in enumerate(route) if regions.get(r, ("",))[0] == "S"),
                       default=-1)
    for i, name in enumerate(route):
        if name not in regions:
            raise TeamError(f"route of {dr.name}: {name!r} is not a target or a station",
                            reason="route", subject=dr.name)
        kind, box = regions[name]
        c = centre(box)
        path = router.path(p, c, dr.vel_max, dr.acc_max)
        sub = leg_steps(path, dr.vel_max, dr.acc_max, sc.step)
        if any(math.isinf(x) for x in sub):
            raise TeamError(f"{dr.name} cannot reach {name} within its bounds",
                            reason="unreachable", subject=dr.name)
        steps = int(sum(sub))
        home = kind == "S" and i == last_station
        dwell = 0 if home else (n_ins if kind == "T" else n_rs)
        if k + steps + dwell > n:
            raise TeamError(
                f"route of {dr.name} does not fit the horizon of {sc.horizon:g} s "
                f"(reaching {name} takes until {(k + steps + dwell) * sc.step:.2f} s)",
                reason="horizon", subject=dr.name)
        kk = k
        for a, b, m in zip(path[:-1], path[1:], sub, strict=True):
            if m:
                prim = rest_to_rest(a, b, dr.vel_max, dr.acc_max, duration=m * sc.step,
                                    straight=len(path) > 2)
                pp, vv, aa = prim.sample(np.arange(m + 1) * sc.step)
                pos[kk : kk + m + 1], vel[kk : kk + m + 1], acc[kk : kk + m + 1] = pp, vv, aa
            kk += m
        k += steps
        pos[k:] = c
        vel[k + 1 :] = 0.0
        acc[k + 1 :] = 0.0
        end = sc.horizon if home else float(times[k + dwell])
        kind_name = "home" if home else ("install" if kind == "T" else "refill")
        visits.append(Visit(dr.name, kind_name, name, float(times[k]), end))
        k += dwell
        p = c
    return pos, vel, acc, visits


def seed_plan(scenario: TeamScenario, route: dict[str, list[str]]) -> TeamPlan:
    """Seed trajectory of every drone of the scenario (see the module docstring)."""
    sc = scenario
    n = samples_for(sc.horizon, sc.step)
    times = np.arange(n + 1) * sc.step
    plan = TeamPlan(times, {}, {}, {}, [], {})
    for dr in sc.drones:
        r = list(route.get(dr.name, []))
        pos, vel, acc, visits = _fly(sc, dr, r, n, times)
        plan.pos[dr.name], plan.vel[dr.name], plan.acc[dr.name] = pos, vel, acc
        plan.visits += visits
        plan.route[dr.name] = r
    return plan


def _box(region: model.Region) -> Box:
    if region.box.frame is not None:
        raise ScenarioError(f"{region.kind} {region.name} is attached to {region.box.frame}; "
                            "team planning needs world-frame regions",
                            reason="scenario", subject=region.name)
    return Box(region.name, tuple(map(float, region.box.lo)), tuple(map(float, region.box.hi)))


def _mission_time(mission: model.Mission, field: str, fallback: float | None) -> float:
    value = getattr(mission, field, None)
    if value is None:
        value = fallback
    if value is None:
        what = "installation" if field == "install_time" else "refilling"
        raise ScenarioError(f"mission {mission.name} does not give the {what} time "
                            f"(`{field}`), needed for team planning", reason="scenario",
                            subject=mission.name)
    if not value > 0:
        raise ScenarioError(f"mission {mission.name}: {field} must be positive, got {value}",
                            reason="scenario", subject=mission.name)
    return float(value)


def scenario_from_program(program: model.Program, mission: model.Mission, *,
                          install_time: float | None = None, refill_time: float | None = None,
                          separation: float = 0.0) -> TeamScenario:
    """The team scenario of ``mission`` (see the module docstring for the fallbacks)."""
    drones = []
    for name in mission.vehicles:
        v = program.vehicles[name]
        if not vehicles.model_of(v).carries_payload(v):
            raise ScenarioError(f"vehicle {name} is a {v.kind}; team planning needs point-mass "
                                "vehicles", reason="scenario", subject=name)
        if v.capacity is None:
            raise ScenarioError(f"vehicle {name} has no capacity (diverters it can carry)",
                                reason="scenario", subject=name)
        drones.append(Drone(name, tuple(map(float, v.start_pos)), tuple(map(float, v.vel_max)),
                            tuple(map(float, v.acc_max)), int(v.capacity)))
    scen = program.scenario
    ws = scen.by_kind("workspace")
    inf = math.inf
    workspace = _box(ws[0]) if ws else Box("workspace", (-inf,) * 3, (inf,) * 3)
    return TeamScenario(
        drones=tuple(drones),
        targets=tuple(_box(r) for r in scen.by_kind("target")),
        stations=tuple(_box(r) for r in scen.by_kind("station")),
        obstacles=tuple(_box(r) for r in scen.by_kind("obstacle")),
        workspace=workspace,
        install_time=_mission_time(mission, "install_time", install_time),
        refill_time=_mission_time(mission, "refill_time", refill_time),
        horizon=float(mission.horizon),
        step=float(mission.step),
        separation=float(separation),
    )
