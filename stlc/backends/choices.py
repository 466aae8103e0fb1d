"""Fixed disjunction choices for the energy stage of the CasADi NLP.

Maximising a smooth *max* (``or``) is not concave: −max in the objective gives the
Lagrangian Hessian negative curvature, and IPOPT regularises nearly every iteration.  Once
the robustness stage has a satisfying plan, the energy stage does not need to re-decide which
branch of each disjunction holds.  ``choice_form`` rewrites every ``or`` of predicates
a_1..a_k as the single predicate

    mix·max(a_1..a_k) + (1 − mix)·Σ_i c_i a_i

with ``mix`` and the per-sample one-hot rows ``c_i`` as signals that the NLP receives as
*parameters* (nothing is rebuilt).  With mix = 1 it is the written disjunction; with mix = 0
the chosen branch's margin is ≤ the max at every sample, so the robustness of the fixed form
is ≤ that of the formula: a plan whose fixed form satisfies the requirement satisfies the
requirement (the exact monitor still judges the formula as written).  ``choose`` picks, per
sample, the branch with the largest margin on a given plan.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from stlc.semantics import ir

MIX = "__mix"  #: 1: the written disjunctions, 0: the fixed branches
CHOICE = "__choice"  #: one-hot branch rows ``CHOICE.<node>.<branch>``
OFF = 1e3  #: what a branch that is not chosen loses (margins are O(1) in the planner form)


def name(j: int, i: int) -> str:
    return f"{CHOICE}.{j}.{i}"


def choice_form(f: ir.Formula) -> tuple[ir.Formula, list[tuple[ir.Expr, ...]]]:
    """``f`` with each ``or`` of ≥ 2 predicates rewritten (see the module docstring), and the
    predicate expressions of each rewritten node in order."""
    nodes: list[tuple[ir.Expr, ...]] = []

    def go(g: ir.Formula) -> ir.Formula:
        match g:
            case ir.Or(args, span) if len(args) > 1 and all(isinstance(a, ir.Pred) for a in args):
                j = len(nodes)
                nodes.append(tuple(a.expr for a in args))
                off = ir.Bin("-", ir.Const(1.0), ir.Sig(MIX))  # 0 as written, 1 when fixed
                return ir.Or(tuple(ir.Pred(ir.Bin("+", a.expr, ir.Bin("*", ir.Bin("*", off, ir.Bin(
                    "-", ir.Sig(name(j, i)), ir.Const(1.0))), ir.Const(OFF))), a.label, a.span)
                    for i, a in enumerate(args)), span)
        return ir.map_children(g, go)

    return go(f), nodes


def signals(nodes: list[tuple[ir.Expr, ...]]) -> list[str]:
    """The parameter signals in NLP-parameter order: MIX, then every branch row."""
    return [MIX] + [name(j, i) for j, ex in enumerate(nodes) for i in range(len(ex))]


def written(nodes: list[tuple[ir.Expr, ...]], n: int) -> dict[str, np.ndarray]:
    """Parameter values for the disjunctions as written (mix = 1)."""
    out = {MIX: np.ones(n)}
    out.update({name(j, i): np.zeros(n) for j, ex in enumerate(nodes) for i in range(len(ex))})
    return out


def choose(nodes: list[tuple[ir.Expr, ...]], channels: Mapping[str, np.ndarray],
           params: Mapping[str, float], n: int) -> dict[str, np.ndarray]:
    """Parameter values fixing, per sample, the branch with the largest margin (mix = 0)."""
    from stlc.analysis import monitor

    out = {MIX: np.zeros(n)}
    for j, exprs in enumerate(nodes):
        vals = np.array([np.broadcast_to(np.asarray(monitor.eval_expr(e, channels, params),
                                                    float), (n,)) for e in exprs])
        best = np.argmax(vals, axis=0)
        for i in range(len(exprs)):
            out[name(j, i)] = (best == i).astype(float)
    return out
