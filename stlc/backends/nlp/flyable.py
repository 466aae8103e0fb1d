"""Plans that can fly: a holdable end state and no heading drift (rows and terms of the
CasADi NLP, ``nlp.model.build``).

**Holdable end state** (default; a mission's ``end = free`` turns it off).  The last sample
must be an equilibrium the vehicle can hold with zero input: every component of the
vehicle's own ODE at the last state, ``f(x_N, u = 0)``, within ``HOLD_TOL`` (SI units).  For
a multirotor that is speed and attitude rates ≈ 0 (ṗ = v, η̇ = W(η)ω) *and* rotor forces
at hover (v̇ ≈ 0: the thrust balances gravity to 0.05 m/s², ω̇ ≈ 0: no net torque); for a
point mass, v ≈ 0 (its input, the acceleration, is free).  The exact check on the plan is
``stlc.planning.holdable`` (the report flags a plan that misses it).

**Heading**: a small regulariser ``YAW_REG · Σ ω_z² / N`` on every multirotor's yaw rate,
so that the heading turns only where the requirement (or the dynamics) needs it; the guess
turns the heading along the course and nothing brought it back.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from stlc import vehicles

#: |f(x_N, 0)| per component (m/s, rad/s, m/s², rad/s², N/s) — see the module docstring
HOLD_TOL = 0.05
YAW_REG = 1e-3


def add_rows(g_list: list, lbg: list, ubg: list, hold_end: bool, layouts: list,
             wt: ca.SX, n: int) -> ca.SX:
    """Append the holdable-end rows (when the problem wants them: ``hold_end``) and return
    the heading regulariser (an objective term)."""
    term = ca.SX(0)
    for L in layouts:
        v = L.vehicle
        vm = vehicles.model_of(v)
        X = ca.reshape(wt[L.x_slice], L.nx, n)
        if hold_end:
            xdot = vm.ode(v)(X[:, -1], ca.DM.zeros(L.nu))
            g_list.append(ca.vec(xdot))
            lbg.append(np.full(L.nx, -HOLD_TOL))
            ubg.append(np.full(L.nx, HOLD_TOL))
        chans = vm.state_channels(v)
        rz = f"{v.name}.rate.z"
        if rz in chans:
            row = X[chans.index(rz), :]
            term += YAW_REG * ca.sumsqr(row) / max(n - 1, 1)
    return term
