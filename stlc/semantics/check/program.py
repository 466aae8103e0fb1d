"""The checker: AST → ``model.Program`` (vehicles, scenario, missions; formulas as typed IR).

It resolves names (with "did you mean" hints), converts units to SI, tells formulas from
numbers, checks intervals against the mission step and horizon, rejects duplicates and
unknown fields, and collects *every* error of the pass before raising ``StlcError``.
Declaration order matters only for named specs (a spec may use the specs defined before
it); vehicles, the scenario and constants can appear anywhere in the file.

This is the top of the ``stlc.semantics.check`` package: ``Checker`` puts the two halves of the
elaborator together on the shared ``Context`` and runs the declaration and mission checks
in order.  The modules it uses import only ``context`` (and lower layers), never each other.
"""

from __future__ import annotations

from dataclasses import replace

from stlc.diagnostics import StlcError
from stlc.frontend import ast
from stlc.semantics import ir, model
from stlc.semantics.check import builtins, declarations, geometry, margins
from stlc.semantics.check.elaborate import ExpressionElaborator
from stlc.semantics.check.events import check_simulate
from stlc.semantics.check.formulas import FormulaElaborator
from stlc.semantics.check.mission import check_mission
from stlc.semantics.check.risklevel import with_levels
from stlc.semantics.check.teams import TeamTemplates
from stlc.semantics.check.values import Sym

TOP_KINDS = ("vehicle", "scenario", "mission", "spec", "const", "signal")


def check(tree: ast.File, placed: frozenset[str] = frozenset()) -> model.Program:
    """Check a parsed file; raise ``StlcError`` with all diagnostics if anything is wrong.

    ``placed`` names world regions whose centre becomes a parameter (``--set``).  A
    mission's quantifiers over its team are also kept (``Mission.team_form``), so that it
    can be judged over another team without checking again (``semantics.teamform``)."""
    ck = Checker(tree, placed)
    try:
        return ck.run()
    except RecursionError:  # the elaborator guards each value; this is the last resort
        ck.d.error("STL004", "formula nested too deeply", ck.where,
                   "name sub-formulas with `spec` instead")
        raise StlcError(ck.d.diagnostics) from None


class Checker(ExpressionElaborator, FormulaElaborator, TeamTemplates):
    """One checker pass over a file."""

    functions = {**builtins.FUNCS, **geometry.FUNCS,  # cylinder, sphere, capsule
                 "dist": geometry.distance_or(builtins.FUNCS["dist"])}  # dist(p, R) too

    def uncertain(self, m: ast.Uncertain, human: str | None, attach: bool = True
                  ) -> model.Normal | None:
        return declarations.uncertain(self, m, human, attach)

    def run(self) -> model.Program:
        members = self.tree.members
        signals = self._signals(members)
        for s in signals:  # bound first: a constant that reads a signal is STL210, not STL101
            self.globals.names[s] = Sym((ir.Sig(s),), None, False, (s,))
        self.consts([m for m in members if isinstance(m, ast.Named) and m.kind == "const"],
                    self.globals)
        for m in members:
            if isinstance(m, ast.Block) and m.kind == "vehicle":
                self.where = m.span
                declarations.vehicle(self, m)
        scen = [m for m in members if isinstance(m, ast.Block) and m.kind == "scenario"]
        for extra in scen[1:]:
            self.d.error("STL102", "a file has one scenario block", extra.span,
                         "merge the scenario blocks")
        if scen:
            declarations.scenario(self, scen[0])
        declarations.bind_world(self, self.globals)
        specs, spans = self.named_specs([m for m in members if isinstance(m, ast.Named)
                                         and m.kind == "spec"], self.globals, None)
        missions: dict[str, model.Mission] = {}
        for m in members:
            self.where = m.span
            if isinstance(m, ast.Block) and m.kind == "mission":
                mis = check_mission(self, m, specs)
                if mis is not None:
                    mis = margins.apply(self, m, mis)  # κ by unit (``margin = [...]``)
                    delay = (mis.replan or model.ReplanConfig()).takeover_delay
                    mis = replace(mis, simulate=check_simulate(self, m, mis.vehicles,
                                                               mis.horizon, delay),
                                  risk=with_levels(self, m, mis.risk))
                    missions[mis.name] = mis
            elif isinstance(m, ast.Block) and m.kind not in ("vehicle", "scenario"):
                self.bad_kind(m.kind, m.span, TOP_KINDS, "at the top level")
            elif isinstance(m, ast.Named) and m.kind not in ("spec", "const"):
                self.bad_kind(m.kind, m.span, TOP_KINDS, "at the top level")
            elif isinstance(m, (ast.Field, ast.Require, ast.Objective, ast.Uncertain)):
                self.d.error("STL108", "this belongs inside a block", m.span,
                             "put fields in a `vehicle`, `scenario` or `mission` block")
        self.d.raise_if_failed()
        return model.Program(
            file=self.tree.path, source=self.tree.source, signals=tuple(signals), specs=specs,
            spec_spans=spans, vehicles=self.vehicles,
            scenario=model.Scenario(tuple(self.regions), tuple(self.humans.values())),
            missions=missions, params=self.params)

    def _signals(self, members) -> list[str]:
        out: list[str] = []
        for m in members:
            if isinstance(m, ast.Signals):
                for name in m.names:
                    if self.define(name, m.span, "signal"):
                        out.append(name)
        return out
