"""The invariants a replanning segment keeps (paper A §4.4): ``kept_clauses`` splits the
kept specs of a problem into one ``Clause`` per ``always[a, b]`` over state predicates of
one vehicle, with its window in mission samples; ``KeptSpecError`` says why a spec cannot
be kept.  Used by the segment backend (``stlc.backends.replan.segment``), which lowers the
clauses, and by the replanning loop (``stlc.replan.disturb``), which judges them."""

from __future__ import annotations

from dataclasses import dataclass

from stlc import vehicles
from stlc.semantics import ir, model


class KeptSpecError(ValueError):
    """A spec named in ``replan { keep = [...] }`` cannot be kept by a segment."""

    def __init__(self, spec: str, message: str):
        super().__init__(message)
        self.spec = spec


@dataclass(frozen=True)
class Clause:
    """``always[first, last] body`` of a kept spec, in mission samples, for one vehicle."""

    spec: str
    first: int
    last: int
    body: ir.Formula  # no temporal operator; NNF


BODY_NODES = (ir.Pred, ir.And, ir.Or, ir.TrueF, ir.FalseF)


def kept_clauses(problem, names, vehicle: model.Vehicle) -> list[Clause]:
    """The clauses of the kept specs ``names`` that read ``vehicle``'s signals.  Raises
    ``KeptSpecError`` for an unknown spec, a spec that is not a conjunction of ``always``
    over state predicates, or one that reads another vehicle or a non-state signal."""
    grid = problem.grid
    states = set(vehicles.model_of(vehicle).state_channels(vehicle))
    # the planned vehicles and those whose channels the problem holds fixed
    owners = {v.name for v in problem.vehicles()} | {c.split(".")[0] for c in problem.fixed_channels}
    out: list[Clause] = []
    for name in names:
        spec = problem.specs.get(name)
        if spec is None:
            raise KeptSpecError(name, f"`keep` names `{name}`, which is not a spec of mission "
                                f"`{problem.mission.name}`")
        f = spec.normal
        parts = f.args if isinstance(f, ir.And) else (f,)
        for part in parts:
            if isinstance(part, ir.TrueF):
                continue
            if not isinstance(part, ir.Always) or not all(
                    isinstance(g, BODY_NODES) for g in ir.nodes(part.arg)):
                raise KeptSpecError(name, f"kept spec `{name}` is not an `always` over state "
                                    "predicates (or a conjunction of them): a replanning "
                                    "segment can only keep such invariants")
            sigs = ir.signals(part.arg)
            users = {s.split(".")[0] for s in sigs}
            if len(users) > 1 or not users <= owners:
                raise KeptSpecError(name, f"kept spec `{name}` reads several vehicles "
                                    f"({', '.join(sorted(users))}): a segment replans one "
                                    "vehicle with the others' plans unchanged")
            if users != {vehicle.name}:
                continue
            bad = sorted(sigs - states)
            if bad:
                raise KeptSpecError(name, f"kept spec `{name}` reads `{bad[0]}`, which is "
                                    f"not a state of {vehicle.name}: only state predicates "
                                    "can be kept on a segment")
            a, b = grid.window(part.lo, part.hi)
            out.append(Clause(name, max(a, 0), min(b, grid.n - 1), part.arg))
    return out
