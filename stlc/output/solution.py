"""The writers of a ``Solution``: ``solution.json`` (``solution_json``) and
``trajectory.csv`` (``trajectory_csv``).

The types live in the planning layer (``stlc.planning.solution``) and are re-exported here,
as are the strict-JSON helpers of ``stlc.strictjson``, so ``from stlc.output.solution import
Solution`` keeps working.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np

from stlc.planning.solution import Comparison, Solution, SpecResult, Verdict, Window
from stlc.strictjson import channels_csv, json_number, strict, strict_dumps

__all__ = ["Comparison", "Solution", "SpecResult", "Verdict", "Window", "channels_csv",
           "comparison_json_dict", "json_number", "solution_json", "solution_json_dict",
           "strict", "strict_dumps", "trajectory_csv"]


def comparison_json_dict(c: Comparison) -> dict:
    return {"label": c.label, "energy": json_number(c.energy),
            "robustness_exact": json_number(c.robustness_exact),
            "specs": {k: json_number(v) for k, v in c.specs.items()},
            "peak_speed": json_number(c.peak_speed),
            "peak_rotor_speed": json_number(c.peak_rotor_speed)}


def solution_json_dict(sol: Solution) -> dict:
    """The contents of ``solution.json`` (strict JSON once ``strict_dumps`` writes it)."""
    num = json_number
    return {
        "mission": sol.mission,
        "status": str(sol.status),
        **({"conflict": list(sol.conflict)} if sol.status == Verdict.INFEASIBLE else {}),
        "robustness": {"exact": num(sol.robustness_exact),
                       "smooth": num(sol.robustness_smooth)},
        "specs": {
            k: {**{f: x for f, x in asdict(v).items() if f != "binding_origin"},
                "robustness": num(v.robustness), "smooth": num(v.smooth)}
            for k, v in sol.specs.items()
        },
        "energy": num(sol.energy),
        "energy_by_vehicle": {k: num(v) for k, v in sol.energy_by_vehicle.items()},
        "timing": {k: round(float(v), 4) for k, v in sol.timing.items()},
        "solver": sol.solver.to_json(),
        "smoothing": sol.smoothing,
        "problem_size": sol.problem_size,
        "notes": sol.notes,
        "comparisons": [comparison_json_dict(c) for c in sol.comparisons],
        **({"team": {"routes": sol.routes,
                     "events": [_event(e) for e in sol.events]}} if sol.routes else {}),
        "peak": {"speed": _peak(sol.channels, ".speed"),
                 "rotor_speed": _peak(sol.channels, ".rotor_speed.")},
        "end_state": sol.end_state,
    }


def solution_json(sol: Solution, mission=None) -> str:
    """``solution.json``; with the checked ``mission``, also the κ its verdict is judged
    against (``threshold``) and its margins per unit (``margins``: unit → SI value, when
    the mission gives ``margin = [...]``)."""
    out = solution_json_dict(sol)
    if mission is not None:
        out["threshold"] = json_number(mission.threshold)
        margins = (mission.options or {}).get("margins")
        if margins:
            out["margins"] = {str(u): json_number(v) for u, v in margins.items()}
    return strict_dumps(out, indent=2)


def trajectory_csv(sol: Solution) -> str:
    """``trajectory.csv``: ``t`` and one column per channel."""
    return channels_csv(sol.times, sol.channels)


def _event(e) -> dict:
    return {"drone": e.drone, "kind": e.kind, "region": e.region,
            "start": round(float(e.start), 6), "end": round(float(e.end), 6)}


def _peak(channels: dict[str, np.ndarray], key: str) -> float | None:
    """Largest value over the channels whose name contains ``key``."""
    vals = [float(np.max(v)) for k, v in channels.items() if key in k]
    return max(vals) if vals else None
