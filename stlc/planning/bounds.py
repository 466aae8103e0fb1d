"""What the report draws on a plan's signal plots: the vehicles' own limits, the bounds
that the mission's predicates put on signals, and the outermost window of each named spec.
Read from the problem's data (vehicle models, predicate structure), not from text."""

from __future__ import annotations

import numpy as np

from stlc import vehicles
from stlc.planning.solution import Window
from stlc.planning.problem import PlanningProblem
from stlc.semantics import ir


def bound_kind(b: ir.Bound) -> str | None:
    """What a predicate's bound limits, for the report's plots: ``speed``, ``rotor_speed``,
    ``hover_speed`` (horizontal speed below which a vehicle counts as hovering),
    ``heading_margin`` or ``distance_min`` — read from the bound's signal and expression."""
    field = b.signal.split(".")[1] if b.signal.count(".") >= 1 else ""
    if field == "speed" and b.side == "upper":
        return "speed"
    if field == "rotor_speed":
        return "rotor_speed"
    if field == "horizontal_speed" and b.side == "upper":
        return "hover_speed"
    calls = b.calls | {x.fn for x in ir.expr_nodes(b.expr) if isinstance(x, ir.Call)}
    if "angdiff" in calls and b.side == "upper":
        return "heading_margin"
    if any(fn.startswith("sd_") for fn in calls):  # a distance to a region, not between drones
        return None
    if calls & {"dist", "norm"} and b.side == "lower":
        return "distance_min"
    return None


def stated_bounds(formula: ir.Formula) -> dict:
    """The limits a formula states: ``speed`` and ``rotor_speed`` as [lo, hi],
    ``heading_margin_deg``, ``distance_min``, ``hover_speed``."""
    out: dict = {}
    for p in ir.predicates(formula):
        if p.bound is None:
            continue
        kind, c = bound_kind(p.bound), abs(float(p.bound.value))
        if kind == "speed":
            out["speed"] = [0.0, c]
        elif kind == "rotor_speed":
            lo, hi = out.get("rotor_speed", [None, None])
            out["rotor_speed"] = [c, hi] if p.bound.side == "lower" else [lo, c]
        elif kind == "heading_margin":
            out["heading_margin_deg"] = round(float(np.degrees(c)), 6)
        elif kind is not None:
            out[kind] = c
    return out


def bound_specs(specs: dict[str, ir.Formula]) -> dict[str, list[str]]:
    """For each bound kind (as in ``stated_bounds``), the named specs that state it."""
    names = {"heading_margin": "heading_margin_deg"}
    out: dict[str, list[str]] = {}
    for name, f in specs.items():
        kinds = {bound_kind(p.bound) for p in ir.predicates(f) if p.bound is not None}
        for k in sorted(k for k in kinds if k is not None):
            out.setdefault(names.get(k, k), []).append(name)
    return out


def plot_bounds(problem: PlanningProblem) -> dict:
    """The vehicles' own limits and the limits the requirement states."""
    out: dict = {}
    for v in problem.vehicles():
        out.update(vehicles.model_of(v).plot_bounds(v))
    out.update(stated_bounds(problem.requirement))
    out.pop("hover_speed", None)
    return out


def spec_windows(problem: PlanningProblem) -> list[Window]:
    out = []
    for name, spec in problem.specs.items():
        g = spec.formula
        while isinstance(g, ir.And) and len(g.args) == 1:
            g = g.args[0]
        if isinstance(g, ir.WINDOWED):
            out.append(Window(name, g.lo, min(g.hi, problem.mission.horizon)))
    return out
