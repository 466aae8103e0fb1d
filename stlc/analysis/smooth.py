"""Smooth robustness: a numpy reference of the semantics the optimisation backend encodes.

Gilpin, Kurtz and Lin (2021), on the negation normal form (``nnf.normalize`` first):

* smooth min  ``-(1/λ) log Σ e^{-λ a_i}``                       (always ≤ min)
* smooth max  ``Σ a_i e^{λ a_i} / Σ e^{λ a_i}``  (``method="gkl"``, ≤ max, so sound), or
              ``(1/λ) log Σ e^{λ a_i}``         (``method="lse"``, ≥ max, not sound).

``and``/``or`` apply them to the children, ``always``/``eventually`` to the window,
``until`` is ``smax over k' of smin({g(k')} ∪ f[k..k'])`` and ``release`` the dual
``smin over k' of smax({g(k')} ∪ f[k..k'])`` — the structure of the exact semantics
(``stlc.analysis.monitor``), with the same windows, clipping and conventions (empty windows,
``next`` at the last sample).  Infinite operands behave like the exact operators: the result is
+inf/-inf exactly where the exact one is.

Numerical stability: every aggregate is a commutative monoid on *lifted* values that
combine with ``np.logaddexp`` (or ``np.maximum``), never with a raw ``exp``.  For GKL the
weighted mean is ``exp(LP - LD) - exp(LQ - LD)`` with ``LD = log Σ e^{λ a}`` and
``LP``/``LQ`` the same sums weighted by the positive/negative parts of ``a``.  Windows use
the van Herk sliding reduction of the monitor (O(n) per window); ``until``/``release`` loop
over window offsets in numpy (O(n·w)): this is a reference, not the fast path.

The fast path (values at the first sample, demand-driven) is ``stlc.analysis.smooth_demand``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from stlc.analysis.monitor import Channels, Evaluator, Params, shift, sliding
from stlc.semantics import nnf
from stlc.semantics.ir import (
    Always,
    And,
    Eventually,
    FalseF,
    Formula,
    Implies,
    Next,
    Not,
    Or,
    Pred,
    Release,
    TrueF,
    Until,
)

INF = np.inf
METHODS = ("gkl", "lse")

Lifted = tuple[np.ndarray, ...]


@dataclass(frozen=True)
class Aggregate:
    """A smooth min or max as a commutative monoid: ``lift`` maps values to components,
    each combined by its ufunc (identity -inf for all), ``value`` maps back."""

    lift: Callable[[np.ndarray], Lifted]
    ufuncs: tuple[np.ufunc, ...]
    value: Callable[[Lifted], np.ndarray]

    def reduce(self, xs: list[np.ndarray]) -> np.ndarray:
        xs = np.broadcast_arrays(*xs)
        parts = [self.lift(x) for x in xs]
        comps = tuple(functools.reduce(u, [p[i] for p in parts])
                      for i, u in enumerate(self.ufuncs))
        return self.value(comps)

    def window(self, x: np.ndarray, lo: int, hi: int) -> np.ndarray:
        comps = tuple(sliding(c, lo, hi, u, -INF, idempotent=False)
                      for c, u in zip(self.lift(x), self.ufuncs))
        return self.value(comps)

    def empty(self, shape: tuple[int, ...]) -> Lifted:
        return tuple(np.full(shape, -INF) for _ in self.ufuncs)

    def combine(self, a: Lifted, b: Lifted) -> Lifted:
        return tuple(u(x, y) for u, x, y in zip(self.ufuncs, a, b))


def smin(lam: float) -> Aggregate:
    return Aggregate(lambda x: (-lam * x,), (np.logaddexp,), lambda c: -c[0] / lam)


def smax_lse(lam: float) -> Aggregate:
    return Aggregate(lambda x: (lam * x,), (np.logaddexp,), lambda c: c[0] / lam)


def smax_gkl(lam: float) -> Aggregate:
    def lift(x: np.ndarray) -> Lifted:
        fin = np.isfinite(x)
        u = np.where(fin, lam * x, -INF)
        pos = np.where(fin & (x > 0), u + np.log(np.abs(x)), -INF)
        neg = np.where(fin & (x < 0), u + np.log(np.abs(x)), -INF)
        return x, u, pos, neg

    def value(c: Lifted) -> np.ndarray:
        mx, ld, lp, lq = c
        return np.where(np.isfinite(mx), np.exp(lp - ld) - np.exp(lq - ld), mx)

    return Aggregate(lift, (np.maximum, np.logaddexp, np.logaddexp, np.logaddexp), value)


def _nested(outer: Aggregate, inner: Aggregate, f: np.ndarray, g: np.ndarray, a: int,
            b: int) -> np.ndarray:
    """``outer`` over k' in [k+a, k+b] (clipped) of ``inner({g(k')} ∪ f[k..k'])``."""
    f, g = np.broadcast_arrays(f, g)
    n = f.shape[-1]
    b = min(b, n - 1)
    acc_out = outer.empty(f.shape)
    if a > n - 1 or b < a:
        return outer.value(acc_out)
    lf, lg = inner.lift(f), inner.lift(g)
    acc_in = inner.empty(f.shape)
    idx = np.arange(n)
    for j in range(b + 1):
        acc_in = inner.combine(acc_in, tuple(shift(c, j, -INF) for c in lf))
        if j < a:
            continue
        term = inner.value(inner.combine(acc_in, tuple(shift(c, j, -INF) for c in lg)))
        valid = idx <= n - 1 - j
        lifted = tuple(np.where(valid, c, -INF) for c in outer.lift(term))
        acc_out = outer.combine(acc_out, lifted)
    return outer.value(acc_out)


class _Smooth(Evaluator):
    """Smooth robustness signals of the subformulas (memoised); windows as the monitor."""

    def __init__(self, dt: float, channels: Channels, params: Params | None, n: int | None,
                 lam: float, method: str):
        super().__init__(dt, channels, params, n)
        if method not in METHODS:
            raise ValueError(f"unknown smoothing method {method!r} (use one of {METHODS})")
        if not lam > 0:
            raise ValueError(f"lambda must be positive, got {lam}")
        self.smin = smin(lam)
        self.smax = smax_gkl(lam) if method == "gkl" else smax_lse(lam)

    def sig(self, f: Formula) -> np.ndarray:
        hit = self.memo.get(f)
        if hit is None:
            with np.errstate(all="ignore"):
                hit = self.memo[f] = _SMOOTH_RULES[type(f)](self, f)
        return hit

    def until(self, f: Until | Release) -> np.ndarray:
        a, b = self.window(f.lo, f.hi)
        left, right = self.sig(f.left), self.sig(f.right)
        if isinstance(f, Until):
            return _nested(self.smax, self.smin, left, right, a, b)
        return _nested(self.smin, self.smax, left, right, a, b)


_SMOOTH_RULES: dict[type, Callable[[_Smooth, Formula], np.ndarray]] = {
    Pred: _Smooth.pred,
    TrueF: lambda m, f: m.const(INF),
    FalseF: lambda m, f: m.const(-INF),
    Not: lambda m, f: m.sig(nnf.normalize(f)),
    Implies: lambda m, f: m.sig(nnf.normalize(f)),
    And: lambda m, f: m.smin.reduce([m.sig(a) for a in f.args]),
    Or: lambda m, f: m.smax.reduce([m.sig(a) for a in f.args]),
    Always: lambda m, f: m.smin.window(m.sig(f.arg), *m.window(f.lo, f.hi)),
    Eventually: lambda m, f: m.smax.window(m.sig(f.arg), *m.window(f.lo, f.hi)),
    Until: _Smooth.until,
    Release: _Smooth.until,
    Next: lambda m, f: shift(m.sig(f.arg), 1, -INF),
}


def smooth_robustness_signal(f: Formula, dt: float, channels: Channels,
                             params: Params | None = None, lam: float = 10.0,
                             method: str = "gkl", *, n: int | None = None) -> np.ndarray:
    """Smooth robustness of ``f`` at every sample: shape ``(n,)`` or ``(K, n)``."""
    return _Smooth(dt, channels, params, n, lam, method).sig(nnf.normalize(f))


def smooth_robustness(f: Formula, dt: float, channels: Channels, params: Params | None = None,
                      lam: float = 10.0, method: str = "gkl", *,
                      n: int | None = None) -> float | np.ndarray:
    """Smooth robustness of ``f`` at the first sample: a float, or shape ``(K,)``."""
    r = smooth_robustness_signal(f, dt, channels, params, lam, method, n=n)[..., 0]
    return float(r) if r.ndim == 0 else r
