"""Why a replan was not flown, in words (``replan.json``: ``detail.reason``; printed by
``stlc simulate``), and the ``replan`` defaults drawn from the vehicle's limits.

A triggered replan is flown only if IPOPT converged, within the budget t_c, rejoining the
reference within tolerance, with every kept spec ≥ κ on the segment.  Each failed test gets
its sentence; for a solve that did not converge the first suspect is the segment length:
correcting a position error d in T seconds with an acceleration limit a (per axis) needs
d ≤ a·T²/4 (accelerate half the time, brake the other half: the bang-bang bound), so the
reason quotes d, T, a·T²/4 and the shortest segment that could do it, 2·√(d/a).

**Defaults** (a ``replan`` block that leaves them out, or none): ζ = 1 m, T_e = 0.5 s,
t_c = 0.4 s as in paper A (Table 3); the waypoint period T_g — the segment is T_g … 2·T_g
long — is the larger of 1 s and the time the vehicle needs to correct a deviation of 1.5·ζ
at half its acceleration limit, 2·√(1.5·ζ / (a/2)), rounded up to the mission step.
"""

from __future__ import annotations

import math

import numpy as np


def shortest_segment(d: float, a: float) -> float:
    """The shortest time that corrects a position error d (m) at acceleration a (m/s²)."""
    return 2.0 * math.sqrt(max(d, 0.0) / a) if a > 0 else math.inf


def min_time(x: float, v: float, a: float) -> float:
    """The least time that brings a double integrator from (x, v) to rest at 0 with
    |ẍ| ≤ a (bang-bang, one switch): with σ = x + v|v|/(2a), T = (v + 2√(a·x + v²/2))/a
    for σ > 0, mirrored for σ < 0, |v|/a on the switching curve."""
    if not a > 0:
        return math.inf
    sigma = x + v * abs(v) / (2 * a)
    if sigma < 0:
        x, v = -x, -v
    elif sigma == 0:
        return abs(v) / a
    return (v + 2.0 * math.sqrt(max(a * x + v * v / 2.0, 0.0))) / a


def default_waypoint_period(threshold: float, acc_max: np.ndarray, step: float) -> float:
    """T_g from the vehicle's limits (module docstring)."""
    a = float(np.min(acc_max)) / 2.0
    t = max(1.0, shortest_segment(1.5 * threshold, a))
    return math.ceil(t / step - 1e-9) * step


def reason(*, converged: bool, status: str, within_budget: bool, solve_s: float,
           budget: float, rejoin: float, rejoin_tol: float, kept: dict[str, float],
           kappa: float, deviation: np.ndarray, segment_s: float, acc_max: np.ndarray
           ) -> str:
    """The sentence(s) for a replan that was not flown ('' if it was acceptable)."""
    out = []
    if not converged:
        d = np.abs(np.asarray(deviation, float))
        a = np.asarray(acc_max, float)
        reach = a * segment_s ** 2 / 4.0
        worst = int(np.argmax(d / np.maximum(reach, 1e-12)))
        axis = "xyz"[worst]
        txt = (f"IPOPT ended `{status}`: rejoining the plan means correcting "
               f"{d[worst]:.2f} m in {axis} within the {segment_s:g} s segment; at the "
               f"acceleration limit {a[worst]:g} m/s² at most {reach[worst]:.2f} m can be "
               "corrected in that time (a·T²/4)")
        if d[worst] > reach[worst]:
            need = shortest_segment(d[worst], a[worst])
            txt += (f" — the segment is too short: it needs ≥ {need:.2f} s, raise "
                    f"`replan {{ waypoint_period }}` to ≥ {need / 2:.2f} s")
        else:
            txt += " — reachable, so the kept specs or the flight envelope bind"
        out.append(txt)
    if not within_budget:
        out.append(f"the solve took {solve_s:.3f} s, over the budget t_c = {budget:g} s")
    if converged and rejoin > rejoin_tol:
        out.append(f"the segment rejoins the plan only to {rejoin:.2e} (tolerance "
                   f"{rejoin_tol:g})")
    low = {k: v for k, v in kept.items() if not v >= kappa}
    for k, v in low.items():
        out.append(f"kept spec `{k}` has robustness {v:+.4f} < κ = {kappa:g} on the segment")
    return "; ".join(out)
