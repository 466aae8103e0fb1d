"""The exact STL→MILP encoding of a requirement in negation normal form on the mission grid.

Every (sub-formula, sample) gets a *term*: a constant (±∞ for an empty window, ``true``,
``false``) or an affine function of the columns with an interval [lo, hi] that contains its
value for every trajectory of the vehicles (from the state intervals of
``milp.model.propagate``).  The term of φ at k is a *lower bound* of the robustness
ρ(φ, k) for every feasible assignment, and equal to it for some (Kurtz & Lin 2022,
"Mixed-Integer Programming for Signal Temporal Logic with Fewer Binary Variables",
arXiv 2204.06367), so maximising the term of the requirement at 0 (its epigraph variable)
gives the maximum robustness over all plans:

* a predicate ``e ≥ 0`` with e affine in states and inputs is the affine term e itself
  (no column, no row);
* ``and`` (``always`` over a window): a column r with r ≤ t_i for every operand — no binary;
* ``or`` (``eventually``, ``not in`` a box, ``until``): a column r with
  r ≤ t_i + M_i (1 − λ_i), where λ is a one-hot choice written with ⌈log2 m⌉ binaries
  b_l (the Gray-code SOS1 encoding written as plain rows, HiGHS having no SOS constraints):
  Σ λ_i = 1, Σ_{i : bit l of g(i) = 1} λ_i ≤ b_l and Σ_{i : bit l of g(i) = 0} λ_i ≤ 1 − b_l
  with g the reflected Gray code — the bits leave one λ_i non-zero.  Its big-M is derived
  per operand and sample, M_i = hi(r) − lo(t_i), never a global constant;
* ``until``/``release``: ``or``/``and`` over k' of the operand at k' and the running
  ``and``/``or`` of the left operand over k … k' (shared prefixes);
* ``next`` shifts by one sample; windows are clipped to the grid (empty: +∞ for
  ``always``/``release``, −∞ for ``eventually``/``until``, as the exact monitor does).

Terms are memoised by (node, sample), structurally: a sub-formula shared by named specs (or
repeated) is encoded once.  A predicate that reads a signed
distance (``dist``, a round region) is encoded as its polyhedral bound, whose robustness is
≤ the exact one (``stlc.semantics.polyhedral``: the MILP's ρ̂ is then a lower bound, and
an infeasible model proves nothing).  Any other predicate that is not affine in the
planned channels raises ``NotLinear`` (the backend refuses it with STL401 at its span,
before any work).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from stlc.backends.milp.model import INF, Milp
from stlc.semantics import ir
from stlc.semantics.polyhedral import polyhedral
from stlc.semantics.shapes import SD_NUMPY
from stlc.semantics.timegrid import TimeGrid


ONE_HOT_MAX = 1 << 30  #: measured: HiGHS solves these faster one-hot (README)


class NotLinear(ValueError):
    def __init__(self, pred: ir.Pred, why: str):
        super().__init__(why)
        self.pred = pred


@dataclass(frozen=True, slots=True)
class Term:
    coefs: tuple[tuple[int, float], ...]  # empty: a constant
    const: float
    lo: float
    hi: float

    @property
    def is_const(self) -> bool:
        return not self.coefs


def const(c: float) -> Term:
    return Term((), c, c, c)


def var_term(j: int, lo: float, hi: float) -> Term:
    return Term(((j, 1.0),), 0.0, lo, hi)


# --------------------------------------------------------------------------- predicates

Affine = tuple[dict[str, float], float]  # signal coefficients, constant


def affine(e: ir.Expr, params: dict[str, float], pred: ir.Pred) -> Affine:
    """``e`` as Σ c_s·s + c over signals, or ``NotLinear``."""
    match e:
        case ir.Const(v):
            return {}, float(v)
        case ir.Param(name):
            if name not in params:
                raise NotLinear(pred, f"parameter `{name}` has no value")
            return {}, float(params[name])
        case ir.Sig(name):
            return {name: 1.0}, 0.0
        case ir.Neg(a):
            ca_, c = affine(a, params, pred)
            return {k: -v for k, v in ca_.items()}, -c
        case ir.Bin(op, a, b):
            la, lb = affine(a, params, pred), affine(b, params, pred)
            if op in "+-":
                s = 1.0 if op == "+" else -1.0
                out = dict(la[0])
                for k, v in lb[0].items():
                    out[k] = out.get(k, 0.0) + s * v
                return out, la[1] + s * lb[1]
            if op == "*" and (not la[0] or not lb[0]):
                (cs, c), f = (lb, la[1]) if not la[0] else (la, lb[1])
                return {k: v * f for k, v in cs.items()}, c * f
            if op == "/" and not lb[0] and lb[1] != 0:
                return {k: v / lb[1] for k, v in la[0].items()}, la[1] / lb[1]
            if op == "^" and not la[0] and not lb[0]:
                return {}, la[1] ** lb[1]
            raise NotLinear(pred, f"`{op}` of two signals is not linear")
        case ir.Call(fn, args):
            vals = [affine(a, params, pred) for a in args]
            if any(v[0] for v in vals):
                raise NotLinear(pred, "a distance to a region (`dist`, a round region) is not "
                                "linear in the state" if fn.startswith("sd_") else
                                f"`{fn}` is not linear in the state")
            return {}, _fold(fn, [v[1] for v in vals])  # of constants: a constant
    raise NotLinear(pred, f"unsupported expression {e!r}")


def _fold(fn: str, xs: list[float]) -> float:
    """A function of constants (e.g. ``cos`` of a human's nominal heading)."""
    one = {"abs": abs, "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "exp": math.exp,
           "log": math.log}
    if fn in one and len(xs) == 1:
        return float(one[fn](xs[0]))
    if fn == "min":
        return min(xs)
    if fn == "max":
        return max(xs)
    if fn == "atan2" and len(xs) == 2:
        return math.atan2(xs[0], xs[1])
    if fn in SD_NUMPY:  # a signed distance of constants
        return float(SD_NUMPY[fn](*xs))
    if fn == "angdiff" and len(xs) == 2:
        d = xs[0] - xs[1]
        return math.atan2(math.sin(d), math.cos(d))  # as the exact monitor
    raise ValueError(f"cannot evaluate `{fn}`")


# --------------------------------------------------------------------------- the encoder


def _opposite(terms: list[Term], pick) -> float:
    """For two terms a·x + c1 and −a·x + c2 (opposite faces of a box or range), min of the
    two is at most and max at least (c1 + c2)/2: the tightest such value (``pick`` is min
    for a conjunction's upper bound, max for a disjunction's lower bound), else ∓∞."""
    best = INF if pick is min else -INF
    if len(terms) > 24:
        return best
    neg = {tuple((j, -v) for j, v in t.coefs): t for t in terms}
    for t in terms:
        u = neg.get(t.coefs)
        if u is not None and u is not t:
            best = pick(best, (t.const + u.const) / 2)
    return best


def gray(i: int) -> int:
    return i ^ (i >> 1)


class Encoder:
    """Encodes formulas into ``milp``; ``channel(name, k)`` gives (column, lo, hi) of a
    planned channel or None, ``fixed(name)`` the samples of a fixed channel or None."""

    def __init__(self, milp: Milp, grid: TimeGrid, params: dict[str, float], channel, fixed,
                 one_hot: int = ONE_HOT_MAX):
        self.m, self.grid, self.params = milp, grid, params
        self.channel, self.fixed = channel, fixed
        self.memo: dict = {}
        self.affine_memo: dict = {}
        #: every term column in creation order (children first), for ``complete``:
        #: ("min", r, lo, hi, terms) or ("max", r, lo, hi, terms, λ columns, bit columns)
        self.nodes: list[tuple] = []
        self.binaries = 0
        #: disjunctions of at most this many operands get one binary per operand, wider
        #: ones the logarithmic encoding (``ExactMilp(one_hot=...)``)
        self.one_hot = one_hot

    # ----------------------------------------------------------------- combinators

    def _new(self, lo: float, hi: float) -> int:
        return self.m.var(lo if math.isfinite(lo) else -INF, hi if math.isfinite(hi) else INF)

    @staticmethod
    def value(t: Term, x) -> float:
        return t.const + sum(c * x[j] for j, c in t.coefs)

    def complete(self, x) -> None:
        """Fill every term, choice and bit column of ``x`` (whose state and input columns
        are set) with its value on that trajectory: each term the exact robustness of its
        sub-formula (clipped to the term's interval), each choice the best branch, with no
        search.  When the trajectory lies within the columns' intervals the point meets
        every row of the encoding (``tests/test_milp_start.py``, Hypothesis)."""
        for node in self.nodes:
            kind, r, lo, hi, terms = node[:5]
            vals = [self.value(t, x) for t in terms]
            if kind == "min":
                x[r] = min(max(min(vals), lo), hi)
                continue
            lam, bits = node[5], node[6]
            best = max(range(len(vals)), key=vals.__getitem__)
            x[r] = min(max(vals[best], lo), hi)
            for i, j in enumerate(lam):
                x[j] = 1.0 if i == best else 0.0
            for bit, b in enumerate(bits):
                x[b] = float(gray(best) >> bit & 1)

    def _le(self, r: int, t: Term, slack_col: int | None = None, big_m: float = 0.0) -> None:
        """r ≤ t  (+ M (1 − λ) when a choice column λ is given)."""
        coefs = {r: 1.0}
        for j, v in t.coefs:
            coefs[j] = coefs.get(j, 0.0) - v
        hi = t.const
        if slack_col is not None:
            coefs[slack_col] = coefs.get(slack_col, 0.0) + big_m
            hi += big_m
        self.m.row(coefs, -INF, hi)

    def conj(self, terms: list[Term]) -> Term:
        """min of the terms: r ≤ t_i, no binary."""
        cmin = min((t.const for t in terms if t.is_const), default=INF)
        lin = list(dict.fromkeys(t for t in terms if not t.is_const))
        if cmin == -INF or not lin:
            return const(cmin)
        if len(lin) == 1 and cmin >= lin[0].hi:
            return lin[0]
        lo = min(min(t.lo for t in lin), cmin)
        hi = min(min(t.hi for t in lin), cmin, _opposite(lin, min))
        if hi < lo:
            lo = hi
        r = self._new(lo, hi)
        for t in lin:
            self._le(r, t)
        self.nodes.append(("min", r, lo, hi, lin))
        return var_term(r, lo, hi)

    def disj(self, terms: list[Term]) -> Term:
        """max of the terms with a one-hot choice on ⌈log2 m⌉ binaries (Gray code)."""
        cmax = max((t.const for t in terms if t.is_const), default=-INF)
        lin = list(dict.fromkeys(t for t in terms if not t.is_const))
        if cmax == INF or not lin:
            return const(cmax)
        lin = [t for t in lin if t.hi > cmax]  # never the max: drop
        if not lin:
            return const(cmax)
        if len(lin) == 1 and cmax == -INF:
            return lin[0]
        if math.isfinite(cmax):
            lin.append(const(cmax))
        lo = max(max(t.lo for t in lin), _opposite(lin, max))
        hi = max(t.hi for t in lin)
        if not (math.isfinite(hi) and all(math.isfinite(t.lo) for t in lin)):
            raise ValueError("a disjunction of unbounded terms has no finite big-M (give "
                             "the vehicle finite velocity and input bounds)")
        r = self._new(lo, hi)
        mcount = len(lin)
        direct = mcount <= self.one_hot
        lam = [self.m.var(0.0, 1.0, integer=direct) for _ in range(mcount)]
        self.m.row({j: 1.0 for j in lam}, 1.0, 1.0)
        nbits = 0 if direct else max(1, (mcount - 1).bit_length())
        self.binaries += mcount if direct else 0
        codes = [gray(i) for i in range(mcount)]
        bits = []
        for bit in range(nbits):
            b = self.m.var(0.0, 1.0, integer=True)
            bits.append(b)
            self.binaries += 1
            ones = [lam[i] for i in range(mcount) if codes[i] >> bit & 1]
            zeros = [lam[i] for i in range(mcount) if not codes[i] >> bit & 1]
            if ones:
                self.m.row({**{j: 1.0 for j in ones}, b: -1.0}, -INF, 0.0)
            if zeros:
                self.m.row({**{j: 1.0 for j in zeros}, b: 1.0}, -INF, 1.0)
        for t, li in zip(lin, lam):
            big_m = max(hi - t.lo, 0.0)
            self._le(r, t, li, big_m)
        self.nodes.append(("max", r, lo, hi, lin, lam, bits))
        return var_term(r, lo, hi)

    # ----------------------------------------------------------------- formulas

    def pred(self, p: ir.Pred, k: int) -> Term:
        key = id(p.expr)
        aff = self.affine_memo.get(key)
        if aff is None:
            aff = self.affine_memo[key] = (p.expr, affine(p.expr, self.params, p))
        coefs_s, c = aff[1]
        coefs: dict[int, float] = {}
        lo = hi = c
        for s, a in coefs_s.items():
            if a == 0.0:
                continue
            ch = self.channel(s, k)
            if ch is None:
                f = self.fixed(s)
                if f is None:
                    raise NotLinear(p, f"no planned channel for signal `{s}`")
                c += a * float(f[k])
                lo += a * float(f[k])
                hi += a * float(f[k])
                continue
            j, slo, shi = ch
            coefs[j] = coefs.get(j, 0.0) + a
            lo += a * (slo if a > 0 else shi)
            hi += a * (shi if a > 0 else slo)
        if not coefs:
            return const(c)
        return Term(tuple(sorted(coefs.items())), c, lo, hi)

    def at(self, f: ir.Formula, k: int) -> Term:
        key = (f, k)
        t = self.memo.get(key)
        if t is None:
            t = self.memo[key] = self._at(f, k)
        return t

    def _window(self, lo: float, hi: float, k: int) -> range:
        a, b = self.grid.window(lo, hi)
        return range(max(k + a, 0), min(k + b, self.grid.n - 1) + 1)

    def _at(self, f: ir.Formula, k: int) -> Term:
        match f:
            case ir.Pred():
                poly = polyhedral(f)  # a signed distance: affine bounds below it
                return self.pred(f, k) if poly is None else self.at(poly, k)
            case ir.TrueF():
                return const(INF)
            case ir.FalseF():
                return const(-INF)
            case ir.And(args):
                return self.conj([self.at(a, k) for a in args])
            case ir.Or(args):
                return self.disj([self.at(a, k) for a in args])
            case ir.Always(lo, hi, a):
                return self.conj([self.at(a, j) for j in self._window(lo, hi, k)])
            case ir.Eventually(lo, hi, a):
                return self.disj([self.at(a, j) for j in self._window(lo, hi, k)])
            case ir.Until(lo, hi, a, b):
                return self.disj([self.conj([self.at(b, j), self._run(f, a, k, j, True)])
                                  for j in self._window(lo, hi, k)])
            case ir.Release(lo, hi, a, b):
                return self.conj([self.disj([self.at(b, j), self._run(f, a, k, j, False)])
                                  for j in self._window(lo, hi, k)])
            case ir.Next(a):
                return self.at(a, k + 1) if k + 1 < self.grid.n else const(-INF)
        raise TypeError(f"the MILP encoding has no rule for {type(f).__name__}")

    def _run(self, node, a: ir.Formula, k: int, j: int, is_min: bool) -> Term:
        """min (until) or max (release) of ``a`` over samples k … j, each prefix built once
        on the one before it."""
        key = ("run", node, k, j)
        t = self.memo.get(key)
        if t is not None:
            return t
        start = j
        while start > k and ("run", node, k, start - 1) not in self.memo:
            start -= 1
        t = self.memo.get(("run", node, k, start - 1)) if start > k else None
        for i in range(start, j + 1):
            here = self.at(a, i)
            if t is None:
                t = here
            else:
                t = self.conj([t, here]) if is_min else self.disj([t, here])
            self.memo[("run", node, k, i)] = t
        return t
