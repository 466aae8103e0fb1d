"""Dwell windows on the knot grid and the initial knots, from a team seed.

The refinement keeps the seed's assignment and order (``TeamPlan.visits``) and re-times it
once, before the NLP: every transit of the seed is stretched by a common factor (1 + α) —
the largest α ≤ ``stretch_cap`` for which every drone still reaches its last region by the
horizon — and every dwell is snapped outward to knots (start rounded up, length rounded up
to whole knot intervals after adding ``dwell_pad``). A final ``home`` visit lasts until the
horizon. Stretching gives the cubic waypoints room inside the velocity and acceleration
bounds (the seed's rest-to-rest primitives are minimum-time) and room to swerve.

The initial knots follow the seed in time-warped form: inside transit i the knot at new
time t copies the seed's state at the proportional seed time (velocity rescaled); inside a
dwell the drone hovers at the region's centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stlc.team import Box, TeamPlan, TeamScenario, Visit


@dataclass(frozen=True, slots=True)
class Window:
    """A dwell fixed on knots: hover inside ``box`` at knots k0 … k1 (inclusive)."""

    visit: Visit
    box: Box
    k0: int
    k1: int


@dataclass
class Schedule:
    knots: np.ndarray
    windows: dict[str, list[Window]]  # drone -> windows in time order
    stretch: float                    # the α used


def _boxes(scenario: TeamScenario) -> dict[str, Box]:
    return {b.name: b for b in (*scenario.targets, *scenario.stations)}


def _dwell_length(scenario: TeamScenario, v: Visit) -> float:
    need = {"install": scenario.install_time, "refill": scenario.refill_time}.get(v.kind, 0.0)
    return max(v.end - v.start, need)


def _per_drone(seed: TeamPlan) -> dict[str, list[Visit]]:
    out: dict[str, list[Visit]] = {d: [] for d in seed.pos}
    for v in seed.visits:
        out.setdefault(v.drone, []).append(v)
    return {d: sorted(vs, key=lambda v: v.start) for d, vs in out.items()}


def _place(scenario, visits: list[Visit], knots, alpha, pad) -> list[Window] | None:
    h = float(knots[1] - knots[0])
    last = len(knots) - 1
    boxes = _boxes(scenario)
    out, t_new, t_seed = [], 0.0, 0.0
    for i, v in enumerate(visits):
        arrive = t_new + max(v.start - t_seed, 0.0) * (1.0 + alpha)
        k0 = math.ceil(arrive / h - 1e-9)
        if v.kind == "home" and i == len(visits) - 1:
            k1 = last
        else:
            k1 = k0 + max(1, math.ceil((_dwell_length(scenario, v) + pad) / h - 1e-9))
        if k1 > last or k0 > last:
            return None
        out.append(Window(v, boxes[v.region], k0, k1))
        t_new, t_seed = float(knots[k1]), v.end
    return out


def make_schedule(scenario: TeamScenario, seed: TeamPlan, knot_dt: float = 1.0,
                  stretch_cap: float = 0.5, dwell_pad: float = 0.5) -> Schedule:
    """Largest common stretch ≤ ``stretch_cap`` that fits every drone into the horizon."""
    from stlc.team.waypoints import knot_times

    knots = knot_times(scenario.horizon, knot_dt)
    visits = _per_drone(seed)
    boxes = _boxes(scenario)
    for vs in visits.values():
        for v in vs:
            if v.region not in boxes:
                raise ValueError(f"visit of {v.drone} to unknown region {v.region!r}")

    def fits(alpha: float, pad: float) -> dict[str, list[Window]] | None:
        out = {}
        for d, vs in visits.items():
            w = _place(scenario, vs, knots, alpha, pad)
            if w is None:
                return None
            out[d] = w
        return out

    pad = dwell_pad
    if fits(0.0, pad) is None:
        pad = 0.0
        if fits(0.0, pad) is None:
            raise ValueError("the seed's visits do not fit into the horizon on the knot grid")
    lo, hi = 0.0, stretch_cap
    if fits(hi, pad) is not None:
        lo = hi
    else:
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if fits(mid, pad) is not None else (lo, mid)
    return Schedule(knots, fits(lo, pad), lo)


def _interp(seed: TeamPlan, d: str, t: float) -> tuple[np.ndarray, np.ndarray]:
    ts = seed.times
    p = np.array([np.interp(t, ts, seed.pos[d][:, j]) for j in range(3)])
    v = np.array([np.interp(t, ts, seed.vel[d][:, j]) for j in range(3)])
    return p, v


def initial_knots(scenario: TeamScenario, seed: TeamPlan, sched: Schedule
                  ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Initial knot positions and velocities (each (K, 3)) per drone, see module doc."""
    knots = sched.knots
    out = {}
    for drone in scenario.drones:
        d = drone.name
        p = np.zeros((len(knots), 3))
        v = np.zeros((len(knots), 3))
        t_new, t_seed = 0.0, 0.0
        wins = sched.windows.get(d, [])
        for w in [*wins, None]:
            ks = w.k0 if w is not None else len(knots) - 1
            s_start = w.visit.start if w is not None else seed.times[-1]
            t_end = float(knots[ks])
            for k in range(len(knots)):
                t = float(knots[k])
                if not (t_new <= t <= t_end):
                    continue
                if w is None:
                    p[k], v[k] = _interp(seed, d, min(t_seed + (t - t_new), seed.times[-1]))
                    continue
                dur = t_end - t_new
                u = (t - t_new) / dur if dur > 0 else 1.0
                p[k], v[k] = _interp(seed, d, t_seed + u * max(s_start - t_seed, 0.0))
                if dur > 0:
                    v[k] *= max(s_start - t_seed, 0.0) / dur
            if w is None:
                break
            centre = 0.5 * (np.array(w.box.lo) + np.array(w.box.hi))
            p[w.k0:w.k1 + 1] = centre
            v[w.k0:w.k1 + 1] = 0.0
            t_new, t_seed = float(knots[w.k1]), w.visit.end
        p[0] = drone.start
        v[0] = 0.0
        out[d] = (p, v)
    return out
