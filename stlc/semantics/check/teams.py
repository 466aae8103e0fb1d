"""Keeping the quantifiers over a mission's ``team`` (``stlc.semantics.teamform``).

``forall d in team`` is expanded over the mission's vehicles like any quantifier; for a
quantifier over ``team`` the checker also elaborates its body once more with a placeholder
vehicle per bound name (a copy of the first team member named ``⟨d#N⟩``; diagnostics of
that pass are dropped: the expansion already reported them), and records which vehicles
the placeholders may be renamed to (``compatible``: every field the body read through them
is the same, up to the name).  ``team_form`` freezes the record of a mission into the
``TeamForm`` stored on ``model.Mission.team_form``, from which ``teamform.for_team``
re-instantiates the mission for another team with no checker.

A mixin of the checker (``stlc.semantics.check.program.Checker``), on the shared
``Context``; ``vehicle_fields`` is the elaborator's own table of a vehicle's fields.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from stlc.diagnostics import Collector
from stlc.frontend import ast
from stlc.semantics import ir, teamform
from stlc.semantics.check.context import Context, Scope
from stlc.semantics.check.elaborate import vehicle_fields
from stlc.semantics.check.values import GroupV, Num, Sym, VehicleV


class TeamTemplates(Context):
    """Records each quantifier over ``team`` (``team_quant``) and freezes a mission's
    record (``team_form``)."""

    def team_quant(self, n: ast.Quant, scope: Scope, dom: GroupV, out: ir.Formula,
                   parts: tuple, total: int) -> ir.Formula:
        """``out``, the checked expansion of ``n`` over ``dom`` (``parts``: pairs of a
        combination of values and its formula), recorded when ``dom`` is the team;
        ``total`` is the expansion count before ``n`` (restored for the template pass)."""
        if dom is not scope.get("team") or not dom.items:
            return out
        seq = self.__dict__.setdefault("_hole_seq", itertools.count())
        k = next(seq)
        holes = tuple(f"{teamform.HOLE}{name}#{k}⟩" for name in n.names)
        src = dom.items[0].vehicle
        reads: dict[str, set[str]] = self.__dict__.setdefault("_hole_reads", {})
        for h in holes:
            reads[h] = set()
        saved = (self.d, getattr(self, "_quant_total", 0), getattr(self, "_quant_outer", 1))
        self.d, self._quant_total = Collector(), total
        stand_in = {h: replace(src, name=h) for h in holes}
        self.vehicles.update(stand_in)  # (looked up by name: the radius of `pos not in R`)
        try:
            body = self.formula(n.body, scope.child(
                {name: VehicleV(stand_in[h]) for name, h in zip(n.names, holes)}))
        finally:
            self.d, self._quant_total, self._quant_outer = saved
            for h in holes:
                del self.vehicles[h]
        read = set().union(*(reads.pop(h) for h in holes))
        tq = teamform.TeamQuant(
            n.kind, holes, body,
            tuple((tuple(v.vehicle.name for v in combo), f) for combo, f in parts),
            self._compatible(src, frozenset(read)), n.span)
        self.__dict__.setdefault("team_quants", {})[id(out)] = (out, tq)
        return out

    def _compatible(self, src, read: frozenset[str]) -> frozenset[str]:
        """The declared vehicles whose fields ``read`` equal ``src``'s up to the name."""
        cache = self.__dict__.setdefault("_compatible_cache", {})
        key = (src.name, read)
        if key not in cache:
            mine = vehicle_fields(src)
            cache[key] = frozenset(
                v.name for v in self.vehicles.values()
                if all(_same(mine.get(f), src.name, vehicle_fields(v).get(f), v.name)
                       for f in read))
        return cache[key]

    def team_form(self, team, requirement: ir.Formula | None, specs: dict
                  ) -> teamform.TeamForm | None:
        """The mission's ``TeamForm`` (None without a quantifier over the team, or when
        the requirement did not check); the record is emptied for the next mission."""
        table = self.__dict__.pop("team_quants", {})
        if requirement is None:
            return None
        return teamform.freeze(tuple(team), requirement, specs, table)


def _same(a, name_a: str, b, name_b: str) -> bool:
    """Two vehicles' values of one field are equal once each vehicle's name is a hole."""
    if a is None or b is None or type(a) is not type(b):
        return False
    if isinstance(a, Num):
        return a.dim == b.dim and np.array_equal(a.v, b.v)
    if isinstance(a, Sym):
        h = teamform.HOLE
        return (a.dim == b.dim and a.vector == b.vector and len(a.items) == len(b.items)
                and all(teamform.rename_expr(x, {name_a: h}) ==
                        teamform.rename_expr(y, {name_b: h}) for x, y in zip(a.items, b.items)))
    return False
