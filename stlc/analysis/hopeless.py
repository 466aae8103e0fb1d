"""Check-time proofs that no plan exists: a start state below κ at t = 0 (STL505).

Every plan starts at the vehicles' declared start, so a part of the requirement that must
hold *at t = 0* and is below κ there makes every plan's robustness < κ.  ``hopeless``
finds such parts without planning, walking the requirement in negation normal form from
its root and keeping only what bounds its robustness from above at sample 0:

* ``and``: each operand (ρ(a ∧ b) ≤ ρ(a));
* ``always[0, b] f``: ``f`` at sample 0 (the window holds sample 0);
* ``f until[a, b] g``: ``f`` at sample 0 (every witness's left window starts at 0);
* a *state formula* (no temporal operator: a predicate, or an ``or`` of them such as
  ``p not in R`` — outside R on some face) whose signals are all fixed by the start: its
  exact robustness on the start state (the exact monitor on a one-sample trace).

Fixed at the start are the declared positions, velocities and attitudes and what is
derived from them alone (speed, horizontal speed, heading, course).  Anything else (an
``eventually``, an ``or`` with a temporal operand, an input, a rotor force) is skipped:
only a proof is reported.  A value below κ is an error naming the mission, the spec, the
predicate as written, the time (0 s) and the value in its unit.
"""

from __future__ import annotations

import numpy as np

from stlc import vehicles
from stlc.analysis import monitor
from stlc.diagnostics import Diagnostic
from stlc.semantics import ir, model, nnf

#: signal fields the declared start fixes (the state's own, and those derived from them)
FIXED = frozenset({"pos", "vel", "att", "speed", "horizontal_speed", "heading", "course"})
TEMPORAL = (ir.Always, ir.Eventually, ir.Until, ir.Release, ir.Next)


def start_channels(program: model.Program, mission: model.Mission) -> dict[str, np.ndarray]:
    """One sample of every fixed channel of the mission's vehicles at their start."""
    out: dict[str, np.ndarray] = {}
    for name in mission.vehicles:
        v = program.vehicles.get(name)
        if v is None:
            continue
        vm = vehicles.model_of(v)
        x0 = np.asarray(vm.initial_state(v), float)
        ch = {c: np.array([x0[i]]) for i, c in enumerate(vm.state_channels(v))}
        try:
            ch.update(vm.derived_channels(v, vehicles.state_matrix(v, ch)))
        except (ValueError, KeyError, IndexError):  # a model that derives nothing from one row
            pass
        out.update({c: np.asarray(x, float)[:1] for c, x in ch.items()
                    if c.split(".")[1] in FIXED and np.size(x)})
    return out


def _necessary(f: ir.Formula, out: list[ir.Formula]) -> None:
    match f:
        case ir.And(args):
            for a in args:
                _necessary(a, out)
        case ir.Always(lo, _, a) if lo == 0:
            _necessary(a, out)
        case ir.Until(_, _, a, _):
            _necessary(a, out)
        case _:
            if not any(isinstance(g, TEMPORAL) for g in ir.nodes(f)):
                out.append(f)


def _spec_of(program: model.Program, mission: model.Mission, preds: list[ir.Pred]
             ) -> str | None:
    for name, s in {**program.specs, **mission.specs}.items():
        mine = set(ir.predicates(nnf.normalize(s)))
        if any(p in mine for p in preds):
            return name
    return None


def hopeless(program: model.Program, missions=None) -> list[Diagnostic]:
    """STL505 for every part of a mission's requirement that the start holds below κ."""
    out = []
    for m in (missions if missions is not None else program.missions.values()):
        ch = start_channels(program, m)
        parts: list[ir.Formula] = []
        _necessary(nnf.normalize(m.requirement), parts)
        for g in parts:
            if not ir.signals(g) or not ir.signals(g) <= set(ch):
                continue
            with np.errstate(all="ignore"):
                rho = float(monitor.robustness(g, m.step, ch, program.params))
            if not rho < m.threshold:
                continue
            preds = ir.predicates(g)
            o = preds[0].origin
            text = (o.text if o is not None and o.text else preds[0].label) or "a predicate"
            if len(preds) == 1 and o is not None and o.axis:  # which face of the box
                text += f" ({o.axis} {'>=' if o.side == 'lo' else '<='} {o.side})"
            unit = f" {o.unit}" if o is not None and o.unit not in ("", "1") else ""
            spec = _spec_of(program, m, preds)
            where = f"spec `{spec}`" if spec else "the requirement"
            out.append(Diagnostic(
                "STL505", f"mission `{m.name}` cannot meet κ = {m.threshold:g}: {where} needs "
                f"`{text}` at t = 0 s, where the start gives {rho:+.4g}{unit}", g.span
                if g.span.known else preds[0].span,
                "every plan starts there: move the start, or lower the threshold"))
    return out
