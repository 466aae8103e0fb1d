"""κ with units: a robustness margin per unit of measure (``margin = [...]`` in a mission).

Robustness is measured in the units of each predicate: metres for positions and
distances, m/s for speeds, rad for angles, Hz for rotor speeds.  One unitless ``threshold``
κ asks the same number of every one of them (0.05 is 5 cm, 0.05 m/s, 2.9° and 0.05 Hz at
once), which ``stlc.semantics.lint`` warns about (STLW05).  A mission may instead give a
margin per unit::

    margin = [0.1 m, 0.05 m/s, 2 deg, 1 Hz]

Every predicate of the requirement (in negation normal form, so a negated one too) must
then hold with the margin of its own unit, and ``threshold`` is the margin of the units
the list does not name (default 0).  The checked mission's requirement becomes the normal
form with each predicate ``e ≥ 0`` written ``e − margin(unit) ≥ 0`` and κ = 0, so every
pass (the planners, the exact monitor's verdict) reads margins as data; a list whose
margins are all equal over the units present is exactly that κ and changes nothing else.
The mission's ``options["margins"]`` keeps the list (unit → SI value) for the report.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from stlc.frontend import ast
from stlc.semantics import ir, model, nnf
from stlc.semantics.check import units
from stlc.semantics.check.context import Context
from stlc.semantics.check.values import ErrorV, Num

def units_of(f: ir.Formula) -> dict[str, int]:
    """Unit → number of predicates of ``f`` measured in it (known units only)."""
    out: dict[str, int] = {}
    for p in ir.predicates(f):
        u = p.origin.unit if p.origin is not None else ""
        if u:
            out[u] = out.get(u, 0) + 1
    return out


def _read(ck: Context, node: ast.Node, scope) -> dict[str, float] | None:
    items = node.items if isinstance(node, ast.List) else (node,)
    out: dict[str, float] = {}
    for it in items:
        v = ck.value(it, scope)
        if isinstance(v, ErrorV):
            return None
        if not isinstance(v, Num) or v.v.ndim != 0 or v.dim is None:
            ck.err("STL204", "a margin is one number with its unit, e.g. `0.1 m`", it.span,
                   "margin = [0.1 m, 0.05 m/s, 2 deg, 1 Hz]")
            return None
        x = float(v.v)
        if not (np.isfinite(x) and x >= 0):
            ck.err("STL207", f"a margin must be a finite number >= 0, found {x:g}", it.span)
            return None
        name = units.unit_name(v.dim)
        if name in out:
            ck.err("STL207", f"two margins in {name}", it.span, "give one margin per unit")
            return None
        out[name] = x
    return out


def apply(ck: Context, block: ast.Block, mission: model.Mission) -> model.Mission:
    """The checked mission with its ``margin`` list applied (module docstring)."""
    m = next((x for x in block.members if isinstance(x, ast.Field) and x.name == "margin"),
             None)
    if m is None:
        return mission
    margin = _read(ck, m.value, ck.globals.child({}))
    if margin is None:
        return mission
    kappa = mission.threshold
    options = {**mission.options, "margins": margin}
    present = units_of(nnf.normalize(mission.requirement))
    values = {margin.get(u, kappa) for u in present} or {kappa}
    if len(values) == 1:  # one margin over every unit present: that is κ
        return dataclasses.replace(mission, threshold=values.pop(), options=options)
    options["margin_default"] = kappa  # for a requirement re-formed over another team
    return dataclasses.replace(mission, requirement=nnf.with_margins(mission.requirement, margin,
                                                                     kappa),
                               threshold=0.0, options=options)
