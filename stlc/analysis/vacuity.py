"""``STLW02``: an implication that holds only vacuously on a plan (or a trace).

``a implies b`` is true wherever ``a`` is false.  When the antecedent never holds at any
sample where the implication is evaluated, the implication says nothing about the plan —
typically a plan that stays *on the face* of the gate box, where ``pos in gate`` has
robustness 0 (not > 0), so ``in gate implies eventually in guard`` is 0 as well and the
plan is judged on that boundary.  The warning names the time at which the antecedent
comes closest to holding, and says when the plan touches its boundary there (|ρ| ≤ 1e-6).

Evaluation times: the root at sample 0; ``always``/``eventually``[a, b] at k evaluate
their operand on k + ⌈a/Δt⌉ … k + ⌊b/Δt⌋ (clipped), ``until`` both sides on its window,
``next`` at k + 1; Boolean connectives pass the times through.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.analysis import monitor
from stlc.diagnostics import Diagnostic
from stlc.semantics import ir

TOUCH = 1e-6


def _window(mask: np.ndarray, lo: float, hi: float, dt: float) -> np.ndarray:
    n = len(mask)
    with np.errstate(over="ignore"):
        qa, qb = lo / dt, hi / dt
    a = n if not (math.isfinite(qa) and qa < n) else int(math.ceil(qa - 1e-9))
    b = n - 1 if not (math.isfinite(qb) and qb < n) else int(math.floor(qb + 1e-9))
    out = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(mask):
        if k + a < n:
            out[k + a: min(n, k + b + 1)] = True
    return out


def _implications(f: ir.Formula, mask: np.ndarray, dt: float, out: list) -> None:
    if isinstance(f, ir.Implies):
        out.append((f, mask))
    if isinstance(f, (ir.Always, ir.Eventually)):
        _implications(f.arg, _window(mask, f.lo, f.hi, dt), dt, out)
    elif isinstance(f, (ir.Until, ir.Release)):
        w = _window(mask, f.lo, f.hi, dt)
        left = w | _window(mask, 0.0, f.hi, dt)
        _implications(f.left, left, dt, out)
        _implications(f.right, w, dt, out)
    elif isinstance(f, ir.Next):
        _implications(f.arg, np.roll(mask, 1) & (np.arange(len(mask)) > 0), dt, out)
    else:
        for c in ir.children(f):
            _implications(c, mask, dt, out)


def _has_implies(f: ir.Formula, memo: dict[int, bool]) -> bool:
    """Does ``f`` contain an implication?  Iterative, shared subformulas visited once (a
    chain of named specs inlines each into the next)."""
    stack = [(f, False)]
    while stack:
        g, done = stack.pop()
        if id(g) in memo:
            continue
        kids = ir.children(g)
        if done or not kids:
            memo[id(g)] = isinstance(g, ir.Implies) or any(memo.get(id(c), False)
                                                            for c in kids)
        else:
            stack.append((g, True))
            stack.extend((c, False) for c in kids if id(c) not in memo)
    return memo[id(f)]


def vacuous(formulas: dict[str, ir.Formula], dt: float, channels: dict, params: dict,
            n: int) -> list[Diagnostic]:
    """One ``STLW02`` warning per implication (by source position) of ``formulas`` whose
    antecedent is ≤ 0 at every sample where it is evaluated."""
    seen: set = set()
    out: list[Diagnostic] = []
    memo: dict[int, bool] = {}
    for name, f in formulas.items():
        if n < 1 or not _has_implies(f, memo):
            continue
        start = np.zeros(n, dtype=bool)
        start[0] = True
        found: list = []
        _implications(f, start, dt, found)
        for node, mask in found:
            key = (node.span.file, node.span.line, node.span.col)
            if key in seen or not mask.any():
                continue
            a = np.asarray(monitor.robustness_signal(node.left, dt, channels, params, n=n),
                           dtype=float)
            vals = np.where(mask, a, -np.inf)
            k = int(np.argmax(vals))
            if not vals[k] <= 0:
                continue
            seen.add(key)
            touch = abs(vals[k]) <= TOUCH
            where = (f"the plan touches its boundary at t = {k * dt:g} s (robustness "
                     f"{vals[k]:.4f})" if touch else
                     f"it comes closest at t = {k * dt:g} s (robustness {vals[k]:.4f})")
            out.append(Diagnostic(
                "STLW02", f"in `{name}`, this implication holds only vacuously: its "
                f"antecedent never holds where it is evaluated; {where}", node.span,
                "an implication is true wherever its antecedent is false; to make the plan "
                "enter the antecedent, require it too (e.g. `eventually (...)`)",
                severity="warning"))
    return out


def plan_warnings(problem, sol) -> list[Diagnostic]:
    """STLW02 on a plan: the mission's requirement and named specs on its channels."""
    m = problem.mission
    formulas = {m.name: m.requirement, **m.specs}
    return vacuous(formulas, problem.grid.dt, sol.channels, problem.program.params,
                   len(sol.times))
