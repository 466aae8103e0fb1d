"""The named specs of a mission: ``mission_specs`` gives the top-level specs about the
mission's vehicles and the mission's own, each as written and in negation normal form;
``mission_named`` is the one lookup of a mission by the name a user gave (STL101)."""

from __future__ import annotations

from dataclasses import dataclass

from stlc.diagnostics import Diagnostic, Span, StlcError, did_you_mean
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


def mission_named(path: str, program: model.Program, name: str) -> model.Mission:
    """The mission ``name`` of ``program`` (read from ``path``), or STL101 with a hint."""
    if name not in program.missions:
        raise StlcError([Diagnostic(
            "STL101", f"no mission `{name}` in {path}", Span(path, 1, 1, 1, 2),
            did_you_mean(name, program.missions) or
            "missions: " + (", ".join(program.missions) or "none"))])
    return program.missions[name]


def reads_payload(formula: ir.Formula) -> bool:
    """The formula reads a drone's payload: the one rule of a team mission (paper B)."""
    return any(s.endswith(".payload") for s in ir.signals(formula))
