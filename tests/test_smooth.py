"""Smooth robustness: soundness (GKL ≤ exact), convergence as λ grows, stability."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from strategies import cases
from test_monitor import bf_expr, window

from stlc.analysis import smooth
from stlc.analysis.monitor import robustness_signal
from stlc.analysis.smooth import smooth_robustness, smooth_robustness_signal
from stlc.semantics import ir, nnf
from stlc.semantics.ir import (
    Always,
    And,
    Bin,
    Const,
    Eventually,
    Not,
    Or,
    Pred,
    Release,
    Sig,
    TrueF,
    Until,
)

INF = math.inf


def lse_min(xs, lam):
    """Independent scalar formulas, straight from the definitions (small |λ a| only)."""
    return -math.log(sum(math.exp(-lam * x) for x in xs)) / lam


def gkl_max(xs, lam):
    w = [math.exp(lam * x) for x in xs]
    return sum(x * wi for x, wi in zip(xs, w)) / sum(w)


def lse_max(xs, lam):
    return math.log(sum(math.exp(lam * x) for x in xs)) / lam


def s_min(xs, lam):
    """Stable scalar versions: shift by the min / max; ±inf handled like min/max."""
    m = min(xs, default=INF)
    if math.isinf(m):
        return m
    return m - math.log(sum(math.exp(-lam * (x - m)) for x in xs)) / lam


def s_max(xs, lam, method):
    m = max(xs, default=-INF)
    if math.isinf(m):
        return m
    w = [math.exp(lam * (x - m)) for x in xs]
    if method == "lse":
        return m + math.log(sum(w)) / lam
    return sum(x * wi for x, wi in zip(xs, w) if wi > 0) / sum(w)


def bf_smooth(f, k, dt, ch, lam, method):
    """Smooth semantics of an NNF formula at sample k, by loops over samples."""
    n = len(ch["x"])

    def r(g, kk):
        return bf_smooth(g, kk, dt, ch, lam, method)
    match f:
        case Pred(e):
            return bf_expr(e, k, ch, {})
        case TrueF():
            return INF
        case ir.FalseF():
            return -INF
        case And(args):
            return s_min([r(a, k) for a in args], lam)
        case Or(args):
            return s_max([r(a, k) for a in args], lam, method)
        case Always(lo, hi, a):
            return s_min([r(a, j) for j in window(lo, hi, dt, k, n)], lam)
        case Eventually(lo, hi, a):
            return s_max([r(a, j) for j in window(lo, hi, dt, k, n)], lam, method)
        case Until(lo, hi, a, b):
            return s_max([s_min([r(b, j)] + [r(a, i) for i in range(k, j + 1)], lam)
                          for j in window(lo, hi, dt, k, n)], lam, method)
        case Release(lo, hi, a, b):
            return s_min([s_max([r(b, j)] + [r(a, i) for i in range(k, j + 1)], lam, method)
                          for j in window(lo, hi, dt, k, n)], lam)
        case ir.Next(a):
            return r(a, k + 1) if k + 1 < n else -INF
    raise TypeError(f)


@settings(max_examples=60, deadline=None)
@given(cases(max_len=12, depth=2), st.sampled_from([0.7, 4.0, 30.0]),
       st.sampled_from(["gkl", "lse"]))
def test_matches_loop_implementation(case, lam, method):
    f, dt, ch = case
    nf = nnf.normalize(f)
    want = [bf_smooth(nf, k, dt, ch, lam, method) for k in range(len(ch["x"]))]
    got = smooth_robustness_signal(f, dt, ch, lam=lam, method=method)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


X = {"x": np.array([0.3, -0.2, 0.5, 0.1]), "y": np.array([0.0, 0.4, -0.1, 0.2])}
px, py = Pred(Sig("x")), Pred(Sig("y"))


@pytest.mark.parametrize("lam", [0.5, 2.0, 7.0])
def test_hand_formulas(lam):
    xs, ys = X["x"].tolist(), X["y"].tolist()
    assert smooth_robustness(And((px, py)), 1.0, X, lam=lam) == pytest.approx(
        lse_min([xs[0], ys[0]], lam))
    assert smooth_robustness(Or((px, py)), 1.0, X, lam=lam) == pytest.approx(
        gkl_max([xs[0], ys[0]], lam))
    assert smooth_robustness(Or((px, py)), 1.0, X, lam=lam, method="lse") == pytest.approx(
        lse_max([xs[0], ys[0]], lam))
    assert smooth_robustness(Always(1, 2, px), 1.0, X, lam=lam) == pytest.approx(
        lse_min(xs[1:3], lam))
    assert smooth_robustness(Eventually(0, 9, px), 1.0, X, lam=lam) == pytest.approx(
        gkl_max(xs, lam))
    # until[1,2]: smax over k' = 1, 2 of smin({y(k')} ∪ x[0..k'])
    terms = [lse_min([ys[k]] + xs[:k + 1], lam) for k in (1, 2)]
    assert smooth_robustness(Until(1, 2, px, py), 1.0, X, lam=lam) == pytest.approx(
        gkl_max(terms, lam))
    terms = [gkl_max([ys[k]] + xs[:k + 1], lam) for k in (0, 1, 2, 3)]
    assert smooth_robustness(Release(0, INF, px, py), 1.0, X, lam=lam) == pytest.approx(
        lse_min(terms, lam))


def test_infinite_operands_and_empty_windows():
    assert smooth_robustness(Always(7, 9, px), 1.0, X) == INF
    assert smooth_robustness(Eventually(7, 9, px), 1.0, X) == -INF
    assert smooth_robustness(And((TrueF(), px)), 1.0, X) == pytest.approx(0.3)
    assert smooth_robustness(Or((Not(TrueF()), px)), 1.0, X) == pytest.approx(0.3)
    assert smooth_robustness(Or((TrueF(), px)), 1.0, X) == INF
    assert smooth_robustness(Until(5, 6, px, py), 1.0, X) == -INF


def tol(x):
    return 1e-9 * (1.0 + np.abs(np.where(np.isfinite(x), x, 0.0)))


def same_infinities(a, b):
    a, b = np.broadcast_arrays(a, b)
    assert np.array_equal(np.isposinf(a), np.isposinf(b))
    assert np.array_equal(np.isneginf(a), np.isneginf(b))
    assert not np.isnan(a).any()


@settings(max_examples=100, deadline=None)
@given(cases(), st.sampled_from([0.5, 3.0, 20.0]))
def test_gkl_under_approximates(case, lam):
    f, dt, ch = case
    exact = robustness_signal(f, dt, ch)
    sm = smooth_robustness_signal(f, dt, ch, lam=lam)
    same_infinities(sm, exact)
    fin = np.isfinite(exact)
    assert np.all(sm[fin] <= exact[fin] + tol(exact[fin]))


@settings(max_examples=50, deadline=None)
@given(cases(max_len=20, depth=2), st.sampled_from(["gkl", "lse"]))
def test_converges_as_lambda_grows(case, method):
    f, dt, ch = case
    exact = robustness_signal(f, dt, ch)
    fin = np.isfinite(exact)
    errs = []
    for lam in (1e2, 1e4, 1e6):
        sm = smooth_robustness_signal(f, dt, ch, lam=lam, method=method)
        same_infinities(sm, exact)
        errs.append(np.max(np.abs(sm[fin] - exact[fin]), initial=0.0))
    # float error: the log-space sums are of size λ|a|, so their rounding (eps·λ|a|, ~2e-10|a|
    # at λ = 1e6) is a *relative* error of the result, i.e. ~eps·λ·|a|² in absolute terms
    # (found by Hypothesis: a = 144 gave 1.8e-6 and a = 1458 gave 1.7e-4 at λ = 1e6)
    scale = max(1.0, float(np.max(np.abs(exact[fin]), initial=0.0)))
    rounding = 1e-9 * scale * scale  # 4·eps·λ·|a|² at λ = 1e6
    assert errs[1] <= 1e-2 + rounding
    assert errs[2] <= 1e-4 + rounding
    assert errs[2] <= errs[0] + rounding


@settings(max_examples=40, deadline=None)
@given(cases(max_len=30), st.integers(0, 2**32 - 1))
def test_stable_for_large_values(case, seed):
    f, dt, ch = case
    rng = np.random.default_rng(seed)
    big = {k: v * 100.0 + rng.normal(0, 1e3, size=v.shape) for k, v in ch.items()}
    exact = robustness_signal(f, dt, big)
    fin = np.isfinite(exact)
    # float error as in test_converges_as_lambda_grows: the log-space sums hold λ|a|, whose
    # rounding is a relative error of the result, ~4·eps·λ·|a|² in absolute terms (found by
    # Hypothesis: a cubic predicate, |a| = 2.6e8, gkl off by 22 at λ = 50)
    scale = max(1.0, float(np.max(np.abs(exact[fin]), initial=0.0)))
    rounding = 4 * np.finfo(float).eps * 50.0 * scale * scale
    for method in ("gkl", "lse"):
        sm = smooth_robustness_signal(f, dt, big, lam=50.0, method=method)
        same_infinities(sm, exact)
        assert np.all(np.abs(sm[fin] - exact[fin]) < 1.0 + rounding)


@settings(max_examples=40, deadline=None)
@given(cases(max_len=25, next_=False))
def test_normalize_and_negation(case):
    f, dt, ch = case
    a = smooth_robustness_signal(f, dt, ch, lam=5.0)
    b = smooth_robustness_signal(nnf.normalize(f), dt, ch, lam=5.0)
    np.testing.assert_array_equal(a, b)


def test_params_broadcast():
    f = Eventually(0, 2, Pred(Bin("-", Sig("x"), ir.Param("p"))))
    pa = np.array([0.0, 0.2, -1.0])
    many = smooth_robustness(f, 1.0, X, {"p": pa}, lam=4.0)
    singles = [smooth_robustness(f, 1.0, X, {"p": p}, lam=4.0) for p in pa]
    np.testing.assert_allclose(many, singles, rtol=1e-12)


def test_rejects_bad_arguments():
    with pytest.raises(ValueError):
        smooth_robustness(px, 1.0, X, lam=0.0)
    with pytest.raises(ValueError):
        smooth_robustness(px, 1.0, X, method="softmax")


def test_every_node_has_a_rule():
    assert set(smooth._SMOOTH_RULES) == set(ir.FORMULA_NODES)


def test_benchmark_formula_close_to_exact():
    rng = np.random.default_rng(0)
    t = np.arange(2000) * 0.1
    ch = {"x": 2.5 + 2 * np.sin(t) + rng.normal(0, 0.1, t.size), "y": rng.normal(1.5, 1, t.size)}
    f = And((Always(0, 17, And((Pred(Sig("x")), Pred(Bin("-", Const(5.0), Sig("x")))))),
             Eventually(0, 12, Always(0, 5, Pred(Bin("-", Sig("y"), Const(1.0)))))))
    exact = robustness_signal(f, 0.1, ch)
    sm = smooth_robustness_signal(f, 0.1, ch, lam=1e5)
    assert np.all(sm <= exact + 1e-9)
    np.testing.assert_allclose(sm, exact, atol=1e-3)
