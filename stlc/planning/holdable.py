"""Can the vehicles hold the plan's final state?  (Checked on every plan, like the monitor.)

A final state is *holdable* when it is an equilibrium of the vehicle's own ODE with zero
input: every component of ``f(x_N, 0)`` within ``HOLD_TOL`` (+ a rounding allowance) — for a
multirotor, speed and attitude rates ≈ 0 and rotor forces at hover (v̇ ≈ 0, ω̇ ≈ 0); for a
point mass, speed ≈ 0.  The planner asks for it by default (``stlc.backends.nlp.flyable``);
the report and ``solution.json`` (``end_state``) say, per vehicle, whether the plan ends
holdable, with the final speed, body rate and acceleration.  A mission with ``end = free``
is not flagged.
"""

from __future__ import annotations

import numpy as np

from stlc import vehicles

HOLD_TOL = 0.05  # as stlc.backends.nlp.flyable.HOLD_TOL
SLACK = 1e-3  # the planner meets its rows to IPOPT's tolerance, the check allows rounding


def end_state(vehicle_list: list, channels: dict) -> dict[str, dict]:
    """Per vehicle: ``holdable``, ``residual`` (max |f(x_N, 0)|), ``speed`` (m/s),
    ``rate`` (rad/s, multirotors) and ``accel`` (|v̇| at zero input, m/s²)."""
    out: dict[str, dict] = {}
    for v in vehicle_list:
        vm = vehicles.model_of(v)
        names = vm.state_channels(v)
        if not all(c in channels and len(channels[c]) for c in names):
            continue
        x = np.array([float(channels[c][-1]) for c in names])
        nu = len(vm.input_channels(v))
        f = np.asarray(vm.ode(v)(x, np.zeros(nu))).ravel()
        row = {"residual": float(np.max(np.abs(f)))}
        vi = [names.index(c) for c in (f"{v.name}.vel.{a}" for a in "xyz") if c in names]
        if len(vi) == 3:
            row["speed"] = float(np.linalg.norm(x[vi]))
            row["accel"] = float(np.linalg.norm(f[vi]))
        if f"{v.name}.rate.x" in names:
            row["rate"] = float(np.linalg.norm([x[names.index(f"{v.name}.rate.{a}")]
                                                for a in "xyz"]))
        row["holdable"] = bool(row["residual"] <= HOLD_TOL + SLACK)
        out[v.name] = row
    return out


def flag(hold_end: bool, ends: dict[str, dict]) -> list[str]:
    """Notes for the vehicles whose final state cannot be held (none when the problem does
    not ask for a holdable end: ``end = free``)."""
    if not hold_end:
        return []
    notes = []
    for name, e in ends.items():
        if not e["holdable"]:
            rate = f", body rate {e['rate']:.3f} rad/s" if "rate" in e else ""
            motion = (f"speed {e['speed']:.3f} m/s{rate}, acceleration {e['accel']:.3f} m/s²"
                      if "speed" in e else f"largest rate of change {e['residual']:.3f}")
            notes.append(f"{name} ends in a state it cannot hold: {motion} at zero input (hover "
                         f"needs every rate of change ≤ {HOLD_TOL:g}); add a final hover or "
                         "`end = free` if the mission means it")
    return notes
