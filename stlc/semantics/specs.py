"""The named specs of a mission: ``mission_specs`` gives the top-level specs about the
mission's vehicles and the mission's own, each as written and in negation normal form."""

from __future__ import annotations

from dataclasses import dataclass

from stlc.diagnostics import Span
from stlc.semantics import ir, model, nnf


@dataclass(frozen=True, slots=True)
class NamedSpec:
    """A named spec reported for a mission: the formula as written and its NNF."""

    name: str
    formula: ir.Formula
    normal: ir.Formula
    span: Span


def mission_specs(program: model.Program, mission: model.Mission) -> dict[str, NamedSpec]:
    """Named specs reported for a mission: top-level specs about its vehicles, then its
    own (a mission's spec shadows a top-level one of the same name)."""
    out: dict[str, NamedSpec] = {}
    team = set(mission.vehicles)
    for name, f in program.specs.items():
        used = {s.split(".")[0] for s in ir.signals(f)}
        if used and used <= team:
            out[name] = NamedSpec(name, f, nnf.normalize(f),
                                  program.spec_spans.get(name, Span.none()))
    for name, f in mission.specs.items():
        out[name] = NamedSpec(name, f, nnf.normalize(f), mission.spec_spans.get(name, Span.none()))
    return out
