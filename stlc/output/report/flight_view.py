"""The closed-loop flight section of the report (``stlc fly``): the plan beside the flown
trajectory.

``flight(solution, fl)`` is ``None`` without a flight.  Otherwise it returns plain data
for the verdict tiles (flown exact robustness beside the plan's, tracking error, the runs'
P(violation) with its bound), a table of every named spec planned and flown, the plan and
the flown path of each drone (top view), and the tracking error ‖p_flown − p_plan‖ at
each plan sample.  ``fl`` is ``{"record": flight.json's contents, "flown": the seeded
flight's channels}``.
"""

from __future__ import annotations

import numpy as np

from stlc.planning.solution import Solution

from .common import drone_color, fmt, nums

PLAN = "#8a94a3"


def _xy(channels: dict, v: str) -> list | None:
    cols = [channels.get(f"{v}.pos.{a}") for a in "xy"]
    return None if any(c is None for c in cols) else [nums(np.asarray(c, float)) for c in cols]


def flight(solution: Solution, fl: dict | None) -> dict | None:
    if fl is None:
        return None
    rec, flown = fl["record"], fl["flown"]
    drones = sorted({k.split(".")[0] for k in flown if ".pos." in k})
    paths = [{"vehicle": v, "color": drone_color(i), "plan": _xy(solution.channels, v),
              "flown": _xy(flown, v)} for i, v in enumerate(drones)]
    plan_specs, flown_specs = rec["plan"]["specs"], rec["flown"]["specs"]
    specs = [{"name": k, "plan": fmt(plan_specs.get(k), 4, signed=True),
              "flown": fmt(v, 4, signed=True),
              "holds": isinstance(v, float) and v > 0} for k, v in flown_specs.items()]
    runs = rec.get("runs")
    return {
        "plan": fmt(rec["plan"]["robustness"], 4, signed=True),
        "flown": fmt(rec["flown"]["robustness"], 4, signed=True),
        "ok": bool(rec["flown"]["satisfied"]),
        "max_error": fmt(rec["tracking"]["max_error_m"], 3),
        "rms_error": fmt(rec["tracking"]["rms_error_m"], 3),
        "setup": rec["setup"],
        "runs": None if runs is None else {
            "n": runs["n"], "p": fmt(runs["p_violation"], 4),
            "upper": fmt(runs["p_violation_upper"], 4), "confidence": fmt(1 - runs["delta"], 3),
            "var": {b: fmt(x, 4, signed=True) for b, x in runs["var"].items()},
            "cvar": {b: fmt(x, 4, signed=True) for b, x in runs["cvar"].items()}},
        "specs": specs, "paths": paths, "notes": list(rec.get("notes", [])),
        "error": {"t": nums(np.asarray(rec["tracking"]["envelope"]["t"], float)),
                  "e": nums(np.asarray(rec["tracking"]["envelope"]["error_m"], float))},
        "colors": {"plan": PLAN},
    }
