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

With ``windows`` the same is done for ``eventually[a, b] φ`` (a smooth max over time):
``φ`` becomes ``φ and gate`` with ``gate = OFF/2 − (1 − mix)(1 − c)·OFF`` and a per-sample
row ``c``.  As written (mix = 1) the gate is +OFF/2 and changes nothing; fixed (mix = 0) the
samples with c = 0 drop out of the max, so again the fixed form's robustness is ≤ the
formula's.  ``choose`` walks the formula from sample 0 and, at every time the ``eventually``
is evaluated, keeps the sample of its window where φ is largest on the plan; nested windows
are evaluated only at the samples their parent kept.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from stlc.semantics import ir

MIX = "__mix"  #: 1: the written disjunctions, 0: the fixed branches
CHOICE = "__choice"  #: one-hot branch rows ``CHOICE.<node>.<branch>``
OFF = 1e3  #: what a branch that is not chosen loses (margins are O(1) in the planner form)


@dataclass(frozen=True, eq=False)
class Window:
    """An ``eventually`` whose sample is fixed; ``node`` is the node as written (``choose``
    finds it in the formula by identity)."""

    node: ir.Eventually


def name(j: int, i: int) -> str:
    return f"{CHOICE}.{j}.{i}"


def _names(j: int, node) -> list[str]:
    return [f"{CHOICE}.{j}.w"] if isinstance(node, Window) else [name(j, i)
                                                                 for i in range(len(node))]


def choice_form(f: ir.Formula, windows: bool = False) -> tuple[ir.Formula, list]:
    """``f`` with each ``or`` of ≥ 2 predicates (and, with ``windows``, each ``eventually``)
    rewritten (see the module docstring), and the rewritten nodes in order: the predicate
    expressions of a disjunction, a ``Window`` for an ``eventually``."""
    nodes: list = []
    off = ir.Bin("-", ir.Const(1.0), ir.Sig(MIX))  # 0 as written, 1 when fixed

    def go(g: ir.Formula) -> ir.Formula:
        match g:
            case ir.Eventually(lo, hi, arg, span) if windows:
                j = len(nodes)
                nodes.append(Window(g))
                c = ir.Sig(_names(j, nodes[-1])[0])
                gate = ir.Bin("-", ir.Const(OFF / 2), ir.Bin("*", ir.Bin("*", off, ir.Bin(
                    "-", ir.Const(1.0), c)), ir.Const(OFF)))
                return ir.Eventually(lo, hi, ir.And((go(arg), ir.Pred(gate, "choice", span)),
                                                    span), span)
            case ir.Or(args, span) if len(args) > 1 and all(isinstance(a, ir.Pred) for a in args):
                j = len(nodes)
                nodes.append(tuple(a.expr for a in args))
                return ir.Or(tuple(ir.Pred(ir.Bin("+", a.expr, ir.Bin("*", ir.Bin("*", off, ir.Bin(
                    "-", ir.Sig(name(j, i)), ir.Const(1.0))), ir.Const(OFF))), a.label, a.span)
                    for i, a in enumerate(args)), span)
        return ir.map_children(g, go)

    return go(f), nodes


def signals(nodes: list) -> list[str]:
    """The parameter signals in NLP-parameter order: MIX, then every branch or window row."""
    return [MIX] + [x for j, node in enumerate(nodes) for x in _names(j, node)]


def written(nodes: list, n: int) -> dict[str, np.ndarray]:
    """Parameter values for the formula as written (mix = 1)."""
    return {MIX: np.ones(n)} | {x: np.zeros(n) for x in signals(nodes)[1:]}


def choose(nodes: list, channels: Mapping[str, np.ndarray], params: Mapping[str, float], n: int,
           formula: ir.Formula | None = None, dt: float | None = None) -> dict[str, np.ndarray]:
    """Parameter values fixing, per sample, the branch with the largest margin, and (given
    the ``formula`` the nodes come from and the step ``dt``) each window's best samples."""
    from stlc.analysis import monitor

    out = {MIX: np.zeros(n)}
    for j, exprs in enumerate(nodes):
        if isinstance(exprs, Window):
            continue
        vals = np.array([np.broadcast_to(np.asarray(monitor.eval_expr(e, channels, params),
                                                    float), (n,)) for e in exprs])
        best = np.argmax(vals, axis=0)
        for i in range(len(exprs)):
            out[name(j, i)] = (best == i).astype(float)
    index = {id(node.node): j for j, node in enumerate(nodes) if isinstance(node, Window)}
    if index:
        if formula is None or dt is None:
            raise ValueError("fixing windows needs the formula and the step")
        rows = {j: np.zeros(n) for j in index.values()}
        _walk(formula, np.array([0]), monitor.Evaluator(dt, channels, params, n), index, rows)
        out.update({_names(j, nodes[j])[0]: row for j, row in rows.items()})
    return out


def _walk(g: ir.Formula, times: np.ndarray, ev, index: dict, rows: dict) -> None:
    """Mark, in ``rows``, the samples each window keeps when ``g`` is evaluated at ``times``."""
    n = ev.n
    if len(times) == 0:
        return

    def span(a: int, b: int) -> np.ndarray:
        return np.unique(np.concatenate([np.arange(t + a, min(t + b, n - 1) + 1)
                                         for t in times]))

    match g:
        case ir.Eventually(lo, hi, arg):
            a, b = ev.window(lo, hi)
            sig = ev.sig(arg)
            kept = [t + a + int(np.argmax(sig[t + a:min(t + b, n - 1) + 1]))
                    for t in times if t + a <= n - 1]
            kept = np.unique(np.array(kept, dtype=int))
            if id(g) in index:
                rows[index[id(g)]][kept] = 1.0
            _walk(arg, kept, ev, index, rows)
        case ir.Always(lo, hi, arg):
            _walk(arg, span(*ev.window(lo, hi)), ev, index, rows)
        case ir.Until(lo, hi, left, right) | ir.Release(lo, hi, left, right):
            a, b = ev.window(lo, hi)
            _walk(left, span(0, b), ev, index, rows)
            _walk(right, span(a, b), ev, index, rows)
        case ir.Next(arg):
            _walk(arg, times[times + 1 < n] + 1, ev, index, rows)
        case ir.And(args) | ir.Or(args):
            for c in args:
                _walk(c, times, ev, index, rows)
        case ir.Pred() | ir.TrueF() | ir.FalseF():
            pass
        case _:
            raise TypeError(f"_walk: not a formula node in negation normal form: {g!r}")
