"""The report's flags: what a reader must see first, at the top of the summary, even on a
satisfied plan — a close pass to an obstacle and a high probability of violation under the
mission's declared uncertainty (the risk cases).  The tables further down hold the detail.

Levels (documented in docs/python.md and the report's own text):

* ``CLOSE_PASS_M``: a vehicle whose nearest approach to an obstacle leaves less than this
  much air beyond its ``radius`` (the clearance of ``stlc.analysis.clearance``, at the
  samples and on the straight segments between them);
* ``HIGH_RISK``: a risk case whose violation probability of the requirement (``risk.json``'s
  ``p_violation``) is at least this.
"""

from __future__ import annotations

import numpy as np

from stlc.planning.solution import Solution
from stlc.semantics.model import Mission, Program

from .common import channel, vehicles

CLOSE_PASS_M = 0.25  #: m of air beyond the vehicle's radius
HIGH_RISK = 0.10  #: violation probability of a risk case


def close_passes(program: Program, mission: Mission, sol: Solution) -> list[dict]:
    """A flag per vehicle whose clearance to an obstacle falls below its radius +
    ``CLOSE_PASS_M``."""
    from stlc.analysis.clearance import obstacle_clearance, segment_clearance

    out = []
    for v in vehicles(mission, sol):
        p = [channel(sol, f"{v}.pos.{a}") for a in "xyz"]
        veh = program.vehicles.get(v)
        if any(c is None or c.size == 0 for c in p) or veh is None:  # type: ignore[union-attr]
            continue
        P = np.stack(p, axis=1)  # type: ignore[arg-type]
        d = obstacle_clearance(program.scenario, P)
        if d is None or not d.size:
            continue
        seg = segment_clearance(program.scenario, P)
        k = int(np.argmin(d))
        low, t = float(d[k]), float(sol.times[k])
        if seg is not None and seg.size and float(np.min(seg)) < low:
            j = int(np.argmin(seg))
            low, t = float(seg[j]), float(sol.times[j])
        r = float(getattr(veh, "radius", 0.0) or 0.0)
        if low < r + CLOSE_PASS_M:
            air = low - r
            out.append({"kind": "clearance", "title": "Close pass",
                        "text": f"{v} passes {low * 100:.0f} cm from an obstacle at t ≈ {t:g} s"
                                f" ({'inside its radius' if air < 0 else f'{air * 100:.0f} cm'}"
                                f"{'' if air < 0 else ' of air'} beyond its radius {r:g} m; "
                                f"flagged below {CLOSE_PASS_M * 100:.0f} cm)"})
    return out


def high_risk(risk: dict | None) -> list[dict]:
    """A flag per risk case whose violation probability is at least ``HIGH_RISK``."""
    out = []
    for c in (risk or {}).get("cases", []):
        p = (c.get("p_violation") or {}).get("value")
        if p is None or p < HIGH_RISK:
            continue
        up = (c.get("p_violation") or {}).get("upper")
        bound = f" (≤ {up * 100:.0f} % with confidence {1 - c.get('delta', 0):g})" \
            if up is not None and c.get("delta") is not None else ""
        out.append({"kind": "risk", "title": "High violation risk",
                    "text": f"under risk case `{c.get('name')}` the plan violates the mission "
                            f"in {p * 100:.0f} % of {c.get('K')} realisations{bound}; "
                            f"flagged from {HIGH_RISK * 100:.0f} %"})
    return out


def flags(program: Program, mission: Mission, sol: Solution) -> list[dict]:
    """Every flag of the plan, close passes first."""
    return close_passes(program, mission, sol) + high_risk(sol.risk)
