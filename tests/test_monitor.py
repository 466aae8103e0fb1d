"""The exact monitor against a brute-force transcription of the contract semantics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import DTS, cases, formulas, traces

from stlc.analysis import monitor
from stlc.analysis.monitor import binding, eval_expr, robustness, robustness_signal, sliding
from stlc.semantics import ir, nnf
from stlc.semantics.ir import (
    Always,
    And,
    Bin,
    Call,
    Const,
    Eventually,
    FalseF,
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

INF = math.inf

# --------------------------------------------------------------------------- brute force


def bf_expr(e, k: int, ch, pa) -> float:
    """Scalar evaluation at sample k with the math module."""
    def ev(x):
        return bf_expr(x, k, ch, pa)
    match e:
        case Const(v):
            return v
        case Sig(name):
            return float(ch[name][k])
        case Param(name):
            return float(pa[name])
        case Neg(a):
            return -ev(a)
        case Bin(op, a, b):
            x, y = ev(a), ev(b)
            return {"+": x + y, "-": x - y, "*": x * y}[op] if op in "+-*" else (
                x / y if op == "/" else x ** y)
        case Call(fn, args):
            xs = [ev(a) for a in args]
            if fn in ("min", "max"):
                return min(xs) if fn == "min" else max(xs)
            if fn == "atan2":
                return math.atan2(*xs)
            if fn == "angdiff":
                d = xs[0] - xs[1]
                return math.atan2(math.sin(d), math.cos(d))
            return getattr(math, "fabs" if fn == "abs" else fn)(xs[0])
    raise TypeError(e)


def window(lo: float, hi: float, dt: float, k: int, n: int) -> range:
    """Samples k + ceil(lo/dt) … k + floor(hi/dt), clipped to the trace (1e-9 tolerance)."""
    first = k + math.ceil(lo / dt - 1e-9)
    last = n - 1 if math.isinf(hi) else min(n - 1, k + math.floor(hi / dt + 1e-9))
    return range(first, last + 1)


def bf(f, k: int, dt: float, ch, pa=None, pol: int = 1, memo=None) -> float:
    """Contract semantics at sample k; ``pol`` = -1 under an odd number of negations, only
    used for the one documented convention: ``next`` past the end is -inf *in the NNF*."""
    pa = pa or {}
    memo = {} if memo is None else memo
    n = len(next(iter(ch.values())))

    def r(g, kk, p=pol):
        key = (id(g), kk, p)
        if key not in memo:
            memo[key] = bf(g, kk, dt, ch, pa, p, memo)
        return memo[key]
    match f:
        case Pred(e):
            return bf_expr(e, k, ch, pa)
        case TrueF():
            return INF
        case FalseF():
            return -INF
        case Not(a):
            return -r(a, k, -pol)
        case Implies(a, b):
            return max(-r(a, k, -pol), r(b, k))
        case And(args):
            return min(r(a, k) for a in args)
        case Or(args):
            return max(r(a, k) for a in args)
        case Always(lo, hi, a):
            return min((r(a, j) for j in window(lo, hi, dt, k, n)), default=INF)
        case Eventually(lo, hi, a):
            return max((r(a, j) for j in window(lo, hi, dt, k, n)), default=-INF)
        case Until(lo, hi, a, b):
            return max((min(r(b, j), min(r(a, i) for i in range(k, j + 1)))
                        for j in window(lo, hi, dt, k, n)), default=-INF)
        case Release(lo, hi, a, b):
            return min((max(r(b, j), max(r(a, i) for i in range(k, j + 1)))
                        for j in window(lo, hi, dt, k, n)), default=INF)
        case Next(a):
            return r(a, k + 1) if k + 1 < n else -INF * pol
    raise TypeError(f)


def bf_signal(f, dt, ch, pa=None) -> np.ndarray:
    """The brute force at every sample (memoised per (node, sample, polarity))."""
    n = len(next(iter(ch.values())))
    memo: dict = {}
    return np.array([bf(f, k, dt, ch, pa, 1, memo) for k in range(n)])


def close(a, b):
    np.testing.assert_allclose(np.asarray(a, float), np.asarray(b, float), rtol=1e-9, atol=1e-9)


# --------------------------------------------------------------------------- hand examples

X = {"x": np.array([1.0, 2.0, 3.0])}
px = Pred(Sig("x"), "x >= 0")


@pytest.mark.parametrize("f, expected", [
    (Always(0, 1, px), 1.0),
    (Eventually(0, 1, px), 2.0),
    (Always(1, 5, px), 2.0),  # clipped to the trace
    (Eventually(5, 6, px), -INF),  # empty window
    (Always(5, 6, px), INF),
    (Always(0.2, 0.7, px), INF),  # [0.2, 0.7] holds no sample at dt = 1
    (Next(px), 2.0),
    (Next(Next(Next(px))), -INF),
    (Not(Next(Next(Next(px)))), -INF),  # documented: next past the end is -inf in the NNF
    (Until(0, 2, px, Pred(Bin("-", Sig("x"), Const(2.5)))), 0.5),
    (Until(0, 1, px, Pred(Bin("-", Sig("x"), Const(2.5)))), -0.5),
    (Implies(px, Pred(Neg(Sig("x")))), -1.0),
    (And((px, Or((Pred(Const(7.0)), FalseF())))), 1.0),
])
def test_hand_examples(f, expected):
    assert robustness(f, 1.0, X) == expected


def test_float_bounds_use_tolerance():
    ch = {"x": np.arange(30.0)}
    # 1.7 / 0.1 = 16.999999999999996: the window must still end at sample 17
    assert robustness(Eventually(0, 1.7, px), 0.1, ch) == 17.0
    assert robustness(Eventually(0.3, 0.3, px), 0.1, ch) == 3.0
    assert robustness(Always(0.3, 1.7, px), 0.1, ch) == 3.0


def test_signal_and_memo_on_shared_subtrees():
    sub = Eventually(0, 1, px)
    f = And((Always(0, 1, sub), Or((sub, Next(sub)))))
    close(robustness_signal(f, 1.0, X), bf_signal(f, 1.0, X))


# --------------------------------------------------------------------------- properties


@settings(max_examples=250, deadline=None)
@given(cases())
def test_monitor_matches_brute_force(case):
    f, dt, ch = case
    close(robustness_signal(f, dt, ch), bf_signal(f, dt, ch))


@settings(max_examples=100, deadline=None)
@given(cases(next_=False))
def test_normalize_preserves_robustness(case):
    f, dt, ch = case
    nf = nnf.normalize(f)
    assert all(isinstance(g, ir.NNF_NODES) for g in _nodes(nf))
    close(bf_signal(nf, dt, ch), bf_signal(f, dt, ch))
    close(robustness_signal(nf, dt, ch), robustness_signal(f, dt, ch))
    close(robustness_signal(Not(f), dt, ch), -robustness_signal(f, dt, ch))


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_not_until_is_release_of_negations(data):
    dt = data.draw(st.sampled_from(DTS))
    sub = formulas(dt, depth=2, next_=False)
    a, b = data.draw(sub), data.draw(sub)
    lo, hi = data.draw(st.sampled_from([(0, 3), (0.5, 2), (0, INF), (1, 1)]))
    ch = data.draw(traces())
    rel = Release(lo, hi, Not(a), Not(b))
    close(-robustness_signal(Until(lo, hi, a, b), dt, ch), robustness_signal(rel, dt, ch))
    close(robustness_signal(rel, dt, ch), bf_signal(rel, dt, ch))


def _nodes(f):
    yield f
    for c in ir.children(f):
        yield from _nodes(c)


@settings(max_examples=60, deadline=None)
@given(cases(params=("p", "q"), depth=2), st.lists(st.floats(-3, 3), min_size=2, max_size=4),
       st.lists(st.floats(-3, 3), min_size=2, max_size=4))
def test_param_arrays_broadcast(case, ps, qs):
    f, dt, ch = case
    k = min(len(ps), len(qs))
    pa = {"p": np.array(ps[:k]), "q": np.array(qs[:k])}
    many = robustness_signal(f, dt, ch, pa)
    singles = np.array([robustness_signal(f, dt, ch, {"p": ps[i], "q": qs[i]})
                        for i in range(k)])
    close(np.broadcast_to(many, singles.shape), singles)
    uses = bool(ir.params(nnf.normalize(f)))
    assert many.shape == ((k, len(ch["x"])) if uses else (len(ch["x"]),))
    close(np.broadcast_to(robustness(f, dt, ch, pa), (k,)), singles[:, 0])


@settings(max_examples=100, deadline=None)
@given(cases())
def test_binding_predicate_carries_the_value(case):
    f, dt, ch = case
    value, k, pred = binding(f, dt, ch)
    assert value == robustness(f, dt, ch)
    if pred is not None:
        assert 0 <= k < len(ch["x"])
        assert eval_expr(pred.expr, ch)[k] == value
    else:
        assert math.isinf(value)


def test_binding_names_the_tight_predicate():
    ch = {"x": np.array([3.0, 1.0, 4.0, 1.5]), "y": np.array([0.0, 0.0, 0.0, 5.0])}
    low = Pred(Bin("-", Sig("x"), Const(0.5)), "x >= 0.5")
    f = And((Always(0, 3, low), Eventually(0, 3, Pred(Sig("y"), "y >= 0"))))
    assert binding(f, 1.0, ch) == (0.5, 1, low)
    value, k, pred = binding(Not(Eventually(0, 3, Pred(Sig("y"), "y >= 0"))), 1.0, ch)
    assert (value, k, pred.label) == (-5.0, 3, "not (y >= 0)")


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 60), st.integers(0, 70), st.integers(0, 70), st.booleans(),
       st.integers(0, 2**32 - 1))
def test_sliding_window_matches_loops(n, lo, width, use_min, seed):
    x = np.random.default_rng(seed).normal(size=(2, n)).round(1)
    op, ident, red = (np.minimum, INF, min) if use_min else (np.maximum, -INF, max)
    got = sliding(x, lo, lo + width, op, ident)
    want = [[red(row[k + lo:k + lo + width + 1], default=ident) for k in range(n)] for row in x]
    close(got, want)
    lse = sliding(x, lo, lo + width, np.logaddexp, -INF, idempotent=False)
    want = [[np.logaddexp.reduce(row[k + lo:k + lo + width + 1]) for k in range(n)]
            for row in x]
    close(lse, want)


def test_expressions():
    ch = {"a": np.array([1.0, -2.0]), "b": np.array([0.5, 3.0])}
    a, b = Sig("a"), Sig("b")
    close(eval_expr(Call("angdiff", (Const(3.0), Const(-3.0))), ch), [6 - 2 * np.pi] * 2)
    close(eval_expr(Bin("^", a, Const(2.0)), ch), [1.0, 4.0])
    close(eval_expr(Call("max", (a, b, Const(0.7))), ch), [1.0, 3.0])
    close(eval_expr(Call("atan2", (b, a)), ch), np.arctan2([0.5, 3.0], [1.0, -2.0]))
    assert eval_expr(Param("p"), ch, {"p": np.array([1.0, 2.0, 3.0])}).shape == (3, 2)
    assert eval_expr(Const(2.0), ch).shape == (2,)
    with pytest.raises(KeyError):
        eval_expr(Sig("nope"), ch)
    with pytest.raises(ValueError):
        eval_expr(Call("atan2", (a,)), ch)


def test_every_node_has_a_rule():
    assert set(monitor._RULES) == set(ir.FORMULA_NODES)
    assert set(monitor._EXPR_RULES) == {Const, Sig, Param, Neg, Bin, Call}


def test_large_trace_until_unbounded():
    rng = np.random.default_rng(1)
    ch = {"x": rng.normal(size=3000), "y": rng.normal(size=3000)}
    f = Until(0.5, INF, Pred(Bin("+", Sig("x"), Const(2.0))), Pred(Sig("y")))
    got = robustness_signal(f, 0.1, ch)
    sub = {k: v[-40:] for k, v in ch.items()}
    close(got[-40:], bf_signal(f, 0.1, sub))


def test_channel_lengths_and_explicit_n():
    ch = {"u": np.zeros(2), "x": np.array([1.0, 2.0, 3.0])}
    assert robustness(Always(0, 9, px), 1.0, ch, n=3) == 1.0  # unused short channel is fine
    with pytest.raises(ValueError):
        robustness(Always(0, 9, Pred(Sig("u"))), 1.0, ch, n=3)
    assert robustness(Eventually(1, 1, TrueF()), 1.0, {}, n=2) == INF
    with pytest.raises(ValueError):
        robustness(TrueF(), 1.0, {})
