"""Payload rule: the diverters on board, recomputed from the positions alone.

A drone's payload is not a free variable of the planner.  It is a piecewise-constant signal
determined by the sampled trajectory under the following rule (paper B, eq. 2, 3e, 3f):

* Grid.  Samples ``t_k = k·Δt``, ``k = 0..N`` (``Δt`` = mission step).  Durations in
  samples: ``n_ins = ⌈T_ins/Δt⌉`` and ``n_rs = ⌈T_rs/Δt⌉`` (a ratio within 1e-9 of an
  integer counts as that integer: 5 s at 0.05 s gives ``n_ins = 100``).
* Inside.  Drone ``d`` is inside region ``R`` at sample ``k`` when its sampled position
  lies in the closed box: ``lo ≤ p_d(t_k) ≤ hi`` on every axis (no tolerance).
* Start.  ``c_d[0] = capacity``.  ``c_d[k]`` is the number on board at sample ``k``.
* Stay.  A stay of drone ``d`` in region ``R`` is a maximal run of consecutive samples
  ``j, …, k`` inside ``R`` (it ends at ``k`` when the drone is outside ``R`` at ``k+1`` or
  ``k = N``).  A stay *counts* for a dwell of duration ``T`` (``n = n_ins`` or ``n_rs``
  samples) when it holds at least ``n + 1`` samples, i.e. lasts ``≥ T``.  The event happens
  when the stay ends, at sample ``k``, and the payload takes its new value from the next
  sample: ``c_d[k+1]``.  (So the payload on board is constant over the whole stay: while a
  drone installs, ``payload > 0.5 and pos in q`` holds over every window of ``T_ins``
  inside its stay — paper B's ``□[0,T_ins](c_d > 0 ∧ p ∈ q)`` — and the planner can hover
  deep inside the region instead of timing the install from the moment it crosses a face.)
* Install.  When drone ``d``'s stay in target ``q`` ends at sample ``k``, counts for
  ``T_ins``, ``c_d[k] > 0`` and ``q`` is not yet installed, ``q`` is installed (for the
  whole team) and ``c_d[k+1] = c_d[k] − 1``.
* Refill.  When drone ``d``'s stay in station ``s`` ends at sample ``k``, counts for
  ``T_rs`` and ``c_d[k] < capacity``: ``c_d[k+1] = capacity``.
* Otherwise ``c_d[k+1] = c_d[k]``.
* One stay, one event.  Only samples after a drone's last event count towards its next
  stay (in overlapping regions).  At most one event per drone and sample; samples are
  processed in time order, and within a sample drones in scenario order, each drone
  checking targets (scenario order) before stations.

Consequences (corner cases, each tested on hand-made trajectories):

* a second visit to an installed target does nothing; neither does a dwell in a station
  with a full payload;
* dwelling twice as long installs once (when the stay ends);
* a drone that enters a target empty installs nothing however long it stays, and the
  target stays open for the others;
* two drones in the same target: the first whose counting stay ends installs it; if both
  end at the same sample, the one listed first in the scenario does; the other keeps its
  payload;
* a stay still under way at the horizon ends there: it is an event if it counts (its
  payload change falls after the plan), none if it is shorter than ``T``;
* leaving and re-entering restarts the count: partial dwells do not add up;
* hence ``0 ≤ c_d[k] ≤ capacity`` always, and a refill happens only in a station, after
  the refilling time.

Events are reported as ``PayloadEvent(drone, kind, region, start=t_j, end=t_k)`` (the
counting stay's first and last samples).
"""

from __future__ import annotations

import numpy as np

from stlc.team import Box, Drone, PayloadEvent, TeamScenario, inside, samples_for


def _runs(flags: np.ndarray) -> np.ndarray:
    """``runs[k]`` = number of consecutive True values of ``flags`` ending at ``k``."""
    out = np.zeros(len(flags), dtype=np.int64)
    count = 0
    for k, f in enumerate(flags):
        count = count + 1 if f else 0
        out[k] = count
    return out


def _check_grid(times: np.ndarray, step: float) -> None:
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or len(t) == 0:
        raise ValueError("times must be a non-empty 1-d array")
    if len(t) > 1 and not np.allclose(np.diff(t), step, rtol=0.0, atol=1e-9 * max(1.0, t[-1])):
        raise ValueError(f"times must be a uniform grid with the mission step {step} s")


def payload_team(
    times: np.ndarray, pos: dict[str, np.ndarray], scenario: TeamScenario
) -> tuple[dict[str, np.ndarray], list[PayloadEvent]]:
    """Payload of every drone in ``pos`` (keys are drone names of the scenario) and the
    events, in completion order; targets are installed once across the team."""
    times = np.asarray(times, dtype=float)
    _check_grid(times, scenario.step)
    n = len(times)
    drones = [d for d in scenario.drones if d.name in pos]
    unknown = set(pos) - {d.name for d in drones}
    if unknown:
        raise ValueError(f"unknown drone(s) {sorted(unknown)}")
    n_ins = samples_for(scenario.install_time, scenario.step)
    n_rs = samples_for(scenario.refill_time, scenario.step)
    regions: list[tuple[str, Box, int]] = [("install", b, n_ins) for b in scenario.targets]
    regions += [("refill", b, n_rs) for b in scenario.stations]

    # runs[d][r] without restarts; restarts are applied through last_event below
    runs: dict[str, list[np.ndarray]] = {}
    ends: dict[str, list[np.ndarray]] = {}  # a stay in the region ends at this sample
    active: dict[str, np.ndarray] = {}  # samples where the drone is inside some region
    for d in drones:
        p = np.asarray(pos[d.name], dtype=float)
        if p.shape != (n, 3):
            raise ValueError(f"positions of {d.name} must have shape ({n}, 3), got {p.shape}")
        flags = [inside(p, box) for _, box, _ in regions]
        runs[d.name] = [_runs(f) for f in flags]
        ends[d.name] = [f & ~np.append(f[1:], False) for f in flags]
        any_in = np.zeros(n, dtype=bool)
        for f in flags:
            any_in |= f
        active[d.name] = any_in

    payload = {d.name: np.empty(n, dtype=np.int64) for d in drones}
    current = {d.name: d.capacity for d in drones}
    last_event = {d.name: -1 for d in drones}
    installed: set[str] = set()
    events: list[PayloadEvent] = []
    for k in range(n):
        for d in drones:
            payload[d.name][k] = current[d.name]
        for d in drones:
            if not active[d.name][k]:
                continue
            c = current[d.name]
            for (kind, box, need), run, end in zip(regions, runs[d.name], ends[d.name],
                                                   strict=True):
                stay = min(int(run[k]), k - last_event[d.name])
                if not end[k] or stay < need + 1:
                    continue
                if kind == "install" and (c <= 0 or box.name in installed):
                    continue
                if kind == "refill" and c >= d.capacity:
                    continue
                if kind == "install":
                    installed.add(box.name)
                    current[d.name] = c - 1
                else:
                    current[d.name] = d.capacity
                last_event[d.name] = k
                events.append(
                    PayloadEvent(d.name, kind, box.name, float(times[k - stay + 1]),
                                 float(times[k]))
                )
                break
    return payload, events


def payload_signal(
    times: np.ndarray, pos: np.ndarray, drone: Drone, scenario: TeamScenario
) -> tuple[np.ndarray, list[PayloadEvent]]:
    """Payload of one drone flying alone (no other drone installs anything)."""
    payload, events = payload_team(times, {drone.name: pos}, scenario)
    return payload[drone.name], events


def uninstalled(events: list[PayloadEvent], scenario: TeamScenario) -> list[str]:
    """Targets of the scenario that no event installs."""
    done = {e.region for e in events if e.kind == "install"}
    return [t.name for t in scenario.targets if t.name not in done]
