"""Exact robustness monitor: the reference oracle every other semantics is checked against.

Interprets the IR (``stlc.semantics.ir``) over a uniformly sampled trace with the contract semantics
of LANGUAGE.md ("Robustness semantics"), vectorised with numpy:

* expressions are evaluated on whole channels at once; a parameter given as an array of
  shape ``(K,)`` (K realisations, for risk analysis) is reshaped to ``(K, 1)``, so every
  signal then has shape ``(K, n)`` instead of ``(n,)``;
* ``always``/``eventually`` are sliding-window min/max by doubling (windows of 2^j samples,
  a window being two overlapping ones): O(n log w) in ⌈log2 w⌉ vectorised ``np.minimum``
  calls, faster in practice than the O(n) van Herk scans (``ufunc.accumulate`` does not
  vectorise), which ``sliding`` keeps for non-idempotent operators;
* ``until`` is a sliding-window composition of clamp functions (see ``_until``), computed
  by binary lifting in O(n log w) numpy operations;
* ``stlc.analysis.monitor_demand`` evaluates several formulas at their first sample in one go (the
  risk pass's fast path) with these semantics.

Conventions the contract leaves open (docs/language.md repeats them):

* The formula is first put in negation normal form (``nnf.normalize``); its semantics is
  that of the NNF, so ``f`` and ``normalize(f)`` always have the same robustness.
* A window clipped to the trace can be empty (it starts after the last sample, or
  ``[lo, hi]`` contains no sample at all, e.g. ``[0.05, 0.08]`` at dt = 0.1): ``always``
  and ``release`` give +inf, ``eventually`` and ``until`` give -inf (the identities of min
  and max), which is consistent with negation.
* ``next f`` at the last sample is -inf: a requirement on a sample after the end of the
  trace is never satisfied. Being applied to the NNF, this holds under negation too —
  ``not next f`` is also -inf there (``not`` is exactly negation everywhere else).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from stlc.semantics import nnf
from stlc.semantics.ir import (
    Always,
    And,
    Bin,
    Call,
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
    Param,
    Pred,
    Release,
    Sig,
    TrueF,
    Until,
)
from stlc.semantics.shapes import SD_NUMPY
from stlc.semantics.timegrid import steps_ceil, steps_floor

INF = np.inf
Channels = Mapping[str, np.ndarray]
Params = Mapping[str, "float | np.ndarray"]

# --------------------------------------------------------------------------- expressions


def _angdiff(a, b):
    d = np.subtract(a, b)
    return np.arctan2(np.sin(d), np.cos(d))


_UNARY: dict[str, Callable] = {"abs": np.abs, "sqrt": np.sqrt, "sin": np.sin, "cos": np.cos,
                               "exp": np.exp, "log": np.log}
_BINARY: dict[str, Callable] = {"+": np.add, "-": np.subtract, "*": np.multiply,
                                "/": np.divide, "^": np.power, "atan2": np.arctan2,
                                "angdiff": _angdiff}


def _call(e: Call, args: list) -> np.ndarray:
    if e.fn in _UNARY and len(args) == 1:
        return _UNARY[e.fn](args[0])
    if e.fn in ("atan2", "angdiff") and len(args) == 2:
        return _BINARY[e.fn](*args)
    if e.fn == "min" and args:
        return np.minimum.reduce(np.broadcast_arrays(*args)) if len(args) > 1 else args[0]
    if e.fn == "max" and args:
        return np.maximum.reduce(np.broadcast_arrays(*args)) if len(args) > 1 else args[0]
    if e.fn in SD_NUMPY:  # exact signed distances (``stlc.semantics.shapes``)
        return SD_NUMPY[e.fn](*args)
    raise ValueError(f"cannot evaluate {e.fn}() with {len(args)} argument(s)")


def _param(name: str, params: Params):
    try:
        v = np.asarray(params[name], dtype=float)
    except KeyError:
        raise KeyError(f"no value for parameter `{name}`") from None
    if v.ndim > 1:
        raise ValueError(f"parameter `{name}` must be a float or a 1-d array, got {v.shape}")
    return v.reshape(-1, 1) if v.ndim == 1 else float(v)


def _channel(name: str, channels: Channels):
    try:
        return np.asarray(channels[name], dtype=float)
    except KeyError:
        raise KeyError(f"trace has no signal `{name}`") from None


#: one rule per expression node: (node, channels, params, recurse) -> value
_EXPR_RULES: dict[type, Callable] = {
    Const: lambda e, ch, pa, ev: float(e.value),
    Sig: lambda e, ch, pa, ev: _channel(e.name, ch),
    Param: lambda e, ch, pa, ev: _param(e.name, pa),
    Neg: lambda e, ch, pa, ev: np.negative(ev(e.arg)),
    Bin: lambda e, ch, pa, ev: _BINARY[e.op](ev(e.left), ev(e.right)),
    Call: lambda e, ch, pa, ev: _call(e, [ev(a) for a in e.args]),
}


def eval_expr(e: Expr, channels: Channels, params: Params | None = None, *,
              n: int | None = None, memo: dict | None = None) -> np.ndarray:
    """Value of ``e`` at every sample: shape ``(n,)``, or ``(K, n)`` if a parameter is an
    array of K realisations.  ``n`` (the number of samples) defaults to the length of the
    first channel; every signal read must have that length.  ``memo`` (keyed by node) may be
    shared between calls on the same trace."""
    params = {} if params is None else params
    memo = {} if memo is None else memo
    if n is None and channels:
        n = len(next(iter(channels.values())))

    def ev(x: Expr):
        hit = memo.get(x)
        if hit is None:
            hit = memo[x] = _EXPR_RULES[type(x)](x, channels, params, ev)
            if type(x) is Sig and n is not None and hit.shape != (n,):
                raise ValueError(f"signal `{x.name}` has shape {hit.shape}, expected ({n},)")
        return hit

    with np.errstate(all="ignore"):
        v = ev(e)
    if n is None:
        return np.asarray(v, dtype=float)
    return np.broadcast_to(v, np.broadcast_shapes(np.shape(v), (n,)))


# --------------------------------------------------------------------------- windows


def sliding(x: np.ndarray, lo: int, hi: int, op: np.ufunc, ident: float,
            idempotent: bool = True) -> np.ndarray:
    """``op``-reduction of ``x[..., k+lo : k+hi+1]`` (clipped to the trace) for every k.

    ``op`` must be an associative, commutative ufunc with identity ``ident`` (which fills
    empty windows).  For an idempotent ``op`` (min, max) windows of 2^j samples are built by
    doubling and a window of w samples is two overlapping ones: ⌈log2 w⌉ vectorised ``op``
    calls.  Otherwise (e.g. ``logaddexp``) van Herk/Gil-Werman: prefix and suffix scans
    within blocks of the window width, a window being the suffix of one block and the prefix
    of the next (or exactly one block, whose suffix is then used alone).
    """
    n = x.shape[-1]
    lead = x.shape[:-1]
    if lo < 0:
        raise ValueError("negative window offset")
    if lo > n - 1 or hi < lo:
        return np.full(x.shape, ident)
    w, m = min(hi, n - 1) - lo + 1, n - lo
    y = x[..., lo:]
    if w == 1:
        r = y
    elif idempotent:
        cur = np.concatenate([y, np.full(lead + (w - 1,), ident)], axis=-1)
        span = 1
        while 2 * span <= w:
            cur = op(cur[..., :-span], cur[..., span:])
            span *= 2
        r = op(cur[..., :m], cur[..., w - span:w - span + m]) if span < w else cur[..., :m]
    elif w >= m:  # every window reaches the end of the trace: a suffix scan
        r = op.accumulate(y[..., ::-1], axis=-1)[..., ::-1]
    else:
        nb = -(-(m + w - 1) // w)
        size = nb * w
        yp = np.concatenate([y, np.full(lead + (size - m,), ident)], axis=-1)
        blocks = yp.reshape(lead + (nb, w))
        pre = op.accumulate(blocks, axis=-1).reshape(lead + (size,))
        suf = op.accumulate(blocks[..., ::-1], axis=-1)[..., ::-1].reshape(lead + (size,))
        r = op(suf[..., :m], pre[..., w - 1:w - 1 + m])
        r = np.where(np.arange(m) % w == 0, suf[..., :m], r)
    if lo == 0:
        return r
    return np.concatenate([r, np.full(lead + (lo,), ident)], axis=-1)


def shift(x: np.ndarray, s: int, fill: float) -> np.ndarray:
    """``x[..., k + s]``, or ``fill`` past the end of the trace."""
    n = x.shape[-1]
    if s == 0:
        return x
    if s >= n:
        return np.full(x.shape, fill)
    return np.concatenate([x[..., s:], np.full(x.shape[:-1] + (s,), fill)], axis=-1)


def _compose(outer: tuple, inner: tuple) -> tuple:
    """Clamps ``c(x) = min(hi, max(lo, x))`` are closed under composition."""
    lo1, hi1 = outer
    return (np.minimum(hi1, np.maximum(lo1, inner[0])),
            np.minimum(hi1, np.maximum(lo1, inner[1])))


def _until(f: np.ndarray, g: np.ndarray, a: int, b: int) -> np.ndarray:
    """``max_{k' in [k+a, k+b]} min(g(k'), min f[k..k'])``, clipped; -inf if empty.

    With ``V(k) = max over k' >= k`` the recursion is ``V(k) = C_k(V(k+1))`` for the clamp
    ``C_k(x) = min(f_k, max(g_k, x))`` = clamp to ``[min(f_k, g_k), f_k]``.  A window of w
    samples starting at m is ``C_m ∘ … ∘ C_{m+w-1}`` applied to -inf, i.e. the lower bound
    of that composition; compositions of 2^j clamps are built by doubling.
    """
    f, g = np.broadcast_arrays(f, g)
    n = f.shape[-1]
    if a > n - 1 or b < a:
        return np.full(f.shape, -INF)
    w = min(b, n - 1) - a + 1
    with np.errstate(invalid="ignore"):
        level = (np.minimum(f, g), f)  # compositions of 2^j clamps starting at each sample
        acc = (np.full(f.shape, -INF), np.full(f.shape, INF))  # identity clamp
        off, j = 0, 0
        while (1 << j) <= w:
            if w & (1 << j):
                acc = _compose(acc, tuple(shift(c, off, e) for c, e in zip(level, (-INF, INF))))
                off += 1 << j
            if (2 << j) <= w:
                h = 1 << j
                level = _compose(level, tuple(shift(c, h, e) for c, e in zip(level, (-INF, INF))))
            j += 1
        win = shift(acc[0], a, -INF)
        if a == 0:
            return win
        return np.minimum(sliding(f, 0, a - 1, np.minimum, INF), win)


# --------------------------------------------------------------------------- formulas


class Evaluator:
    """Robustness signals of the subformulas of one formula on one trace, memoised by node
    (``sig``), so shared subformulas are computed once; ``stlc.analysis.smooth`` subclasses it."""

    def __init__(self, dt: float, channels: Channels, params: Params | None, n: int | None):
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        if n is None:
            if not channels:
                raise ValueError("no channels: pass the number of samples n")
            n = len(next(iter(channels.values())))
        if n < 1:
            raise ValueError("the trace has no samples")
        self.dt, self.n = dt, n
        self.channels, self.params = channels, {} if params is None else params
        self.memo: dict = {}
        self.expr_memo: dict = {}

    def window(self, lo: float, hi: float) -> tuple[int, int]:
        if lo < 0 or hi < 0:
            raise ValueError(f"negative time bound in [{lo}, {hi}]")
        return steps_ceil(lo, self.dt), steps_floor(hi, self.dt)

    def sig(self, f: Formula) -> np.ndarray:
        hit = self.memo.get(f)
        if hit is None:
            hit = self.memo[f] = _RULES[type(f)](self, f)
        return hit

    def pred(self, f: Pred) -> np.ndarray:
        return eval_expr(f.expr, self.channels, self.params, n=self.n, memo=self.expr_memo)

    def const(self, value: float) -> np.ndarray:
        return np.full(self.n, value)

    def until(self, f: Until | Release) -> np.ndarray:
        a, b = self.window(f.lo, f.hi)
        left, right = self.sig(f.left), self.sig(f.right)
        if isinstance(f, Until):
            return _until(left, right, a, b)
        return -_until(-left, -right, a, b)


_RULES: dict[type, Callable[[Evaluator, Formula], np.ndarray]] = {
    Pred: Evaluator.pred,
    TrueF: lambda m, f: m.const(INF),
    FalseF: lambda m, f: m.const(-INF),
    Not: lambda m, f: m.sig(nnf.normalize(f)),
    Implies: lambda m, f: m.sig(nnf.normalize(f)),
    And: lambda m, f: np.minimum.reduce(np.broadcast_arrays(*map(m.sig, f.args))),
    Or: lambda m, f: np.maximum.reduce(np.broadcast_arrays(*map(m.sig, f.args))),
    Always: lambda m, f: sliding(m.sig(f.arg), *m.window(f.lo, f.hi), np.minimum, INF),
    Eventually: lambda m, f: sliding(m.sig(f.arg), *m.window(f.lo, f.hi), np.maximum, -INF),
    Until: Evaluator.until,
    Release: Evaluator.until,
    Next: lambda m, f: shift(m.sig(f.arg), 1, -INF),
}


def robustness_signal(f: Formula, dt: float, channels: Channels, params: Params | None = None,
                      *, n: int | None = None) -> np.ndarray:
    """Robustness of ``f`` at every sample: shape ``(n,)`` or ``(K, n)``.

    ``n`` defaults to the length of the first channel; pass it when ``channels`` mixes
    lengths (e.g. inputs with one sample fewer than states) or is empty.
    """
    return Evaluator(dt, channels, params, n).sig(nnf.normalize(f))


def robustness(f: Formula, dt: float, channels: Channels, params: Params | None = None,
               *, n: int | None = None) -> float | np.ndarray:
    """Robustness of ``f`` at the first sample: a float, or shape ``(K,)``."""
    r = robustness_signal(f, dt, channels, params, n=n)[..., 0]
    return float(r) if r.ndim == 0 else r


# --------------------------------------------------------------------------- binding


def binding(f: Formula, dt: float, channels: Channels, params: Params | None = None,
            *, n: int | None = None) -> tuple[float, int, Pred | None]:
    """``(robustness at t=0, sample index, predicate)`` whose value *is* the robustness.

    The argmin/argmax is traced down the NNF tree (first index on ties), so the predicate
    comes from ``normalize(f)`` (a negated predicate is labelled ``not (...)``).  The
    predicate is ``None`` when the value comes from ``true``/``false``, an empty window or
    ``next`` past the end.  Parameters must be scalars.
    """
    m = Evaluator(dt, channels, params, n)
    nf = nnf.normalize(f)
    r = m.sig(nf)
    if r.ndim != 1:
        raise ValueError("binding needs scalar parameters")
    k, pred = _bind(m, nf, 0)
    return float(r[0]), k, pred


def _bind(m: Evaluator, f: Formula, k: int) -> tuple[int, Pred | None]:
    n = m.n
    match f:
        case Pred():
            return k, f
        case And(args) | Or(args):
            vals = [m.sig(c)[k] for c in args]
            i = int(np.argmin(vals) if isinstance(f, And) else np.argmax(vals))
            return _bind(m, args[i], k)
        case Next(arg):
            return (k, None) if k + 1 > n - 1 else _bind(m, arg, k + 1)
        case Always(lo, hi, arg) | Eventually(lo, hi, arg):
            a, b = m.window(lo, hi)
            first, last = k + a, min(k + b, n - 1)
            if first > last:
                return k, None
            seg = m.sig(arg)[first:last + 1]
            j = np.argmin(seg) if isinstance(f, Always) else np.argmax(seg)
            return _bind(m, arg, first + int(j))
        case Until(lo, hi, left, right) | Release(lo, hi, left, right):
            a, b = m.window(lo, hi)
            first, last = k + a, min(k + b, n - 1)
            if first > last:
                return k, None
            is_until = isinstance(f, Until)
            inner, outer = (np.minimum, np.argmax) if is_until else (np.maximum, np.argmin)
            fs = m.sig(left)[k:last + 1]
            run = inner.accumulate(fs)[first - k:]
            gs = m.sig(right)[first:last + 1]
            j = int(outer(inner(gs, run)))
            kp = first + j
            if (gs[j] <= run[j]) if is_until else (gs[j] >= run[j]):
                return _bind(m, right, kp)
            seg = fs[:kp - k + 1]
            return _bind(m, left, k + int(np.argmin(seg) if is_until else np.argmax(seg)))
    return k, None
