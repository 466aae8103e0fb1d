"""Lower a normalised STL formula to smooth robustness in CasADi SX, ready for an NLP.

``lower_robustness`` turns an NNF formula (``nnf.normalize``) on a ``TimeGrid`` into

* ``root`` — the smooth robustness at sample 0 (to be maximised),
* ``aux``  — auxiliary decision variables introduced by *lifting*,
* ``g``    — inequality constraints ``g >= 0``, and ``h`` — equality constraints ``h == 0``
  (``constraints()`` stacks both with their bounds),
* ``init`` — a ``casadi.Function`` from numeric channel/parameter/λ values to the aux values
  that make every constraint hold (the un-lifted smooth values) and the un-lifted root.

One pass lowers the formula over placeholder channels: the NLP's rows are its rows with the
actual channels substituted, and ``init`` its aux definitions resolved into one another
(``casadi.substitute_inplace``: each reads only earlier aux).

Semantics (the numpy reference ``stlc.analysis.smooth`` computes the same numbers): predicates are
their expression (``nlp.expr``); ``and``/``always``/the inner min of ``until`` use the
smooth min, ``or``/``eventually``/the outer max of ``until`` the smooth max of ``method``
(``"gkl"`` or ``"lse"``), each as *one flat* smooth op over all its operands (the until inner
min is over ``{g(k')} ∪ {f(k..k')}``, the release inner max over ``{b(k')} ∪ {a(k..k')}``).
Windows are ``grid.window(lo, hi)`` clipped to the n samples; an empty window, ``true``,
``false`` and ``next`` past the end are the constants ±``BIG``.

Only needed samples are computed: the root needs sample 0, and each operator maps the
sample set it needs onto its children (``always[0,17]`` at {0} needs its child at 0..170).

**Dyadic windows.**  A window of length L > ``lift_span`` is the smooth op of the blocks of
the binary expansion of L (≤ log2 L + 1 blocks); a block of size 2^j at start p combines the
two blocks of size 2^(j-1) at p and p + 2^(j-1).  Blocks are built level by level, vectorised
over every start any window needs, so n windows of length W cost O(n log W) operands
instead of O(n W).  The smooth ops are associative in the block form (see ``nlp.expr``),
so the value equals the flat one up to rounding.

**Lifting.**  Every value carries a *span*, the number of base operands (predicates or aux
variables) it depends on through smooth ops.  When a smooth op's span exceeds
``lift_span`` its result is replaced by a fresh variable r constrained by
``op(children) - r == 0`` (default) or, with ``hypograph=True``, ``op(children) - r >= 0``.
Every constraint then couples ≤ 2·``lift_span`` variables and the Hessian stays sparse.  The
root itself is never lifted (a linear objective ``-r`` made IPOPT wander far into
infeasibility).

*Equality* lifting is a change of variables: any feasible point has exactly the un-lifted
smooth robustness, which is sound (smin ≤ min, GKL mean ≤ max; ``lse`` over-approximates).

*Hypograph* lifting is a relaxation that stays sound: by induction every feasible r is ≤
the exact robustness of its sub-formula — ``r ≤ smin(x) ≤ min(x) ≤ min(exact)`` and
``r ≤ gkl(x) ≤ max(x) ≤ max(exact)``, the GKL mean being a convex combination of its
operands whatever the weights.  It is exact at the optimum only where the path to the root
is nondecreasing: the GKL mean is *not* monotone (raising a low operand raises its weight),
so below a GKL max the optimiser would push r → -∞ to drop operands, and the relaxed
problem's supremum is the non-smooth exact max, never attained.  Hence components on a
non-monotone path (below a GKL ``or``/``eventually``/``until``/``release``), and the
normaliser ``s`` of a GKL block, always get equalities.  Measured on a 3-D reach-and-stay
problem (N = 170), hypograph lifting still failed at λ = 50 and 100 where equality lifting
converged in 83–95 iterations: with a barrier method, a hypograph slack whose multiplier is
~0 (a non-binding operand of a smooth min) is pushed to infinity by the barrier itself.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import casadi as ca
import numpy as np

from stlc.backends.nlp.expr import (
    BIG,
    Alg,
    ExprEnv,
    LoweringError,
    MinAlg,
    Num,
    lower_expr,
    max_alg,
)
from stlc.backends.nlp.windows import (
    LAM,
    PARAM,
    LoweredRobustness,
    assemble,
    bits_desc,
    check_window,
    child_needs,
    const_value,
    fan_in,
    Row,
    Val,
    sample_windows,
)
from stlc.semantics import ir
from stlc.semantics.timegrid import TimeGrid

__all__ = ["LoweringError", "lower_robustness", "LOWER", "BIG"]

# --------------------------------------------------------------------------- the lowerer


class _Lowerer:
    """One pass over the formula.  ``mode``: ``"none"`` (no lifting) or ``"aux"`` (introduce
    aux variables and constraints, and record each one's defining value in ``defs``)."""

    def __init__(self, grid: TimeGrid, env: ExprEnv, mode: str, dyadic: bool, lift_span: int,
                 hypograph: bool = False, lam_scaling: bool = False):
        self.grid, self.n, self.env, self.lam = grid, grid.n, env, env.lam
        self.base_lam, self.lam_scaling = env.lam, lam_scaling
        self.mode, self.dyadic, self.lift_span = mode, dyadic, lift_span
        self.hypograph = hypograph
        self.min_alg, self.max_alg = MinAlg(), max_alg(env.method)
        self.rows: dict[ir.Formula, Row] = {}
        self.aux: list[ca.SX] = []
        self.defs: list[ca.SX] = []  # each aux variable's defining value
        self.g: list[ca.SX] = []
        self.h: list[ca.SX] = []
        self.operands = 0
        self._last_lift: tuple | None = None
        self.mono = True  # is the path from the node being lowered to the root monotone?

    # ---- smooth ops and lifting

    def combine(self, alg: Alg, vals: list[Val]) -> Val:
        if len(vals) == 1:
            return vals[0]
        self.operands += len(vals) * vals[0].size
        return Val(alg.combine([v.comps for v in vals], self.lam), sum(v.span for v in vals))

    def lift(self, v: Val, kinds: tuple[str, ...], mono: bool | None = None) -> Val:
        """Replace a wide value by aux variables.  ``"ineq"`` components get the hypograph
        constraint only if the path to the root is monotone (``mono``, default: that of the
        node being lowered); otherwise, and for ``"eq"`` components, an equality."""
        if self.mode == "none" or v.span <= self.lift_span:
            return v
        syms, lists = [], []
        for c, kind in zip(v.comps, kinds):
            r = ca.SX.sym(f"r{len(self.aux)}", 1, c.numel())
            self.aux.append(r.T)
            self.defs.append(c.T)
            hypo = kind == "ineq" and self.hypograph and (self.mono if mono is None else mono)
            lists.append(self.g if hypo else self.h)
            lists[-1].append((c - r).T)
            syms.append(r)
        self._last_lift = (tuple(syms), v.comps, [self.aux, self.defs] + lists)
        return Val(tuple(syms), 1)

    def finish(self, alg: Alg, v: Val, mono: bool | None = None) -> Val:
        """The plain value of a block, lifted if it is wide."""
        return self.lift(Val((alg.value(v.comps),), v.span), ("ineq",), mono)

    def reduce(self, alg: Alg, vals: list[Val]) -> Val:
        """Plain smooth op of plain rows."""
        return self.finish(alg, self.combine(alg, [self.leaf(alg, v) for v in vals]))

    @staticmethod
    def leaf(alg: Alg, v: Val) -> Val:
        return Val(alg.leaf(v.comps[0]), v.span)

    # ---- driver

    def run(self, f: ir.Formula) -> ca.SX:
        order: list[ir.Formula] = []
        seen: set[ir.Formula] = set()

        def visit(node: ir.Formula) -> None:
            if node in seen:
                return
            seen.add(node)
            for c in ir.children(node):
                visit(c)
            order.append(node)

        visit(f)
        needs: dict[ir.Formula, list[np.ndarray]] = {f: [np.zeros(1, dtype=np.int64)]}
        need: dict[ir.Formula, np.ndarray] = {}
        mono: dict[ir.Formula, bool] = {f: True}
        for node in reversed(order):  # parents before children
            k = np.unique(np.concatenate(needs.get(node, [np.zeros(0, dtype=np.int64)])))
            need[node] = k
            if len(k):
                edge = mono[node] and self.edge_monotone(node)
                for child, ks in child_needs(node, k, self.grid):
                    needs.setdefault(child, []).append(ks)
                    mono[child] = mono.get(child, True) and edge
        for node in order:  # children before parents
            k = need[node]
            if len(k):
                self.mono = mono[node]
                if self.lam_scaling:
                    self.lam = self.base_lam * (1.0 + np.log(fan_in(node, self.grid)))
                fn = LOWER.get(type(node))
                if fn is None:
                    raise LoweringError(f"{type(node).__name__} is not an NNF node; "
                                        "run nnf.normalize first")
                self.rows[node] = Row(k, fn(self, node, k))
        root = self.rows[f].val.comps[0]
        last = self._last_lift
        if last is not None and len(last[0]) == 1 and last[0][0] is root:
            # never lift the root: a linear objective -r over a hypograph makes IPOPT take
            # long infeasible steps; keep the root as the smooth op of its children
            _, expr, lists = last
            for lst in lists:
                lst.pop()
            root = expr[0]
        return root[0, 0]

    def edge_monotone(self, f: ir.Formula) -> bool:
        """Is ``f`` nondecreasing in its children's values?  Not if a GKL max consumes them."""
        if isinstance(f, ir.Or | ir.Eventually | ir.Until | ir.Release):
            return self.max_alg.monotone
        return True

    # ---- windows

    def window(self, alg: Alg, child: ir.Formula, k: np.ndarray, a: int, b: int) -> Val:
        first, last = sample_windows(k, a, b, self.n)
        length = last - first + 1
        empty = np.flatnonzero(length <= 0)
        pieces = [(empty, const_value(alg.empty, len(empty)))]
        if len(empty) == len(k):
            return pieces[0][1]
        row = self.rows[child]
        groups = {int(m): np.flatnonzero(length == m) for m in np.unique(length[length > 0])}
        wide = {m: first[p] for m, p in groups.items() if self.dyadic and m > self.lift_span}
        levels = self.levels(alg, row, wide) if wide else {}
        for m, pos in groups.items():
            starts = first[pos]
            if m in wide:
                parts, off = [], 0
                for j in bits_desc(m):
                    st, blk = levels[j]
                    parts.append(blk.take(np.searchsorted(st, starts + off)))
                    off += 1 << j
            else:
                parts = [self.leaf(alg, row.at(starts + j)) for j in range(m)]
            pieces.append((pos, self.finish(alg, self.combine(alg, parts))))
        return assemble(pieces)

    def levels(self, alg: Alg, row: Row, wide: dict[int, np.ndarray]
               ) -> dict[int, tuple[np.ndarray, Val]]:
        """Dyadic blocks (starts, block row) per level j, for every start a window needs."""
        want: dict[int, list[np.ndarray]] = {}
        for m, starts in wide.items():
            off = 0
            for j in bits_desc(m):
                want.setdefault(j, []).append(starts + off)
                off += 1 << j
        top = max(want)
        starts_at: dict[int, np.ndarray] = {}
        for j in range(top, -1, -1):
            st = np.unique(np.concatenate(want.get(j, [np.zeros(0, dtype=np.int64)])))
            starts_at[j] = st
            if j:
                want.setdefault(j - 1, []).extend([st, st + (1 << (j - 1))])
        out = {0: (starts_at[0], self.leaf(alg, row.at(starts_at[0])))}
        for j in range(1, top + 1):
            st = starts_at[j]
            prev_st, prev = out[j - 1]
            left = prev.take(np.searchsorted(prev_st, st))
            right = prev.take(np.searchsorted(prev_st, st + (1 << (j - 1))))
            out[j] = (st, self.lift(self.combine(alg, [left, right]), alg.kinds))
        return out

    def until_like(self, f: ir.Until | ir.Release, k: np.ndarray,
                   inner: Alg, outer: Alg) -> Val:
        """``max_{k'} min(g(k'), f(k..k'))`` (until) or its dual (release) as two chains
        over the offset d = k' - k, vectorised over k.  The last offset of sample k,
        min(b, n-1-k), is nonincreasing in k, so the samples still active at offset d are a
        prefix of k; the others are finished and set aside."""
        a, b = self.grid.window(f.lo, f.hi)
        left, right = self.rows.get(f.left), self.rows.get(f.right)
        reach = np.minimum(b, self.n - 1 - k)  # last offset per sample, nonincreasing
        pieces: list[tuple[np.ndarray, Val]] = []
        no_window = np.flatnonzero(reach < a)
        pieces.append((no_window, const_value(outer.empty, len(no_window))))
        prefix = acc = None
        active = len(k)
        mono = self.mono and outer.monotone  # prefix and inner values are outer operands
        last_d = int(reach.max()) if len(k) and reach.max() >= a else -1
        for d in range(last_d + 1):
            m = int(np.count_nonzero(reach >= d))
            if m < active and acc is not None:  # samples whose window ended at d - 1
                pieces.append((np.arange(m, active), self.finish(outer, acc.take(
                    np.arange(m, active)))))
            active = m
            ks = k[:m] + d
            term = self.leaf(inner, left.at(ks))
            prefix = term if prefix is None else self.lift(
                self.combine(inner, [prefix.take(np.arange(m)), term]), inner.kinds, mono)
            if d < a:
                continue
            cur = self.leaf(inner, right.at(ks))
            op = self.leaf(outer, self.finish(inner, self.combine(inner, [cur, prefix]), mono))
            acc = op if acc is None else self.lift(
                self.combine(outer, [acc.take(np.arange(m)), op]), outer.kinds)
        if acc is not None:
            pieces.append((np.arange(active), self.finish(outer, acc)))
        return assemble(pieces)


# --------------------------------------------------------------------------- dispatch


def _pred(lw: _Lowerer, f: ir.Pred, k: np.ndarray) -> Val:
    v = lower_expr(f.expr, lw.env)
    if not isinstance(v, ca.SX) or v.numel() == 1:
        return Val((ca.repmat(ca.SX(v), 1, len(k)),), 1)
    return Val((v,), 1).take(k)


def _always(lw: _Lowerer, f: ir.Always, k: np.ndarray) -> Val:
    return lw.window(lw.min_alg, f.arg, k, *check_window(f, lw.grid))


def _eventually(lw: _Lowerer, f: ir.Eventually, k: np.ndarray) -> Val:
    return lw.window(lw.max_alg, f.arg, k, *check_window(f, lw.grid))


def _next(lw: _Lowerer, f: ir.Next, k: np.ndarray) -> Val:
    inside = k + 1 < lw.n
    pos_in, pos_out = np.flatnonzero(inside), np.flatnonzero(~inside)
    pieces = [(pos_out, const_value(-BIG, len(pos_out)))]
    if len(pos_in):
        pieces.append((pos_in, lw.rows[f.arg].at(k[inside] + 1)))
    return assemble(pieces)


def _until(lw: _Lowerer, f: ir.Until, k: np.ndarray) -> Val:
    check_window(f, lw.grid)
    return lw.until_like(f, k, lw.min_alg, lw.max_alg)


def _release(lw: _Lowerer, f: ir.Release, k: np.ndarray) -> Val:
    check_window(f, lw.grid)
    return lw.until_like(f, k, lw.max_alg, lw.min_alg)


LOWER: dict[type, Callable[[_Lowerer, ir.Formula, np.ndarray], Val]] = {
    ir.Pred: _pred,
    ir.TrueF: lambda lw, f, k: const_value(BIG, len(k)),
    ir.FalseF: lambda lw, f, k: const_value(-BIG, len(k)),
    ir.And: lambda lw, f, k: lw.reduce(lw.min_alg, [lw.rows[c].at(k) for c in f.args]),
    ir.Or: lambda lw, f, k: lw.reduce(lw.max_alg, [lw.rows[c].at(k) for c in f.args]),
    ir.Always: _always,
    ir.Eventually: _eventually,
    ir.Until: _until,
    ir.Release: _release,
    ir.Next: _next,
}


# --------------------------------------------------------------------------- entry point


def _is_symbolic(x: object) -> bool:
    return isinstance(x, ca.SX) and not x.is_constant()


def lower_robustness(f: ir.Formula, grid: TimeGrid, channels: Mapping[str, ca.SX],
                     params: Mapping[str, Num], lam: Num, method: str = "gkl",
                     lift: bool = True, dyadic: bool = True, lift_span: int = 4,
                     hypograph: bool = False, lam_scaling: bool = False) -> LoweredRobustness:
    """Smooth robustness of the NNF formula ``f`` at sample 0 as CasADi SX.

    ``channels`` maps each signal to a 1×n SX row (n = ``grid.n``; entries may be decision
    variables or expressions of them); ``params`` and ``lam`` may be SX symbols or floats.
    ``lift`` introduces aux variables (see module docstring) for smooth ops wider than
    ``lift_span`` operands, constrained by equalities or (``hypograph``, where sound and
    exact) by ``g >= 0``; ``dyadic`` evaluates sliding windows from power-of-two blocks.
    With ``lam_scaling`` an operator over n operands smooths with λ·(1 + ln n) instead of λ,
    so that its worst-case under-estimate ln(n)/λ_op stays below 1/λ for any window length.
    """
    n = grid.n
    sigs, pars = sorted(ir.signals(f)), sorted(ir.params(f))
    for s in sigs:
        if s not in channels:
            raise LoweringError(f"no channel for signal {s!r}")
        if channels[s].shape != (1, n):
            raise LoweringError(f"channel {s!r} has shape {channels[s].shape}, want (1, {n})")
    for p in pars:
        if p not in params:
            raise LoweringError(f"no value for parameter {p!r}")

    # placeholders: the init Function takes numeric values of channels, params and λ
    ph_ch = {s: ca.SX.sym(s, 1, n) for s in sigs}
    ph_par = {p: ca.SX.sym(p) if _is_symbolic(params[p]) else params[p] for p in pars}
    ph_lam = ca.SX.sym("lam") if _is_symbolic(lam) else lam
    inputs = [ph_ch[s] for s in sigs] + [ph_par[p] for p in pars if _is_symbolic(params[p])]
    names = sigs + [PARAM + p for p in pars if _is_symbolic(params[p])]
    if _is_symbolic(lam):
        inputs.append(ph_lam)
        names.append(LAM)

    actual = [channels[s] for s in sigs] + [params[p] for p in pars if _is_symbolic(params[p])]
    if _is_symbolic(lam):
        actual.append(lam)
    if lift:
        # one pass over the placeholders: the NLP's rows are its rows with the actual
        # channels substituted, and the initial values its aux definitions resolved into
        # each other (each reads only earlier aux), a function of the inputs alone
        lw = _Lowerer(grid, ExprEnv(ph_ch, ph_par, ph_lam, method), "aux", dyadic, lift_span,
                      hypograph, lam_scaling)
        root0 = lw.run(f)
        aux = ca.vertcat(*lw.aux) if lw.aux else ca.SX(0, 1)
        defs = ca.vertcat(*lw.defs) if lw.defs else ca.SX(0, 1)
        g = ca.vertcat(*lw.g) if lw.g else ca.SX(0, 1)
        h = ca.vertcat(*lw.h) if lw.h else ca.SX(0, 1)
        root = root0
        if inputs:
            root, g, h = ca.substitute([root0, g, h], [ca.vec(x) for x in inputs],
                                       [ca.vec(ca.SX(x)) for x in actual])
        aux0, root_in = defs, root0
        if aux.numel():
            aux0, root_in = ca.substitute_inplace([aux], [defs], [root0], False)
            aux0, root_in = aux0[0], root_in[0]
        init = ca.Function("robustness_init", inputs, [aux0, root_in], names, ["aux", "root"])
    else:
        lw = _Lowerer(grid, ExprEnv(ph_ch, ph_par, ph_lam, method), "none", dyadic,
                      lift_span, lam_scaling=lam_scaling)
        root0 = lw.run(f)
        init = ca.Function("robustness_init", inputs, [ca.SX(0, 1), root0], names,
                           ["aux", "root"])
        root = ca.substitute([root0], [ca.vec(x) for x in inputs],
                             [ca.vec(ca.SX(x)) for x in actual])[0] if inputs else root0
        aux = g = h = ca.SX(0, 1)
    stats = {"operands": lw.operands, "aux": aux.numel(), "g": g.numel(), "h": h.numel(),
             "nodes": len(lw.rows)}
    return LoweredRobustness(root, aux, g, h, init, stats)
