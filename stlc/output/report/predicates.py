"""Readable predicate labels, and what the report learns from a mission's predicates.

The monitor names a binding predicate by its source text plus the face it binds on, with
the negations of the normal form spelled out: ``not (uav1.pos not in operator.behind (y <=
hi))`` is the face constraint of being *outside* ``operator.behind`` past its ``y = hi``
face.  What that predicate *is* — the face ``y <= hi`` of the box membership of
``operator.behind``, negated by the normal form — travels as data on the predicate
(``ir.Pred.origin``, set by the checker; ``SpecResult.binding_origin``), and ``readable``
renders it as ``uav1.pos outside operator.behind (y > hi)`` without reading the label; the
raw label stays in the view for the tooltip.  Which regions a mission mentions is read from
the same origins (``mentioned``), never by searching names in label text.
"""

from __future__ import annotations

from stlc.planning.bounds import stated_bounds
from stlc.semantics import ir
from stlc.semantics.origin import FACE, RANGE, Origin

_FLIP = {"<=": ">", ">=": "<", "<": ">=", ">": "<=", "==": "!=", "!=": "=="}
_PRETTY = (("<=", "≤"), (">=", "≥"), ("!=", "≠"))


def _pretty(s: str) -> str:
    for a, b in _PRETTY:
        s = s.replace(f" {a} ", f" {b} ")
    return s


def readable(origin: Origin | None, label: str = "") -> str:
    """A friendlier rendering of a binding predicate (same meaning), from its ``origin``;
    a predicate without one (built outside the checker) shows its label as written."""
    if not label:
        return "—"
    if origin is None:
        return _pretty(label)
    neg = origin.negated
    if origin.kind == FACE:
        op = ">=" if origin.side == "lo" else "<="
        where = "outside" if neg else "in"
        region = origin.region_text or origin.region
        if origin.side == "surface":  # a round region: one predicate, its signed distance
            return _pretty(f"{origin.subject} {where} {region}")
        return _pretty(f"{origin.subject} {where} {region} "
                       f"({origin.axis} {_FLIP[op] if neg else op} {origin.side})")
    if origin.kind == RANGE:
        lower = origin.side == "lower"
        op = (">=" if lower else "<=") if not neg else ("<" if lower else ">")
        return _pretty(f"{origin.subject} {op} {origin.bound_text}")
    part = f" [{origin.component}]" if origin.component else ""
    if not neg:
        return _pretty(f"{origin.text}{part}" if origin.text else label)
    if origin.op in _FLIP and origin.left and origin.right:
        return _pretty(f"{origin.left} {_FLIP[origin.op]} {origin.right}{part}")
    return _pretty(label)


def hover_speed(formula: ir.Formula | None) -> float | None:
    """The ``horizontal_speed <= c`` of a heading requirement (below it the vehicle counts
    as hovering and its direction of motion is undefined), if the mission states one."""
    if formula is None:
        return None
    return stated_bounds(formula).get("hover_speed")


def mentioned(formulas: list[ir.Formula]) -> set[str]:
    """The declared regions some predicate of ``formulas`` reads (its origin's ``regions``:
    a membership's region, or a region named in a comparison)."""
    return {r for f in formulas for p in ir.predicates(f) if p.origin is not None
            for r in p.origin.regions}
