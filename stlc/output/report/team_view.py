"""The team section of the report (paper B, bird diverters): who does what, when, and how.

``team(program, mission, solution)`` is ``None`` unless the solution is a team plan (it has
routes, planned visits or payload events).  Otherwise it returns plain data for

* ``drones``: one entry per drone, with its colour (the same as in the scene), capacity,
  route (targets and stations in the order the assignment MILP gave them) and the number of
  installs and refills the verification found;
* ``gantt``: one bar per payload event (``Solution.events``, recomputed from the positions)
  and per planned dwell (``Solution.visits``), with start and duration;
* ``forward``: the forward speed v_for = hypot(v_x, v_y) of every drone against v*, with
  the mean speed and the cost Σ(1 − v_for/v*)² over its transit samples (outside its
  payload events) — v* per drone from the mission's ``forward_speed`` or, without it, from
  each drone's aerodynamic data (eq. 8, ``v_stars``); a drone without either gets no v*
  line; ``None`` when no drone has a v*;
* ``plans``: this plan beside each comparison ("MILP only" = the seed, "standard" = the
  plan without the forward-speed term), spec by spec (exact robustness, holds or not), with
  the closest approach of two drones and the peak forward speed of each plan.

The payload and pairwise-distance plots are in the signals section (``signals.py``).
"""

from __future__ import annotations

import math

import numpy as np

from stlc.analysis import verdict
from stlc.planning.solution import Solution
from stlc.semantics.model import Mission, Program

from .common import channel, drone_color, fmt, num, nums, vehicles

#: bar colours of the Gantt chart, by kind (the scene's target / station / home colours)
KIND_COLORS = {"install": "#2ca02c", "refill": "#9467bd", "home": "#7f7f7f"}
KIND_LABELS = {"install": "install", "refill": "refill", "home": "home"}


def is_team(sol: Solution) -> bool:
    """A team plan carries the assignment's routes, its planned dwells or payload events."""
    return bool(sol.routes or sol.visits or sol.events)


def _positions(channels: dict[str, np.ndarray], names: list[str]) -> dict[str, np.ndarray]:
    out = {}
    for v in names:
        xyz = [channels.get(f"{v}.pos.{a}") for a in "xyz"]
        if all(c is not None for c in xyz):
            out[v] = np.stack([np.asarray(c, float).ravel() for c in xyz], axis=1)  # type: ignore
    return out


def closest_approach(channels: dict[str, np.ndarray], names: list[str],
                     times: np.ndarray) -> tuple[float | None, str, float | None]:
    """Smallest distance between two drones over the plan, the pair and the time."""
    pos = _positions(channels, names)
    keys = list(pos)
    best: tuple[float | None, str, float | None] = (None, "", None)
    for i, a in enumerate(keys):
        for b in keys[i + 1:]:
            d = np.linalg.norm(pos[a] - pos[b], axis=1)
            if not d.size or not np.isfinite(d).any():
                continue
            k = int(np.nanargmin(d))
            if best[0] is None or d[k] < best[0]:
                t = float(times[k]) if k < len(times) else None
                best = (float(d[k]), f"{a}–{b}", t)
    return best


def forward_speeds(channels: dict[str, np.ndarray], v: str) -> np.ndarray | None:
    """Eq. (10) of paper B: v_for = hypot(v_x, v_y) of drone ``v``."""
    vx, vy = channels.get(f"{v}.vel.x"), channels.get(f"{v}.vel.y")
    if vx is None or vy is None:
        return None
    return np.hypot(np.asarray(vx, float).ravel(), np.asarray(vy, float).ravel())


def _bar(d: object, planned: bool) -> dict:
    start, end = float(d.start), float(d.end)  # type: ignore[attr-defined]
    kind = str(d.kind)  # type: ignore[attr-defined]
    region = str(d.region)  # type: ignore[attr-defined]
    what = "planned " if planned else ""
    return {"drone": str(d.drone), "kind": kind, "region": region,  # type: ignore[attr-defined]
            "planned": planned, "start": num(start), "end": num(end),
            "duration": num(end - start), "color": KIND_COLORS.get(kind, "#17becf"),
            "text": f"{what}{KIND_LABELS.get(kind, kind)} {region}: "
                    f"{fmt(start)}–{fmt(end)} s ({fmt(end - start, unit='s')})"}


def _gantt(sol: Solution, names: list[str], horizon: float) -> dict:
    rows = list(names)
    for e in [*sol.events, *sol.visits]:
        if e.drone not in rows:
            rows.append(str(e.drone))
    bars = [_bar(v, True) for v in sorted(sol.visits, key=lambda v: (v.drone, v.start))]
    bars += [_bar(e, False) for e in sorted(sol.events, key=lambda e: (e.drone, e.start))]
    kinds = list(dict.fromkeys(b["kind"] for b in bars))
    return {"rows": rows, "bars": bars, "horizon": num(horizon),
            "has_planned": bool(sol.visits),
            "legend": [{"label": KIND_LABELS.get(k, k), "color": KIND_COLORS.get(k, "#17becf")}
                       for k in kinds]}


def _transit(sol: Solution, v: str, t: np.ndarray) -> np.ndarray:
    """Samples of drone ``v`` outside all its payload events (dwells and the final stay)."""
    mask = np.ones(t.size, bool)
    for e in sol.events:
        if e.drone == v:
            mask &= ~((t >= float(e.start) - 1e-9) & (t <= float(e.end) + 1e-9))
    return mask


def v_stars(program: Program, mission: Mission, names: list[str]) -> dict[str, float]:
    """v* per drone: the mission's ``forward_speed`` for every drone when it gives one, else
    paper B eq. 8 from each drone's declared aerodynamic data (mass, rotors, disk area,
    flat-plate area, induced factor, air density); a drone with neither has no v*."""
    from stlc.team.energy import optimal_forward_speed

    fs = mission.objective.forward_speed
    if fs is not None and math.isfinite(fs) and fs > 0:
        return dict.fromkeys(names, float(fs))
    out = {}
    for v in names:
        veh = program.vehicles.get(v)
        aero, mass = getattr(veh, "aero", None), getattr(veh, "mass", None)
        if aero is not None and mass is not None:
            try:
                vs = optimal_forward_speed(mass, *aero)
            except (TypeError, ValueError):  # incomplete or invalid data: no v* to show
                continue
            if math.isfinite(vs) and vs > 0:
                out[v] = float(vs)
    return out


def _forward(program: Program, mission: Mission, sol: Solution, names: list[str]) -> dict | None:
    stars = v_stars(program, mission, names)
    if not stars:
        return None
    t = np.asarray(sol.times, float)
    drones = []
    for i, v in enumerate(names):
        vf = forward_speeds(sol.channels, v)
        if vf is None or vf.size != t.size:
            continue
        veh = program.vehicles.get(v)
        vel_max = getattr(veh, "vel_max", None)
        v_star = stars.get(v)
        # v* clamped to the largest horizontal speed the per-axis bounds allow (paper B)
        target = v_star
        if v_star is not None and vel_max:
            target = min(v_star, math.hypot(vel_max[0], vel_max[1]))
        transit = _transit(sol, v, t)
        moving = vf[transit]
        cost = (float(np.sum((1.0 - moving / target) ** 2))
                if moving.size and target is not None else None)
        comps = []
        for comp in sol.comparisons:
            cf = forward_speeds(comp.channels, v)
            if cf is not None and cf.size == t.size:
                comps.append({"label": comp.label, "y": nums(cf)})
        drones.append({
            "name": v, "color": drone_color(i), "y": nums(vf),
            "v_star": num(target) if target is not None else None,
            "v_star_text": fmt(target, unit="m/s") if target is not None else "—",
            "clamped": target is not None and target < v_star, "comparisons": comps,
            "mean_transit": num(moving.mean()) if moving.size else None,
            "mean_transit_text": fmt(moving.mean(), unit="m/s") if moving.size else "—",
            "peak_text": fmt(vf.max(), unit="m/s") if vf.size else "—",
            "transit_samples": int(moving.size),
            "cost": num(cost), "cost_text": fmt(cost),
        })
    if not drones:
        return None
    common = set(stars.values())
    v_all = common.pop() if len(common) == 1 and len(stars) == len(names) else None
    return {"t": nums(t), "v_star": num(v_all) if v_all is not None else None,
            "v_star_text": fmt(v_all, unit="m/s") if v_all is not None
            else "per drone (paper B eq. 8; see the table)",
            "weight_text": fmt(mission.objective.forward_weight), "drones": drones}


def _cell(rho: float | None) -> dict:
    value = num(rho)
    ok = None if rho is None else verdict.judge(rho)  # a drone's own specs: κ = 0
    return {"value": value, "text": fmt(rho, signed=True), "ok": ok,
            "mark": "—" if ok is None else ("✓" if ok else "✗")}


def _metric(value: float | None, unit: str, extra: str = "") -> dict:
    return {"value": num(value), "text": fmt(value, unit=unit) + extra, "ok": None, "mark": ""}


def _plans(sol: Solution, names: list[str]) -> dict:
    t = np.asarray(sol.times, float)
    plans = [("this plan", sol.channels, {k: r.robustness for k, r in sol.specs.items()},
              sol.robustness_exact)]
    plans += [(c.label, c.channels, c.specs, c.robustness_exact) for c in sol.comparisons]
    rows = [{"name": name, "metric": False,
             "cells": [_cell(specs.get(name)) for _, _, specs, _ in plans]}
            for name in sol.specs]
    rows.append({"name": "requirement", "metric": False,
                 "cells": [_cell(rho) for *_, rho in plans]})
    approach = []
    for _, ch, _, _ in plans:
        d, pair, when = closest_approach(ch, names, t)
        approach.append(_metric(d, "m", f" ({pair}, t = {fmt(when, unit='s')})" if pair else ""))
    if any(c["value"] is not None for c in approach):
        rows.append({"name": "closest approach", "metric": True, "cells": approach})
    peaks = []
    for _, ch, _, _ in plans:
        vals = [float(np.nanmax(f)) for v in names
                if (f := forward_speeds(ch, v)) is not None and f.size]
        peaks.append(_metric(max(vals) if vals else None, "m/s"))
    if any(c["value"] is not None for c in peaks):
        rows.append({"name": "peak forward speed", "metric": True, "cells": peaks})
    return {"columns": [label for label, *_ in plans], "rows": rows}


def team(program: Program, mission: Mission, sol: Solution) -> dict | None:
    """The ``team`` section of the view model (``None`` for a mission without a team plan)."""
    if not is_team(sol):
        return None
    names = [v for v in vehicles(mission, sol) if channel(sol, f"{v}.pos.x") is not None]
    for v in [*sol.routes, *(e.drone for e in sol.events)]:
        if v not in names:
            names.append(str(v))
    kinds = {r.name: r.kind for r in program.scenario.regions}
    drones = []
    for i, v in enumerate(names):
        route = [{"name": str(r), "kind": kinds.get(str(r), "region")}
                 for r in sol.routes.get(v, [])]
        veh = program.vehicles.get(v)
        ev = [e for e in sol.events if e.drone == v]
        drones.append({"name": v, "color": drone_color(i),
                       "capacity": getattr(veh, "capacity", None),
                       "route": route, "route_text": " → ".join(r["name"] for r in route) or "—",
                       "installs": sum(e.kind == "install" for e in ev),
                       "refills": sum(e.kind == "refill" for e in ev)})
    horizon = float(sol.times[-1]) if len(sol.times) else mission.horizon
    dmin = sol.bounds.get("distance_min")
    installed = sorted({str(e.region) for e in sol.events if e.kind == "install"})
    targets = [r.name for r in program.scenario.regions if r.kind == "target"]
    return {
        "drones": drones,
        "gantt": _gantt(sol, names, horizon),
        "forward": _forward(program, mission, sol, names),
        "plans": _plans(sol, names),
        "distance_min_text": fmt(dmin, unit="m") if num(dmin) is not None else "—",
        "installed_text": f"{len(installed)} of {len(targets)} targets" if targets
        else f"{len(installed)} targets",
        "missing": [q for q in targets if q not in installed],
    }
