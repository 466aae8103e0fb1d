"""Conservative polyhedral inner approximations of norm bounds, for the MILP seed.

The seed's MILP keeps only affine predicates; every other one becomes ``true``
(``conflict.drop_nonlinear``), so a speed limit such as ``q1.speed <= 0.4 m/s`` —
``0.4 − sqrt(vx² + vy² + vz²) ≥ 0`` — was not in it at all: on random handovers the seed
path flew through the slow phase at up to 1.3 m/s over the limit, and the kinematic
smoothing did not always bring it back (its exact robustness below 0 on 3 of 4 such seeds,
then the NLP missed κ and the whole fallback ran).  Here a predicate ``c − ‖(a_1 … a_k)‖₂ ≥
0`` with affine a_i and a constant c becomes the box ``|a_i| ≤ c/√k`` for every i (a
conjunction: no binary).  The box lies inside the ball (‖a‖₂ ≤ √k · max|a_i|), so a path
that keeps it keeps the limit — an *inner* approximation, right for a seed (the MILP must
not pick a path the vehicle may not fly) and wrong for a proof, whose relaxation must
contain every plan: ``milp.conflict`` takes the box *around* the ball (``outer``: |a_i| ≤ c,
a margin c − |a_i| ≥ c − ‖a‖₂ for every i).  A norm bound from
below (``‖a‖ ≥ c``, not convex) and every other nonlinear predicate are left as they are.
"""

from __future__ import annotations

import math

from stlc.semantics import ir


def inner_norms(f: ir.Formula, params: dict, outer: bool = False) -> ir.Formula:
    """``f`` (in NNF) with every upper bound on a Euclidean norm of affine terms replaced by
    the box inside it (``outer``: the box around it); the rest unchanged."""
    memo: dict[int, tuple[ir.Formula, ir.Formula]] = {}

    def go(g: ir.Formula) -> ir.Formula:
        hit = memo.get(id(g))
        if hit is not None:
            return hit[1]
        out = _box(g, params, outer) if isinstance(g, ir.Pred) else ir.map_children(g, go)
        memo[id(g)] = (g, out)
        return out

    return go(f)


def norm_bounded(p: ir.Pred, params: dict) -> bool:
    """Is ``p`` an upper bound on a Euclidean norm of affine terms (what ``inner_norms``
    replaces by a box)?"""
    return _norm_bound(p.expr, params, p) is not None


def _box(p: ir.Pred, params: dict, outer: bool = False) -> ir.Formula:
    parts = _norm_bound(p.expr, params, p)
    if parts is None:
        return p
    c, terms = parts
    r = c if outer else ir.Bin("*", ir.Const(1.0 / math.sqrt(len(terms))), c)
    preds = []
    for a in terms:
        for e, side in ((ir.Bin("-", r, a), "upper"), (ir.Bin("+", r, a), "lower")):
            preds.append(ir.Pred(e, f"{p.label} (inner box, {side})", p.span))
    return ir.And(tuple(preds), p.span)


def _norm_bound(e: ir.Expr, params: dict, p: ir.Pred):
    """(c, [a_1 … a_k]) when ``e`` is ``c − sqrt(a_1² + … + a_k²)`` with a constant c and
    affine a_i; else None."""
    from stlc.backends.milp.encode import NotLinear, affine

    if not (isinstance(e, ir.Bin) and e.op == "-" and isinstance(e.right, ir.Call)
            and e.right.fn == "sqrt" and len(e.right.args) == 1):
        return None
    try:
        cs, _ = affine(e.left, params, p)
    except (NotLinear, ValueError):
        return None
    if cs:  # c reads a signal
        return None
    terms = _squares(e.right.args[0])
    if not terms:
        return None
    for a in terms:
        try:
            affine(a, params, p)
        except (NotLinear, ValueError):
            return None
    return e.left, terms


def _squares(e: ir.Expr) -> list[ir.Expr] | None:
    """[a_1 … a_k] when ``e`` is a sum of squares a_i·a_i (or a_i ^ 2); else None."""
    if isinstance(e, ir.Bin) and e.op == "+":
        left, right = _squares(e.left), _squares(e.right)
        return None if left is None or right is None else left + right
    if isinstance(e, ir.Bin) and e.op == "*" and e.left == e.right:
        return [e.left]
    if (isinstance(e, ir.Bin) and e.op == "^" and isinstance(e.right, ir.Const)
            and e.right.value == 2):
        return [e.left]
    return None
