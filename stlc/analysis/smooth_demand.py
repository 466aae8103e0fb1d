"""Demand-driven smooth robustness: the fast path of ``stlc.analysis.smooth``.

``SmoothDemand`` / ``smooth_robustness_many`` give the smooth robustness (the semantics of
``stlc.analysis.smooth``) at the first sample of several formulas at once, demand-driven as
``monitor_demand.Demand``: its aggregates (``_Soft``) shift by the largest lifted value and
sum plain exponentials, one exp per operand and element, falling back to the ``Aggregate``
of ``stlc.analysis.smooth`` where an operand is infinite or a shifted sum underflows.
"""

from __future__ import annotations

import numpy as np

from stlc.analysis.monitor import Channels, Params
from stlc.analysis.monitor_demand import Demand, Plan, _pad
from stlc.analysis.smooth import INF, METHODS, Aggregate, smax_gkl, smax_lse, smin
from stlc.semantics import nnf


def _all_finite(xs) -> bool:
    """No inf or NaN in any of the arrays (a sum that overflows only sends a finite input
    down the general path, which is also correct)."""
    with np.errstate(all="ignore"):
        return all(np.isfinite(np.sum(x)) for x in xs)


#: smallest sum of shifted terms trusted by the fast paths (well above the subnormals)
TINY = 1e-280


class _Soft:
    """A smooth min or max evaluated with a shift instead of a chain of ``logaddexp``.

    The lifted value of an operand is ``u = sign·λ·x`` (sign −1 for the min); a reduction
    is the state ``(M, D, N)`` with ``M = max u``, ``D = Σ e^(u − M)``, ``N = Σ x e^(u − M)``,
    and smin = −(M + log D)/λ, LSE smax = (M + log D)/λ, GKL smax = N/D — the values of
    ``smin``/``smax_lse``/``smax_gkl`` up to rounding.  Infinite operands give the exact
    operators' infinities, as there: an operand at the absorbing end (−inf in a min, +inf in
    a max) decides, one at the identity end drops out.  Operands known to be finite
    (``finite=True``; ``None``: check) take fast paths: one exp per operand and element,
    in place; time-only operands, shape (n,), are reduced before the per-realisation ones,
    shape (K, n)."""

    def __init__(self, lam: float, is_min: bool, gkl: bool):
        self.lam, self.sign, self.gkl = lam, (-1.0 if is_min else 1.0), gkl and not is_min
        self.ext = np.minimum if is_min else np.maximum

    # ---- states (general: any infinities)
    def state(self, x: np.ndarray, axis: int | None = None):
        """State of one operand (``axis=None``) or of a reduction along ``axis`` (kept)."""
        u = (self.sign * self.lam) * x
        m = u if axis is None else np.max(u, axis=axis, keepdims=True)
        mf = np.where(np.isfinite(m), m, 0.0)
        w = np.exp(u - mf)
        d = w if axis is None else np.sum(w, axis=axis, keepdims=True)
        if not self.gkl:
            return m, d, None
        xw = np.where(np.isfinite(x), x, 0.0) * w
        return m, d, (xw if axis is None else np.sum(xw, axis=axis, keepdims=True))

    def merge(self, states: list):
        if len(states) == 1:
            return states[0]
        m = states[0][0]
        for s in states[1:]:
            m = np.maximum(m, s[0])
        mf = np.where(np.isfinite(m), m, 0.0)
        d = nn = 0.0
        for s_m, s_d, s_n in states:
            scale = np.exp(np.where(np.isfinite(s_m), s_m, -INF) - mf)
            d = d + s_d * scale
            if self.gkl:
                nn = nn + s_n * scale
        return m, d, (nn if self.gkl else None)

    def value(self, state) -> np.ndarray:
        m, d, nn = state
        fin = np.isfinite(m)
        if self.gkl:
            return np.where(fin, nn / np.where(fin, d, 1.0), m)
        v = (np.where(fin, m, 0.0) + np.log(np.where(fin, d, 1.0))) / self.lam
        return np.where(fin, self.sign * v, self.sign * m)

    def _group_state(self, xs: list):
        if len(xs) == 1:
            return self.state(xs[0])
        st = self.state(np.stack(np.broadcast_arrays(*xs)), axis=0)
        return tuple(None if c is None else c[0] for c in st)

    def _finish(self, m, d, nn) -> np.ndarray:
        """The value of a state without infinities."""
        if self.gkl:
            return nn / d
        return self.sign * (m + np.log(d)) / self.lam

    # ---- reductions
    def reduce(self, xs: list, finite: bool | None = None, seps=None) -> np.ndarray:
        """Smooth min/max of operands that broadcast together.  ``seps[i]``, when given,
        is operand i as ``t + p`` (``monitor_demand._Sep``: time-only plus per-realisation part):
        two or more such operands are reduced by a matrix product (``_sep_state``)."""
        xs = [np.asarray(x, dtype=float) for x in xs]
        if not (_all_finite(xs) if finite is None else finite):
            small = [x for x in xs if x.ndim < 2]
            states = ([self._group_state(small)] if small else []) + [
                self._group_state([x]) for x in xs if x.ndim >= 2]
            return self.value(self.merge(states))
        small, big, group = [], [], []
        for x, sp in zip(xs, seps or [None] * len(xs), strict=True):
            if x.ndim < 2:
                small.append(x)
            elif (sp is not None and np.ndim(sp.t) == 1 and np.ndim(sp.p) == 2
                  and np.shape(sp.p)[1] == 1):
                group.append((x, sp))
            else:
                big.append(x)
        states = [self._group_state(small)] if small else []
        st = self._sep_state([sp for _, sp in group]) if len(group) > 1 else None
        if st is None:
            big += [x for x, _ in group]
        else:
            states.append(st)
        if not big:
            return self._finish(*self._merge_finite(states))
        # M from the extreme operand, then one exp per operand and element, in place
        lam = self.sign * self.lam
        m = big[0]
        for x in big[1:]:
            m = self.ext(m, x)
        m = m * lam  # a new array: max of u over the big operands
        for st in states:
            np.maximum(m, st[0], out=m)
        t = np.empty(m.shape)
        d = nn = None
        for x in big:
            np.multiply(x, lam, out=t)
            t -= m
            np.exp(t, out=t)
            d = t.copy() if d is None else np.add(d, t, out=d)
            if self.gkl:
                t *= x
                nn = t.copy() if nn is None else np.add(nn, t, out=nn)
        for st_m, st_d, st_n in states:
            scale = np.exp(st_m - m)
            d += st_d * scale
            if self.gkl:
                nn += st_n * scale
        return self._finish(m, d, nn)

    def _merge_finite(self, states: list):
        if len(states) == 1:
            return states[0]
        m = states[0][0]
        for st in states[1:]:
            m = np.maximum(m, st[0])
        d = nn = 0.0
        for st_m, st_d, st_n in states:
            scale = np.exp(st_m - m)
            d = d + st_d * scale
            if self.gkl:
                nn = nn + st_n * scale
        return m, d, (nn if self.gkl else None)

    def _sep_state(self, seps: list):
        """State of finite operands ``x_j = t_j + p_j`` (t_j shape (n,), p_j shape (K, 1)):
        ``e^(u_j − M) = e^(λ t_j − T) · e^(λ p_j − P)`` with ``T = max_j λ t_j`` and
        ``P = max_j λ p_j`` (signs folded into λ), so ``D = A B`` and
        ``N = A (t∘B) + (p∘A) B`` are (K, J) × (J, n) matrix products instead of J
        exponentials over (K, n).  ``None`` (use the operands one by one) when a sum falls
        below ``TINY``: the two shifts are too far from the largest term."""
        lam = self.sign * self.lam
        tt = np.stack([sp.t for sp in seps])  # (J, n)
        pp = np.concatenate([sp.p for sp in seps], axis=1)  # (K, J)
        ut, up = lam * tt, lam * pp
        big_t = np.max(ut, axis=0)
        big_p = np.max(up, axis=1, keepdims=True)
        b = np.exp(ut - big_t)
        a = np.exp(up - big_p)
        # einsum, not ``@``: a multi-threaded BLAS (numpy imported before stlc) on a busy
        # machine made these small products 100x slower; einsum's own loop is steady
        d = np.einsum("kj,jt->kt", a, b)
        if not np.min(d) >= TINY:
            return None
        nn = (np.einsum("kj,jt->kt", np.concatenate([a, pp * a], axis=1),
                        np.concatenate([tt * b, b], axis=0)) if self.gkl else None)
        return big_p + big_t, d, nn

    def along(self, x: np.ndarray, finite: bool | None = None) -> np.ndarray:
        """Smooth min/max along the last axis (kept, with length 1)."""
        if not (_all_finite([x]) if finite is None else finite):
            return self.value(self.state(x, axis=-1))
        u = (self.sign * self.lam) * x
        m = np.max(u, axis=-1, keepdims=True)
        u -= m
        np.exp(u, out=u)
        d = np.sum(u, axis=-1, keepdims=True)
        nn = None
        if self.gkl:
            u *= x
            nn = np.sum(u, axis=-1, keepdims=True)
        return self._finish(m, d, nn)

    def window(self, x: np.ndarray, width: int, fallback: Aggregate,
               finite: bool | None = None) -> np.ndarray:
        """Smooth min/max of ``x[..., j : j + width + 1]`` (clipped) for every j.

        Each row is shifted by its largest lifted value, so every term is one exp ≤ 1, and
        window sums are sums of non-negative terms (``_window_sums``, no logaddexp).  Rows
        with a non-finite value, or where a window's sum falls below ``TINY`` (its terms
        more than ~640/λ below the row's extreme: the shift is too coarse), are computed
        by ``fallback`` (the ``Aggregate``)."""
        if x.shape[-1] == 0:
            return x
        rows = x.reshape(-1, x.shape[-1])
        if not (_all_finite([rows]) if finite is None else finite):
            fin = np.all(np.isfinite(rows), axis=-1)
            out = np.empty(rows.shape)
            if fin.any():
                out[fin] = self.window(rows[fin], width, fallback, True)
            out[~fin] = fallback.window(rows[~fin], 0, width)
            return out.reshape(x.shape)
        u = (self.sign * self.lam) * rows
        m = np.max(u, axis=-1, keepdims=True)
        u -= m
        np.exp(u, out=u)
        d = _window_sums(u, width)
        v = self._finish(m, d, _window_sums(u * rows, width) if self.gkl else None)
        bad = np.flatnonzero(np.min(d, axis=-1) < TINY)
        if bad.size:
            v[bad] = fallback.window(rows[bad], 0, width)
        return v.reshape(x.shape)

    def prefix_terms(self, f: np.ndarray, g: np.ndarray, fallback: Aggregate,
                     finite: bool | None = None) -> np.ndarray:
        """``self`` over ``{g[j - a]} ∪ f[0..j]`` for j = a … a + len(g) − 1, with
        ``a = len(f) − len(g)``: the terms of an until at its first sample.  Cumulative
        sums after a shift by each row's extreme; rows with a non-finite value or a sum
        below ``TINY`` are computed by ``fallback``, one term at a time."""
        a = f.shape[-1] - g.shape[-1]
        shape = np.broadcast_shapes(f.shape[:-1], g.shape[:-1])
        f2 = np.broadcast_to(f, shape + f.shape[-1:]).reshape(-1, f.shape[-1])
        g2 = np.broadcast_to(g, shape + g.shape[-1:]).reshape(-1, g.shape[-1])
        out = np.empty(g2.shape)
        if finite is None:
            finite = _all_finite([f2, g2])
        ok = (np.ones(len(f2), dtype=bool) if finite else
              np.all(np.isfinite(f2), axis=-1) & np.all(np.isfinite(g2), axis=-1))
        rows = np.flatnonzero(ok)
        if rows.size:
            fr, gr = (f2, g2) if rows.size == len(f2) else (f2[rows], g2[rows])
            uf, ug = (self.sign * self.lam) * fr, (self.sign * self.lam) * gr
            m = np.maximum(np.max(uf, axis=-1, keepdims=True),
                           np.max(ug, axis=-1, keepdims=True))
            ef, eg = np.exp(uf - m), np.exp(ug - m)
            d = np.cumsum(ef, axis=-1)[:, a:] + eg
            nn = (np.cumsum(fr * ef, axis=-1)[:, a:] + gr * eg) if self.gkl else None
            v = self._finish(m, d, nn)
            good = np.min(d, axis=-1) >= TINY
            out[rows[good]] = v[good]
            ok[rows[~good]] = False
        for r in np.flatnonzero(~ok).tolist():  # the reference, one term at a time
            acc = fallback.empty((1,))
            for j in range(f2.shape[-1]):
                acc = fallback.combine(acc, fallback.lift(f2[r, j:j + 1]))
                if j >= a:
                    out[r, j - a] = fallback.value(fallback.combine(acc, fallback.lift(
                        g2[r, j - a:j - a + 1])))[0]
        return out.reshape(shape + g.shape[-1:])


def _window_sums(x: np.ndarray, width: int) -> np.ndarray:
    """``x[..., j : j + width + 1].sum()`` (clipped) for every j: sums of 2^i consecutive
    samples by doubling, a window being the disjoint pieces of the binary expansion of its
    length (additions of non-negative terms only: no cancellation).  A new array."""
    m = x.shape[-1]
    w = min(width + 1, m)
    if w == 1:
        return x.copy()
    cur = np.concatenate([x, np.zeros(x.shape[:-1] + (w - 1,))], axis=-1)
    out, off, span = None, 0, 1
    while True:
        if w & span:
            piece = cur[..., off:off + m]
            out = piece.copy() if out is None else np.add(out, piece, out=out)
            off += span
        if 2 * span > w:
            return out
        cur = cur[..., :-span] + cur[..., span:]
        span *= 2


class SmoothDemand(Demand):
    """``monitor_demand.Demand`` with the smooth semantics (the values of ``_Smooth`` up to
    rounding; tests check it).  ``share`` — an exact ``Demand`` on the same plan, trace and
    parameters — lends its predicate values and finiteness flags."""

    def __init__(self, plan: Plan, channels: Channels, params: Params | None = None,
                 lam: float = 10.0, method: str = "gkl", *, share: Demand | None = None):
        super().__init__(plan, channels, params, share=share)
        if method not in METHODS:
            raise ValueError(f"unknown smoothing method {method!r} (use one of {METHODS})")
        if not lam > 0:
            raise ValueError(f"lambda must be positive, got {lam}")
        gkl = method == "gkl"
        self.soft_min, self.soft_max = _Soft(lam, True, gkl), _Soft(lam, False, gkl)
        self.smin = smin(lam)
        self.smax = smax_gkl(lam) if gkl else smax_lse(lam)

    separated = True

    def conj(self, kids: list, is_and: bool, finite: bool, seps=None) -> np.ndarray:
        if len(kids) == 1:
            return kids[0]
        return (self.soft_min if is_and else self.soft_max).reduce(kids, finite, seps)

    def window(self, x: np.ndarray, width: int, length: int, is_min: bool,
               finite: bool) -> np.ndarray:
        soft, agg = (self.soft_min, self.smin) if is_min else (self.soft_max, self.smax)
        if length == 1:
            return soft.along(x, finite)
        return _pad(soft.window(x, width, agg, finite), length, INF if is_min else -INF)

    def until(self, f: np.ndarray, g: np.ndarray, a: int, b: int, length: int,
              is_until: bool, finite: bool) -> np.ndarray:
        outer, inner = (self.smax, self.smin) if is_until else (self.smin, self.smax)
        if length > 1:
            g = _pad(g, f.shape[-1], -INF, front=a)
            return _nested_head(outer, inner, *np.broadcast_arrays(f, g), a, b, length)
        # at one sample: the outer aggregate of the terms inner({g(k')} ∪ f[0..k'])
        soft_in, soft_out = ((self.soft_min, self.soft_max) if is_until else
                             (self.soft_max, self.soft_min))
        return soft_out.along(soft_in.prefix_terms(f, g, inner, finite), finite)


def _nested_head(outer: Aggregate, inner: Aggregate, f: np.ndarray, g: np.ndarray, a: int,
                 b: int, length: int) -> np.ndarray:
    """``_nested`` at the first ``length`` samples only: O(length · window) work."""
    n = f.shape[-1]
    b = min(b, n - 1)
    shape = f.shape[:-1] + (length,)
    acc_out = outer.empty(shape)
    if a > n - 1 or b < a:
        return outer.value(acc_out)
    lf, lg = inner.lift(f), inner.lift(g)
    acc_in = inner.empty(shape)
    idx = np.arange(length)
    for j in range(b + 1):
        acc_in = inner.combine(acc_in, tuple(_pad(c[..., j:], length, -INF) for c in lf))
        if j < a:
            continue
        term = inner.value(inner.combine(acc_in, tuple(_pad(c[..., j:], length, -INF)
                                                       for c in lg)))
        valid = idx <= n - 1 - j
        lifted = tuple(np.where(valid, c, -INF) for c in outer.lift(term))
        acc_out = outer.combine(acc_out, lifted)
    return outer.value(acc_out)


def smooth_robustness_many(formulas, dt: float, channels: Channels,
                           params: Params | None = None, lam: float = 10.0,
                           method: str = "gkl", *, n: int | None = None) -> list:
    """Smooth robustness at the first sample of each formula (``nnf.normalize`` is applied)
    in one shared, demand-driven evaluation (``SmoothDemand``): floats, or arrays of
    shape (K,)."""
    if n is None:
        if not channels:
            raise ValueError("no channels: pass the number of samples n")
        n = len(next(iter(channels.values())))
    plan = Plan([nnf.normalize(f) for f in formulas], dt, n)
    return SmoothDemand(plan, channels, params, lam, method).values()
