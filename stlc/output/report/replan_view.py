"""The simulation section of the report (``stlc simulate``): how the plan recovered.

``replan(program, mission, solution, sim)`` is ``None`` without a simulation.  Otherwise it
returns plain data for

* ``events``: one row per triggered event (time, vehicle, deviation, solve time against the
  budget, IPOPT status, accepted or not, exact robustness of the kept specs on the segment)
  and the count of event instants that did not trigger;
* ``executed``: the exact robustness of the mission and of each named spec on the executed
  trajectory (the kept ones marked);
* ``paths``: per vehicle the nominal path (the compiled plan) and the executed one, each
  replanned segment, and markers where replanning triggered or a drone failed (paper A
  Fig. 12, paper B Fig. 12), drawn over the scene's boxes in 3-D and from the top;
* ``deviation``: ‖p̃ − p*‖ over time per vehicle against ζ (disturbance simulations).
"""

from __future__ import annotations

import numpy as np

from stlc.planning.solution import Solution
from stlc.semantics.model import Mission, Program

from .common import drone_color, fmt, num, nums

#: the simulation's colours: nominal (grey), replanned segments, trigger markers
NOMINAL, REPLANNED, TRIGGER = "#8a94a3", "#e7298a", "#c5221f"


def _xyz(channels: dict, v: str, idx=None) -> list | None:
    cols = [channels.get(f"{v}.pos.{a}") for a in "xyz"]
    if any(c is None for c in cols):
        return None
    return [nums(np.asarray(c, float)[idx] if idx is not None else np.asarray(c, float))
            for c in cols]


def _at(channels: dict, times: np.ndarray, v: str, t: float) -> list | None:
    k = int(np.clip(np.searchsorted(times, t - 1e-9), 0, len(times) - 1))
    p = _xyz(channels, v, slice(k, k + 1))
    return None if p is None else [c[0] for c in p]


def replan(program: Program, mission: Mission, solution: Solution, sim) -> dict | None:
    if sim is None:
        return None
    kappa = sim.threshold
    vehicles = sorted({k.split(".")[0] for k in sim.executed if ".pos." in k},
                      key=lambda v: (v not in mission.vehicles, v))
    # a failed drone is drawn up to its failure (it is then parked out of the mission)
    until = {f.vehicle: f.time for f in sim.failures}
    paths = []
    for i, v in enumerate(vehicles):
        flown = None if v not in until else slice(0, int(np.searchsorted(
            sim.times, until[v] + 1e-9)))
        paths.append({"vehicle": v, "color": drone_color(i),
                      "nominal": _xyz(sim.nominal, v), "executed": _xyz(sim.executed, v, flown)})
    segments, markers, rows = [], [], []
    for e in sim.events:
        if not e.triggered:
            continue
        p = _at(sim.executed, sim.times, e.vehicle, e.time)
        label = (f"{e.vehicle} fails at {e.time:g} s" if e.kind == "failure" else
                 f"replan at {e.time:g} s (deviation {e.deviation:.2f} m)")
        if p is not None:
            markers.append({"t": e.time, "x": p[0], "y": p[1], "z": p[2], "label": label,
                            "kind": e.kind})
        if e.accepted and e.times is not None and e.channels:  # what was flown
            for v in sorted({k.split(".")[0] for k in e.channels if ".pos." in k}):
                seg = _xyz(e.channels, v)
                if seg is not None:
                    segments.append({"vehicle": v, "label": f"replan {e.time:g} s",
                                     "x": seg[0], "y": seg[1], "z": seg[2]})
        rows.append({
            "time": fmt(e.time, 4), "vehicle": e.vehicle, "kind": e.kind,
            "deviation": fmt(e.deviation, 3) if e.kind != "failure" else "—",
            "solve": fmt(e.solve_s, 3) if e.solve_s is not None else "—",
            "within_budget": e.within_budget, "status": e.status or "—",
            "accepted": bool(e.accepted),
            "segment": "—" if e.segment is None else f"{e.segment[0]:g}–{e.segment[1]:g} s",
            "kept": [{"name": k, "value": fmt(r, 4, signed=True), "holds": bool(r >= kappa)}
                     for k, r in e.kept.items()],
        })
    executed = [{"name": k, "value": fmt(r, 4, signed=True), "holds": bool(r >= kappa),
                 "kept": k in sim.kept} for k, r in sim.executed_robustness.items()]
    deviation = None
    if sim.disturbances:
        series = []
        for i, v in enumerate(vehicles):
            a, b = _xyz(sim.executed, v), _xyz(sim.nominal, v)
            if a is None or b is None:
                continue
            d = np.linalg.norm(np.array(a, float) - np.array(b, float), axis=0)
            series.append({"vehicle": v, "color": drone_color(i), "d": nums(d)})
        deviation = {"t": nums(sim.times), "series": series,
                     "zeta": num(_zeta(mission)),
                     "events": [m["t"] for m in markers]}
    solves = [e.solve_s for e in sim.triggered if e.solve_s is not None]
    return {
        "kind": "failure" if sim.failures else "disturbance",
        "ok": sim.ok(),
        "budget": fmt(sim.budget, 3), "threshold": fmt(kappa, 4),
        "instants": len(sim.events), "triggered": len(rows),
        "median_solve": fmt(float(np.median(solves)), 3) if solves else "—",
        "max_solve": fmt(max(solves), 3) if solves else "—",
        "events": rows, "executed": executed, "paths": paths, "segments": segments,
        "markers": markers, "deviation": deviation, "notes": list(sim.notes),
        "colors": {"nominal": NOMINAL, "replanned": REPLANNED, "trigger": TRIGGER},
    }


def _zeta(mission: Mission) -> float:
    return mission.replan.threshold if mission.replan is not None else 1.0
