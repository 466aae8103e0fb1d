"""A mission's formulas over *another team*, without the checker.

The checker expands ``forall d in team`` / ``exists d in team`` into an ``And`` / ``Or``
over the mission's vehicles.  To judge the executed team of a backup takeover (the backup
added), that expansion must be redone for a larger team after check time.  So the checker
also keeps, for each quantifier over ``team``, a ``TeamQuant``: its checked parts by
combination of vehicles, and its body elaborated once with a *placeholder* vehicle per
bound name (``holes``; signals ``⟨d#3⟩.pos.x``).  ``freeze`` turns the checker's record of
them into a ``TeamForm`` (the requirement and named specs with those nodes kept) stored on
``model.Mission.team_form``; ``for_team`` is a pure function that re-instantiates the
mission for a team: a combination the checker expanded takes its checked part, a new one
the body with the placeholders renamed to its vehicles.  For the mission's own team it
returns formulas equal to the checked ones (``tests/test_team_form.py``).

A placeholder copies the first team member's data, so renaming it is exact only for a
vehicle whose fields *read through the quantifier* are the same up to its name
(``TeamQuant.compatible``, decided by the checker); another vehicle is a ``TeamFormError``.
Data flows one way: this module reads IR only (no source text, parser or checker).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from stlc.diagnostics import Span
from stlc.semantics import ir, nnf

__all__ = ["HOLE", "TeamForm", "TeamFormError", "TeamQuant", "for_team", "freeze",
           "instantiate", "rename_expr"]

HOLE = "⟨"  # placeholder vehicle names start with it (``⟨d#3⟩``): never a user's name


class TeamFormError(ValueError):
    """The mission cannot be re-instantiated for the team asked (``subject``: a vehicle)."""

    def __init__(self, message: str, subject: str = "") -> None:
        super().__init__(message)
        self.subject = subject


@dataclass(frozen=True, slots=True)
class TeamQuant:
    """A quantifier over the mission's team, kept: ``kind`` ``forall``/``exists``, one
    placeholder name per bound name, the body over the placeholders (None if the checker
    could not elaborate it so), the checked parts by combination (vehicle names, in team
    order), and the vehicles the placeholders may be renamed to."""

    kind: str
    holes: tuple[str, ...]
    body: ir.Formula | None
    parts: tuple[tuple[tuple[str, ...], ir.Formula], ...]
    compatible: frozenset[str]
    span: Span = field(default=ir.NO_SPAN, compare=False)


@dataclass(frozen=True, slots=True)
class TeamForm:
    """The requirement and the named specs of a mission with every ``TeamQuant`` kept
    (subformulas without one are the checked objects themselves)."""

    team: tuple[str, ...]
    requirement: ir.Formula
    specs: Mapping[str, ir.Formula]


def freeze(team: tuple[str, ...], requirement: ir.Formula, specs: Mapping[str, ir.Formula],
           table: Mapping[int, tuple[ir.Formula, TeamQuant]]) -> TeamForm | None:
    """The ``TeamForm`` of checked formulas; ``table`` maps ``id`` of each formula the
    checker returned for a team quantifier to (that formula, its ``TeamQuant`` whose body
    and parts are still checked formulas).  None when the mission quantifies over no team."""
    if not table:
        return None
    memo: dict[tuple[int, bool], ir.Formula] = {}

    def go(f, tagged: bool = True):
        hit = memo.get((id(f), tagged))
        if hit is not None:
            return hit
        q = table.get(id(f)) if tagged else None
        if q is not None and q[0] is f:  # a part or body may be ``f`` itself (one vehicle)
            tq = q[1]
            out = replace(tq, body=None if tq.body is None else go(tq.body, tq.body is not f),
                          parts=tuple((c, go(p, p is not f)) for c, p in tq.parts))
        else:
            kids = ir.children(f)
            new = [go(k) for k in kids]
            it = iter(new)  # map_children visits the children in order
            out = f if all(a is b for a, b in zip(kids, new)) else \
                ir.map_children(f, lambda _k: next(it))
        memo[(id(f), tagged)] = out
        return out

    return TeamForm(tuple(team), go(requirement), {k: go(v) for k, v in specs.items()})


def rename_expr(e: ir.Expr, env: Mapping[str, str]) -> ir.Expr:
    """``e`` with every signal of a placeholder vehicle renamed (``⟨d#3⟩.pos.x`` → the
    vehicle ``env`` gives for ``⟨d#3⟩``)."""
    match e:
        case ir.Sig(name):
            head, dot, rest = name.partition(".")
            return ir.Sig(env[head] + dot + rest) if head in env else e
        case ir.Const() | ir.Param():
            return e
        case ir.Neg(a):
            return ir.Neg(rename_expr(a, env))
        case ir.Bin(op, a, b):
            return ir.Bin(op, rename_expr(a, env), rename_expr(b, env))
        case ir.Call(fn, args):
            return ir.Call(fn, tuple(rename_expr(a, env) for a in args))
    raise TypeError(f"not an expression node: {e!r}")


def _rename_text(s: str, env: Mapping[str, str]) -> str:
    if HOLE in s:
        for hole, v in env.items():
            s = s.replace(hole, v)
    return s


def _rename_pred(p: ir.Pred, env: Mapping[str, str]) -> ir.Pred:
    b = p.bound
    if b is not None:
        b = replace(b, signal=_rename_text(b.signal, env), expr=rename_expr(b.expr, env))
    return ir.Pred(rename_expr(p.expr, env), p.label, p.span, b, p.origin)


def instantiate(forms: list[ir.Formula], team: tuple[str, ...]) -> list[ir.Formula]:
    """Formulas of a ``TeamForm`` for ``team``: every ``TeamQuant`` expanded over it (one
    memo: what the formulas share stays shared)."""
    memo: dict[tuple, ir.Formula] = {}

    def go(f, env: dict[str, str]):
        key = (id(f), tuple(sorted(env.items())))
        hit = memo.get(key)
        if hit is None:
            hit = memo[key] = _node(f, env)
        return hit

    def _node(f, env):
        if isinstance(f, TeamQuant):
            return _expand(f, env)
        if isinstance(f, ir.Pred):
            return _rename_pred(f, env) if env else f
        return ir.map_children(f, lambda k: go(k, env))

    def _expand(tq: TeamQuant, env):
        n = len(tq.holes)
        if len(team) < n:
            if tq.kind == "forall":  # as the checker: vacuously true
                return ir.TrueF(tq.span)
            raise TeamFormError(f"`exists` over {n} distinct vehicles of a team of "
                                f"{len(team)}")
        known = dict(tq.parts)
        parts = []
        for combo in itertools.combinations(team, n):
            if combo in known:
                parts.append(go(known[combo], env))
                continue
            bad = [v for v in combo if v not in tq.compatible]
            if tq.body is None or bad:
                who = bad[0] if bad else combo[0]
                raise TeamFormError(f"vehicle `{who}` reads different data than the team's "
                                    "in a quantifier over the team; the mission cannot be "
                                    "re-instantiated with it", who)
            parts.append(go(tq.body, {**env, **dict(zip(tq.holes, combo))}))
        if len(parts) == 1:
            return parts[0]
        return (ir.And if tq.kind == "forall" else ir.Or)(tuple(parts), tq.span)

    return [go(f, {}) for f in forms]


def for_team(mission, team: tuple[str, ...]):
    """``mission`` (a ``model.Mission``) with ``team`` as its vehicles and its requirement
    and named specs re-instantiated over it (a pure function of the checked mission)."""
    team = tuple(team)
    if team == tuple(mission.vehicles):
        return mission
    tf: TeamForm | None = mission.team_form
    if tf is None:  # nothing quantifies over the team
        return replace(mission, vehicles=team, simulate=None)
    names = list(tf.specs)
    req, *specs = instantiate([tf.requirement, *(tf.specs[k] for k in names)], team)
    if "margin_default" in mission.options:  # margins per unit: as the checker applied them
        req = nnf.with_margins(req, mission.options["margins"], mission.options["margin_default"])
    return replace(mission, vehicles=team, requirement=req, specs=dict(zip(names, specs)),
                   simulate=None)
