"""Tests of the CasADi smooth-robustness lowering (``stlc.backends.nlp.smooth``).

The lowering is checked against an independent, deliberately naive numpy implementation
below (per sample, flat windows, no lifting, no dyadic blocks), against the numpy reference
``stlc.analysis.smooth`` when it exists, against finite differences, and by solving small NLPs whose
optimum is known.  ``test_size_and_speed`` prints a size/time comparison (run with ``-s``).
"""

from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from strategies import cases

from stlc.backends.nlp import expr as cx
from stlc.backends.nlp.smooth import LOWER, lower_robustness
from stlc.semantics import ir, nnf
from stlc.semantics.ir import Always, And, Bin, Call, Const, Eventually, Or, Pred, Sig
from stlc.semantics.timegrid import TimeGrid

BIG = cx.BIG

# --------------------------------------------------------------------------- naive reference


def _smin(a: list[float], lam: float) -> float:
    m = min(a)
    return m - math.log(sum(math.exp(-lam * (x - m)) for x in a)) / lam


def _smax(a: list[float], lam: float, method: str) -> float:
    m = max(a)
    w = [math.exp(lam * (x - m)) for x in a]
    if method == "lse":
        return m + math.log(sum(w)) / lam
    return sum(x * wi for x, wi in zip(a, w)) / sum(w)


def ref_expr(e: ir.Expr, k: int, ch: dict, par: dict, lam: float, method: str) -> float:
    def ev(x: ir.Expr) -> float:
        return ref_expr(x, k, ch, par, lam, method)

    match e:
        case Const(v):
            return v
        case Sig(name):
            return float(ch[name][k])
        case ir.Param(name):
            return par[name]
        case ir.Neg(a):
            return -ev(a)
        case Bin(op, a, b):
            x, y = ev(a), ev(b)
            ops = {"+": lambda: x + y, "-": lambda: x - y, "*": lambda: x * y,
                   "/": lambda: x / y, "^": lambda: x**y}
            return ops[op]()
        case Call(fn, args):
            v = [ev(a) for a in args]
            if fn == "abs":
                return math.sqrt(v[0] ** 2 + cx.ABS_EPS**2)
            if fn == "sqrt":
                return math.sqrt(max(v[0], 0.0) + cx.SQRT_EPS)
            if fn == "log":
                return math.log(max(v[0], cx.LOG_EPS))
            if fn in ("sin", "cos", "exp"):
                return getattr(math, fn)(v[0])
            if fn == "min":
                return _smin(v, lam)
            if fn == "max":
                return _smax(v, lam, method)
            if fn == "atan2":
                return math.atan2(v[0], v[1]) if v[0] ** 2 + v[1] ** 2 > cx.ATAN2_EPS else 0.0
            if fn == "angdiff":
                return math.atan2(math.sin(v[0] - v[1]), math.cos(v[0] - v[1]))
    raise TypeError(e)


def ref_rho(f: ir.Formula, dt: float, ch: dict, par: dict, lam: float, method: str) -> float:
    n = len(next(iter(ch.values())))
    grid = TimeGrid(dt, n - 1)
    memo: dict = {}

    def rho(g: ir.Formula, k: int) -> float:
        key = (g, k)
        if key not in memo:
            memo[key] = _rho(g, k)
        return memo[key]

    def _rho(g: ir.Formula, k: int) -> float:
        match g:
            case Pred(e):
                return ref_expr(e, k, ch, par, lam, method)
            case ir.TrueF():
                return BIG
            case ir.FalseF():
                return -BIG
            case And(args):
                return _smin([rho(a, k) for a in args], lam)
            case Or(args):
                return _smax([rho(a, k) for a in args], lam, method)
            case ir.Next(a):
                return rho(a, k + 1) if k + 1 < n else -BIG
        a_, b_ = grid.window(g.lo, g.hi)
        w = range(k + a_, min(k + b_, n - 1) + 1)
        match g:
            case Always(_, _, a):
                return _smin([rho(a, j) for j in w], lam) if len(w) else BIG
            case Eventually(_, _, a):
                return _smax([rho(a, j) for j in w], lam, method) if len(w) else -BIG
            case ir.Until(_, _, a, b):
                ops = [_smin([rho(b, j)] + [rho(a, i) for i in range(k, j + 1)], lam)
                       for j in w]
                return _smax(ops, lam, method) if ops else -BIG
            case ir.Release(_, _, a, b):
                ops = [_smax([rho(b, j)] + [rho(a, i) for i in range(k, j + 1)], lam, method)
                       for j in w]
                return _smin(ops, lam) if ops else BIG
        raise TypeError(g)

    return rho(f, 0)


# --------------------------------------------------------------------------- helpers


def build(f, grid, lam=10.0, method="gkl", lift=True, dyadic=True, lift_span=4,
          signals=("x", "y", "z"), param_names=("p",), hypograph=False):
    """Lower with symbolic channels/params; return (lowered, F(channels..., params..., aux))."""
    syms = {s: ca.SX.sym(s, 1, grid.n) for s in signals}
    psyms = {p: ca.SX.sym(p) for p in param_names}
    lr = lower_robustness(f, grid, syms, psyms, lam, method=method, lift=lift, dyadic=dyadic,
                          lift_span=lift_span, hypograph=hypograph)
    fn = ca.Function("F", [*syms.values(), *psyms.values(), lr.aux], [lr.root, lr.g, lr.h])
    return lr, fn


def evaluate(lr, fn, ch, par, lam=None):
    aux, root0 = lr.init_values(ch, par, lam)
    root, g, h = fn(*[np.reshape(v, (1, -1)) for v in ch.values()], *par.values(), aux)
    return root0, float(root), np.array(g).ravel(), np.array(h).ravel()


def close(a: float, b: float, tol: float = 1e-9) -> bool:
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


lams = st.sampled_from([0.5, 4.0, 25.0])
methods = st.sampled_from(["gkl", "lse"])

# --------------------------------------------------------------------------- structure


def test_every_nnf_node_is_registered():
    assert set(ir.NNF_NODES) <= set(LOWER)
    assert {ir.Const, ir.Sig, ir.Param, ir.Neg, ir.Bin, ir.Call} <= set(cx.EXPR_LOWER)
    assert set(ir.CALLS_1) | set(ir.CALLS_N) <= set(cx.CALLS)


def test_not_normalised_is_rejected():
    f = ir.Not(Pred(Bin("-", Sig("x"), Const(1.0))))
    with pytest.raises(cx.LoweringError):
        build(f, TimeGrid(0.1, 5))


def test_only_needed_samples_are_computed():
    p = Pred(Bin("-", Sig("x"), Const(1.0)))
    grid = TimeGrid(0.1, 200)
    lr, _ = build(Always(0.0, 0.4, p), grid, lift=False, dyadic=False)
    assert lr.stats["operands"] == 5  # one window of 5 samples at sample 0 only
    lr, _ = build(Eventually(0.0, 0.2, Always(0.0, 0.2, p)), grid, lift=False, dyadic=False)
    assert lr.stats["operands"] == 3 + 3 * 3


def test_dyadic_blocks_shrink_sliding_windows():
    p = Pred(Bin("-", Sig("x"), Const(1.0)))
    grid = TimeGrid(0.1, 300)
    f = Eventually(0.0, 10.0, Always(0.0, 10.0, p))
    flat, _ = build(f, grid, lift=False, dyadic=False)
    dy, _ = build(f, grid, lift=False, dyadic=True)
    assert flat.stats["operands"] == 101 * 101 + 101
    assert dy.stats["operands"] < flat.stats["operands"] / 3


# --------------------------------------------------------------------------- semantics


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=cases(params=("p",), max_len=16), lam=lams, method=methods,
       lift_span=st.sampled_from([1, 2, 4]), dyadic=st.booleans(), hypograph=st.booleans(),
       pval=st.sampled_from([-0.5, 0.0, 1.25]))
def test_matches_naive_reference(case, lam, method, lift_span, dyadic, hypograph, pval):
    f, dt, ch = case
    f = nnf.normalize(f)
    par = {"p": pval}
    grid = TimeGrid(dt, len(ch["x"]) - 1)
    ref = ref_rho(f, dt, ch, par, lam, method)
    assume(math.isfinite(ref))

    flat, ffn = build(f, grid, lam, method, lift=False, dyadic=dyadic, lift_span=lift_span)
    root0, root, _, _ = evaluate(flat, ffn, ch, par)
    assert close(root0, ref), (root0, ref)
    assert close(root, ref), (root, ref)

    lifted, lfn = build(f, grid, lam, method, lift=True, dyadic=dyadic, lift_span=lift_span,
                        hypograph=hypograph)
    root0, root, g, h = evaluate(lifted, lfn, ch, par)
    scale = 1e-9 * max(1.0, abs(ref), *np.abs(np.concatenate([ch[s] for s in ch])))
    assert close(root0, ref) and close(root, ref), (root0, root, ref)
    assert g.size == 0 or g.min() >= -scale * 10
    assert h.size == 0 or np.abs(h).max() <= scale * 10


@settings(max_examples=60, deadline=None)
@given(case=cases(max_len=12, next_=True), lam=lams)
def test_gkl_is_sound(case, lam):
    """Smooth GKL robustness never exceeds the exact robustness, as long as ±BIG are extreme
    and no predicate uses abs/sqrt/min/max (smoothed inside expressions, which is not
    sign-safe: e.g. sqrt(abs(x)) at x = 0 is sqrt(ABS_EPS) = 0.01)."""
    from stlc.analysis import monitor

    f, dt, ch = case
    f = _replace_preds(nnf.normalize(f), lambda p: _calls(p.expr) & {"min", "max", "abs", "sqrt"})
    exact = monitor.robustness(f, dt, ch)
    preds = [monitor.eval_expr(p.expr, ch) for p in ir.predicates(f)]
    if not math.isfinite(exact) or any(np.any(np.abs(v) >= BIG / 10) for v in preds):
        return  # ±inf and huge predicates: the ±BIG stand-ins are not extreme
    grid = TimeGrid(dt, len(ch["x"]) - 1)
    lr, fn = build(f, grid, lam, "gkl", lift=True, lift_span=2)
    root0, root, _, _ = evaluate(lr, fn, ch, {"p": 0.0})
    assert root0 <= exact + 1e-9 * max(1.0, abs(root0))


def _replace_preds(f: ir.Formula, bad) -> ir.Formula:
    """``f`` with every predicate ``p`` for which ``bad(p)`` replaced by ``x >= 0.25``."""
    match f:
        case Pred():
            return Pred(Bin("-", Sig("x"), Const(0.25))) if bad(f) else f
        case And(args) | Or(args):
            return type(f)(tuple(_replace_preds(a, bad) for a in args))
        case Always(lo, hi, a) | Eventually(lo, hi, a):
            return type(f)(lo, hi, _replace_preds(a, bad))
        case ir.Until(lo, hi, a, b) | ir.Release(lo, hi, a, b):
            return type(f)(lo, hi, _replace_preds(a, bad), _replace_preds(b, bad))
        case ir.Next(a):
            return ir.Next(_replace_preds(a, bad))
    return f


def _calls(e: ir.Expr) -> set[str]:
    match e:
        case Call(fn, args):
            return {fn}.union(*(_calls(a) for a in args))
        case Bin(_, a, b):
            return _calls(a) | _calls(b)
        case ir.Neg(a):
            return _calls(a)
    return set()


@settings(max_examples=40, deadline=None)
@given(case=cases(max_len=10, next_=False), lam=st.sampled_from([1.0, 5.0]), method=methods,
       seed=st.integers(0, 2**31 - 1))
def test_gradient_matches_finite_differences(case, lam, method, seed):
    f, dt, ch = case
    f = nnf.normalize(f)
    rng = np.random.default_rng(seed)
    ch = {s: rng.uniform(-2.0, 2.0, size=len(v)) for s, v in ch.items()}  # generic point
    grid = TimeGrid(dt, len(ch["x"]) - 1)
    syms = {s: ca.SX.sym(s, 1, grid.n) for s in ch}
    lr = lower_robustness(f, grid, syms, {}, lam, method=method, lift=False, lift_span=2)
    w = ca.vertcat(*[ca.vec(s) for s in syms.values()])
    fn = ca.Function("F", [w], [lr.root, ca.gradient(lr.root, w)])
    x0 = np.concatenate(list(ch.values()))
    val, grad = fn(x0)
    grad = np.array(grad).ravel()
    assume(abs(float(val)) < BIG / 2)
    step = 1e-6
    fd = np.array([(float(fn(x0 + step * e)[0]) - float(fn(x0 - step * e)[0])) / (2 * step)
                   for e in np.eye(len(x0))])
    assert np.all(np.isfinite(grad))
    assert np.allclose(grad, fd, rtol=1e-5, atol=1e-5 * max(1.0, np.abs(grad).max())), (
        grad, fd)


def test_derivatives_finite_at_singular_points():
    x, y = Sig("x"), Sig("y")
    exprs = [Call("abs", (x,)), Call("sqrt", (Bin("*", x, x),)), Call("atan2", (y, x)),
             Call("angdiff", (x, y)), Call("log", (x,)), Call("min", (x, y)),
             Call("max", (x, y))]
    f = And(tuple(Pred(e) for e in exprs))
    grid = TimeGrid(0.1, 2)
    syms = {"x": ca.SX.sym("x", 1, 3), "y": ca.SX.sym("y", 1, 3)}
    lr = lower_robustness(f, grid, syms, {}, 10.0, lift=False)
    w = ca.vertcat(ca.vec(syms["x"]), ca.vec(syms["y"]))
    fn = ca.Function("F", [w], [lr.root, ca.gradient(lr.root, w), ca.hessian(lr.root, w)[0]])
    for point in (np.zeros(6), np.array([0, 1, 2, 0, 1, 2.0])):
        for out in fn(point):
            assert np.all(np.isfinite(np.array(out)))


def test_extreme_values_do_not_overflow():
    p = Pred(Bin("-", Sig("x"), Const(0.0)))
    grid = TimeGrid(0.1, 9)
    xs = np.array([1e3, -1e3, 5.0, 999.0, -999.0, 0.0, 3.0, -2.0, 1e3, 7.0])
    for method in ("gkl", "lse"):
        f = And((Always(0.0, 0.9, p), Eventually(0.0, 0.9, p), Or((p, Always(0, 0.5, p)))))
        lr, fn = build(f, grid, 100.0, method, signals=("x",), param_names=())
        root0, root, g, h = evaluate(lr, fn, {"x": xs}, {})
        assert math.isfinite(root0) and close(root0, root)
        assert close(root0, ref_rho(f, 0.1, {"x": xs}, {}, 100.0, method))


@settings(max_examples=80, deadline=None)
@given(case=cases(params=("p",), max_len=16), lam=st.sampled_from([2.0, 10.0, 40.0]),
       method=methods)
def test_matches_numpy_reference_on_random_formulas(case, lam, method):
    """Same numbers as ``stlc.analysis.smooth`` wherever the conventions agree: finite robustness
    (the reference uses ±inf where we use ±BIG) and no abs/sqrt/min/max/atan2 in predicates
    (the reference evaluates expressions exactly, we smooth them)."""
    smooth = pytest.importorskip("stlc.analysis.smooth")
    f, dt, ch = case
    f = _replace_preds(nnf.normalize(f),
                       lambda p: _calls(p.expr) & {"min", "max", "abs", "sqrt", "atan2"})
    par = {"p": 0.75}
    ref = float(smooth.smooth_robustness(f, dt, ch, par, lam, method))
    if not (math.isfinite(ref) and abs(ref) < BIG / 10):
        return
    grid = TimeGrid(dt, len(ch["x"]) - 1)
    lr, fn = build(f, grid, lam, method)
    root0, root, _, _ = evaluate(lr, fn, ch, par)
    assert close(root0, ref, 1e-8) and close(root, ref, 1e-8), (root0, root, ref)


def test_matches_numpy_reference_if_present():
    smooth = pytest.importorskip("stlc.analysis.smooth")
    rng = np.random.default_rng(0)
    x, y = Sig("x"), Sig("y")
    box = And((Pred(Bin("-", x, Const(-0.5))), Pred(Bin("-", Const(1.0), x)),
               Pred(Bin("-", y, Const(0.0)))))
    f = nnf.normalize(And((Always(0.0, 1.0, box), Eventually(0.0, 0.8, Always(0.0, 0.5, box)),
                          ir.Until(0.0, 0.7, Pred(Bin("-", x, y)), box),
                          ir.Implies(Pred(Bin("-", y, Const(1.0))),
                                     Eventually(0.0, 0.4, Pred(Bin("-", x, Const(0.2))))))))
    grid = TimeGrid(0.1, 20)
    for method in ("gkl", "lse"):
        for lam in (2.0, 20.0):
            ch = {"x": rng.uniform(-1, 2, grid.n), "y": rng.uniform(-1, 2, grid.n)}
            lr, fn = build(f, grid, lam, method, signals=("x", "y"), param_names=())
            root0, root, _, _ = evaluate(lr, fn, ch, {})
            ref = float(smooth.smooth_robustness(f, 0.1, ch, {}, lam, method))
            assert close(root0, ref) and close(root, ref), (method, lam, root0, ref)


# --------------------------------------------------------------------------- optimisation


def solve(lr, w, lbw, ubw, w0, p=None, p0=None):
    g, lbg, ubg = lr.constraints()
    x = ca.vertcat(w, lr.aux)
    nlp = {"x": x, "f": -lr.root, "g": g}
    if p is not None:
        nlp["p"] = p
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}
    solver = ca.nlpsol("S", "ipopt", nlp, opts)
    na = lr.aux.numel()
    args = dict(x0=w0, lbx=np.concatenate([lbw, -np.inf * np.ones(na)]),
                ubx=np.concatenate([ubw, np.inf * np.ones(na)]), lbg=lbg, ubg=ubg)
    if p is not None:
        args["p"] = p0
    sol = solver(**args)
    return np.array(sol["x"]).ravel(), -float(sol["f"]), solver.stats()


def box_always(T: float):
    x = Sig("x")
    return Always(0.0, T, And((Pred(Bin("-", x, Const(1.0))), Pred(Bin("-", Const(3.0), x)))))


@pytest.mark.parametrize("lam", [10.0, 50.0])
def test_ipopt_always_in_interval(lam):
    grid = TimeGrid(0.1, 20)
    X = ca.SX.sym("x", 1, grid.n)
    lr = lower_robustness(box_always(2.0), grid, {"x": X}, {}, lam)
    x0 = np.linspace(-5.0, 8.0, grid.n)
    aux0, _ = lr.init_values({"x": x0})
    sol, val, stats = solve(lr, X.T, -10 * np.ones(grid.n), 10 * np.ones(grid.n),
                            np.concatenate([x0, aux0]))
    assert stats["success"]
    assert np.allclose(sol[: grid.n], 2.0, atol=1e-4)
    expected = 1.0 - math.log(2 * grid.n) / lam  # all 2n operands equal to 1
    assert abs(val - expected) < 1e-6


def test_ipopt_eventually_reach():
    grid = TimeGrid(0.1, 30)
    X = ca.SX.sym("x", 1, grid.n)
    f = Eventually(0.0, 3.0, Pred(Bin("-", Sig("x"), Const(5.0))))
    for method, lam in (("gkl", 20.0), ("lse", 2.0)):
        lr = lower_robustness(f, grid, {"x": X}, {}, lam, method=method)
        x0 = np.zeros(grid.n)
        aux0, _ = lr.init_values({"x": x0})
        sol, val, stats = solve(lr, X.T, -10 * np.ones(grid.n), 6 * np.ones(grid.n),
                                np.concatenate([x0, aux0]))
        assert stats["success"]
        if method == "gkl":  # GKL ≤ max = 1: reached by x ≡ 6, or by one x = 6, others far
            assert abs(val - 1.0) < 1e-6 and sol[: grid.n].max() > 6.0 - 1e-6
        else:  # lse is increasing in every operand: x ≡ 6
            assert np.allclose(sol[: grid.n], 6.0, atol=1e-4)
            assert abs(val - (1.0 + math.log(grid.n) / lam)) < 1e-6


def test_ipopt_symbolic_lambda_schedule():
    """One NLP, λ as a parameter, warm-started along a schedule: smooth value → exact (1)."""
    grid = TimeGrid(0.1, 20)
    X, lam = ca.SX.sym("x", 1, grid.n), ca.SX.sym("lam")
    lr = lower_robustness(box_always(2.0), grid, {"x": X}, {}, lam)
    x0 = np.linspace(-5.0, 8.0, grid.n)
    w0 = np.concatenate([x0, lr.init_values({"x": x0}, lam=5.0)[0]])
    last = -np.inf
    for lv in (5.0, 20.0, 100.0):
        w0[grid.n:] = lr.init_values({"x": w0[: grid.n]}, lam=lv)[0]
        w0, val, stats = solve(lr, X.T, -10 * np.ones(grid.n), 10 * np.ones(grid.n), w0,
                               p=lam, p0=lv)
        assert stats["success"] and val > last
        last = val
    assert abs(last - (1 - math.log(2 * grid.n) / 100.0)) < 1e-6


# --------------------------------------------------------------------------- size / speed


def _benchmark_problem(lift: bool, dyadic: bool, lam: float = 50.0, solve: bool = True,
                       hypograph: bool = False) -> dict:
    """A point mass in 3-D (x_{k+1} = x_k + dt·v_k, |v_i| ≤ 1) must stay in a corridor box
    for 17 s and, within 12 s, reach a target box and stay 5 s (n = 171, dt = 0.1)."""
    from stlc.analysis import monitor

    grid = TimeGrid(0.1, 170)
    n, dt = grid.n, grid.dt
    P = ca.SX.sym("P", 3, n)
    V = ca.SX.sym("V", 3, n - 1)
    names = ("x", "y", "z")
    chans = {s: P[i, :] for i, s in enumerate(names)}

    def box(lo, hi):
        preds = []
        for s, a, b in zip(names, lo, hi):
            preds += [Pred(Bin("-", Sig(s), Const(a))), Pred(Bin("-", Const(b), Sig(s)))]
        return And(tuple(preds))

    corridor = box((-1.0, -1.0, 0.0), (6.0, 2.0, 3.0))
    target = box((4.0, 0.0, 1.0), (5.0, 1.0, 2.0))
    f = nnf.normalize(And((Always(0.0, 17.0, corridor),
                          Eventually(0.0, 12.0, Always(0.0, 5.0, target)))))
    t0 = time.perf_counter()
    lr = lower_robustness(f, grid, chans, {}, lam, lift=lift, dyadic=dyadic,
                          hypograph=hypograph)
    out = dict(lr.stats, lower_s=time.perf_counter() - t0)
    if not solve:
        return out
    dyn = ca.vec(P[:, 1:] - P[:, :-1] - dt * V)
    g, lbg, ubg = lr.constraints()
    w = ca.vertcat(ca.vec(P), ca.vec(V), lr.aux)
    solver = ca.nlpsol("S", "ipopt", {"x": w, "f": -lr.root, "g": ca.vertcat(dyn, g)},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
                        "ipopt.max_iter": 500})
    out["build_s"] = time.perf_counter() - t0
    pos0 = np.zeros((3, n))
    pos0[0] = np.linspace(0, 4.5, n)
    pos0[1] = np.linspace(0, 0.5, n)
    pos0[2] = np.linspace(0.5, 1.5, n)
    vel0 = np.diff(pos0, axis=1) / dt
    aux0, _ = lr.init_values({s: pos0[i] for i, s in enumerate(names)})
    nv, na = 3 * (n - 1), lr.aux.numel()
    start = [0.0, 0.0, 0.5]
    lbw = np.concatenate([start, np.full(3 * n - 3, -np.inf), -np.ones(nv), np.full(na, -np.inf)])
    ubw = np.concatenate([start, np.full(3 * n - 3, np.inf), np.ones(nv), np.full(na, np.inf)])
    t0 = time.perf_counter()
    sol = solver(x0=np.concatenate([pos0.ravel(order="F"), vel0.ravel(order="F"), aux0]),
                 lbx=lbw, ubx=ubw, lbg=np.concatenate([np.zeros(dyn.numel()), lbg]),
                 ubg=np.concatenate([np.zeros(dyn.numel()), ubg]))
    out["solve_s"] = time.perf_counter() - t0
    xs = np.array(sol["x"]).ravel()[: 3 * n].reshape((3, n), order="F")
    out["exact"] = float(monitor.robustness(f, dt, {s: xs[i] for i, s in enumerate(names)}))
    out["smooth"] = -float(sol["f"])
    out["iters"] = solver.stats()["iter_count"]
    out["status"] = solver.stats()["return_status"]
    return out


def _report(lift: bool, dyadic: bool, r: dict) -> str:
    line = (f"lift={lift!s:5} dyadic={dyadic!s:5} operands={r['operands']:5d} aux={r['aux']:4d} "
            f"g={r['g']:4d} h={r['h']:4d} lower={r['lower_s']:.2f}s")
    if "solve_s" in r:
        line += (f" build={r['build_s']:.2f}s solve={r['solve_s']:.2f}s iters={r['iters']} "
                 f"smooth={r['smooth']:.4f} exact={r['exact']:.4f} {r['status']}")
    return line


def test_size_and_speed():
    """Printed, not asserted beyond sanity (run with -s).  Only lifted+dyadic is solved here;
    ``python tests/test_smooth_casadi.py`` solves all four variants (~2 minutes: the
    un-lifted NLPs spend 30-60 s in nlpsol set-up)."""
    fast = _benchmark_problem(True, True)
    print("\n" + _report(True, True, fast))
    for lift, dyadic in ((True, False), (False, True), (False, False)):
        print(_report(lift, dyadic, _benchmark_problem(lift, dyadic, solve=False)))
    assert fast["exact"] > 0 and fast["smooth"] <= fast["exact"] + 1e-6


if __name__ == "__main__":
    for lift, dyadic in ((True, True), (True, False), (False, True), (False, False)):
        print(_report(lift, dyadic, _benchmark_problem(lift, dyadic)), flush=True)
