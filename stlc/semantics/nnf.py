"""The normaliser of the IR (``stlc.semantics.ir``): negation normal form.

``normalize`` desugars ``Implies``, pushes ``Not`` down to predicates (negation normal
form, adding ``Release`` as the dual of ``Until``) and flattens nested ``And``/``Or``;
every backend interprets the normalised formula (``ir.NNF_NODES``).
"""

from __future__ import annotations

import dataclasses

from stlc.diagnostics import Span
from stlc.semantics import ir
from stlc.semantics.ir import (
    Always,
    And,
    Bin,
    Const,
    Eventually,
    Expr,
    FalseF,
    Formula,
    Implies,
    Neg,
    Next,
    Not,
    Or,
    Pred,
    Release,
    TrueF,
    Until,
)


def negate_expr(e: Expr) -> Expr:
    if isinstance(e, Const):
        return Const(-e.value)
    if isinstance(e, Neg):
        return e.arg
    if isinstance(e, Bin) and e.op == "-":
        return Bin("-", e.right, e.left)
    return Neg(e)


def _negate_label(label: str) -> str:
    return f"not ({label})" if label else ""


def normalize(f: Formula) -> Formula:
    """Desugar ``implies``, push negations to predicates, flatten and/or.

    Linear in the size of the formula as a DAG: a subformula shared by reference (a named
    spec used twice) is normalised once per polarity, so the result shares it too."""
    return _nnf(f, False, {})


def normalize_many(fs, flat_max: int | None = None) -> list[Formula]:
    """``normalize`` of several formulas with one memo: what they share stays shared.
    ``flat_max``: an ``And``/``Or`` child with more operands than this is kept nested, not
    flattened (same exact robustness; a chain of n specs ``s_i = s_{i-1} and p_i`` is then
    of size O(n), not O(n²)).  Smooth semantics depend on flattening: only for exact use."""
    memo: dict = {"flat_max": flat_max}
    return [_nnf(f, False, memo) for f in fs]


def _nnf(f: Formula, neg: bool, memo: dict) -> Formula:
    key = (id(f), neg)
    hit = memo.get(key)
    if hit is None:
        hit = memo[key] = (f, _nnf_node(f, neg, memo))  # f kept alive: ids stay unique
    return hit[1]


def _nnf_node(f: Formula, neg: bool, memo: dict) -> Formula:
    match f:
        case Pred(expr, label, span, bound, origin):
            if not neg:
                return f
            return Pred(negate_expr(expr), _negate_label(label), span,
                        bound.negated() if bound is not None else None,
                        origin.negation() if origin is not None else None)
        case TrueF(span):
            return FalseF(span) if neg else f
        case FalseF(span):
            return TrueF(span) if neg else f
        case Not(arg):
            return _nnf(arg, not neg, memo)
        case Implies(a, b, span):
            return _nnf(Or((Not(a), b), span), neg, memo)
        case And(args, span):
            kids = tuple(_nnf(a, neg, memo) for a in args)
            return _flat(Or if neg else And, kids, span, memo.get("flat_max"))
        case Or(args, span):
            kids = tuple(_nnf(a, neg, memo) for a in args)
            return _flat(And if neg else Or, kids, span, memo.get("flat_max"))
        case Always(lo, hi, arg, span):
            return (Eventually if neg else Always)(lo, hi, _nnf(arg, neg, memo), span)
        case Eventually(lo, hi, arg, span):
            return (Always if neg else Eventually)(lo, hi, _nnf(arg, neg, memo), span)
        case Until(lo, hi, a, b, span):
            return (Release if neg else Until)(lo, hi, _nnf(a, neg, memo), _nnf(b, neg, memo),
                                               span)
        case Release(lo, hi, a, b, span):
            return (Until if neg else Release)(lo, hi, _nnf(a, neg, memo), _nnf(b, neg, memo),
                                               span)
        case Next(arg, span):
            return Next(_nnf(arg, neg, memo), span)
    raise TypeError(f"not a formula node: {f!r}")


def _flat(cls: type, kids: tuple[Formula, ...], span: Span,
          flat_max: int | None = None) -> Formula:
    out: list[Formula] = []
    for k in kids:
        if isinstance(k, cls) and (flat_max is None or len(k.args) <= flat_max):
            out.extend(k.args)
        else:
            out.append(k)
    if len(out) == 1:
        return out[0]
    return cls(tuple(out), span)


def with_margins(f: ir.Formula, margin: dict[str, float], default: float) -> ir.Formula:
    """``f`` in normal form with each predicate lowered by the margin of its unit."""
    memo: dict[int, ir.Formula] = {}

    def go(g: ir.Formula) -> ir.Formula:
        hit = memo.get(id(g))
        if hit is None:
            if isinstance(g, ir.Pred):
                u = g.origin.unit if g.origin is not None else ""
                m = margin.get(u, default)
                # the bound (the limit as written, for reports and separations) is kept
                hit = g if m == 0 else dataclasses.replace(
                    g, expr=ir.Bin("-", g.expr, ir.Const(m)))
            else:
                hit = ir.map_children(g, go)
            memo[id(g)] = hit
        return hit

    return go(normalize(f))
