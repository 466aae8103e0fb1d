"""What the report draws on a plan's signal plots: the vehicles' own limits, the bounds
that the mission's predicates put on signals, and the outermost window of each named spec.
Read from the problem's data (vehicle models, predicate structure), not from text."""

from __future__ import annotations

import numpy as np

from stlc import ir, vehicles
from stlc.planning.problem import PlanningProblem
from stlc.solution import Window


def plot_bounds(problem: PlanningProblem) -> dict:
    out: dict = {}
    for v in problem.vehicles():
        out.update(vehicles.model_of(v).plot_bounds(v))
    for p in ir.predicates(problem.requirement):
        lab = p.label
        const = _const_side(p.expr)
        if const is None:
            continue
        if ".speed <=" in lab:
            out["speed"] = [0.0, const]
        elif ".rotor_speed in" in lab:
            lo, hi = out.get("rotor_speed", [None, None])
            out["rotor_speed"] = [const, hi] if "(lower)" in lab else [lo, const]
        elif "angdiff" in lab and "<=" in lab and "deg" in lab:
            out["heading_margin_deg"] = round(float(np.degrees(const)), 6)
        elif ("norm(" in lab or "dist(" in lab) and ">=" in lab:
            out["distance_min"] = const
    return out


def _const_side(e: ir.Expr) -> float | None:
    """``c - x`` or ``x - c`` → c (the bound of a simple predicate)."""
    if isinstance(e, ir.Bin) and e.op == "-":
        for side in (e.left, e.right):
            if isinstance(side, ir.Const):
                return abs(side.value)
    return None


def spec_windows(problem: PlanningProblem) -> list[Window]:
    out = []
    for name, spec in problem.specs.items():
        g = spec.formula
        while isinstance(g, ir.And) and len(g.args) == 1:
            g = g.args[0]
        if isinstance(g, (ir.Always, ir.Eventually, ir.Until)):
            out.append(Window(name, g.lo, min(g.hi, problem.mission.horizon)))
    return out
