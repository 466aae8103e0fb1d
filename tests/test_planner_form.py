"""Tests of what the NLP optimises instead of the formula as written.

``casadi_expr.planner_form(f, κ)`` rewrites every predicate margin m into a smooth margin
with the sign of m - κ, so that ρ(P_κ f) > 0 ⟺ ρ(f) > κ for the exact monitor: checked here
on random trajectories against ``stlc.analysis.monitor`` (the reference) for boxes, speed bounds,
rotor-speed intervals and the heading-or-hover disjunction of the handover comfort spec.
``lam_scaling`` (λ·(1 + ln n) per n-ary operator) is checked against a hand-computed
smooth min.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from stlc.analysis import monitor
from stlc.backends.nlp import expr as cx
from stlc.backends.nlp.smooth import lower_robustness
from stlc.semantics import ir, nnf
from stlc.semantics.ir import Always, And, Bin, Call, Const, Eventually, Or, Pred, Sig
from stlc.semantics.timegrid import TimeGrid

X, Y, VX, VY, VZ, PSI, XI = (Sig(s) for s in ("x", "y", "vx", "vy", "vz", "psi", "xi"))


def _sqrt(e: ir.Expr) -> ir.Expr:
    return Call("sqrt", (e,))


def _sq(*xs: ir.Expr) -> ir.Expr:
    out: ir.Expr = Bin("*", xs[0], xs[0])
    for x in xs[1:]:
        out = Bin("+", out, Bin("*", x, x))
    return out


def _box(lo: tuple[float, float], hi: tuple[float, float]) -> ir.Formula:
    return And((Pred(Bin("-", X, Const(lo[0]))), Pred(Bin("-", Const(hi[0]), X)),
                Pred(Bin("-", Y, Const(lo[1]))), Pred(Bin("-", Const(hi[1]), Y))))


def comfort() -> ir.Formula:
    """The handover comfort spec's shape, as ``elaborate`` writes it."""
    speed = Pred(Bin("-", Const(0.4), _sqrt(_sq(VX, VY, VZ))))
    rotor_lo = Pred(Bin("-", _sqrt(Bin("/", XI, Const(1.15e-3))), Const(40.0)))
    rotor_hi = Pred(Bin("-", Const(80.0), _sqrt(Bin("/", XI, Const(1.15e-3)))))
    heading = Pred(Bin("-", Const(math.radians(30)), Call("abs", (
        Call("angdiff", (PSI, Call("atan2", (VY, VX)))),))))
    hover = Pred(Bin("-", Const(0.1), _sqrt(_sq(VX, VY))))
    return Always(0, 1, And((speed, rotor_lo, rotor_hi, Or((heading, hover)))))


def reach_avoid() -> ir.Formula:
    avoid = nnf.normalize(ir.Not(_box((-1.0, -1.0), (0.0, 1.0))))
    return And((Always(0, 1, avoid), Eventually(0, 1, _box((0.5, 0.5), (0.8, 0.9)))))


@st.composite
def traces(draw):
    n = 3
    f = st.floats(-2, 2, allow_nan=False)
    ch = {s: np.array(draw(st.lists(f, min_size=n, max_size=n)))
          for s in ("x", "y", "vx", "vy", "vz")}
    ch["vx"] *= draw(st.sampled_from([0.05, 0.3, 1.0]))  # hovering, slow and fast
    ch["vy"] *= draw(st.sampled_from([0.05, 0.3, 1.0]))
    ch["vz"] *= 0.2
    ch["psi"] = np.array(draw(st.lists(st.floats(-6, 6), min_size=n, max_size=n)))
    ch["xi"] = np.array(draw(st.lists(st.floats(0.3, 11.5), min_size=n, max_size=n)))
    return ch


@settings(max_examples=300, deadline=None)
@given(ch=traces(), kappa=st.sampled_from([0.0, 0.01, 0.05]),
       which=st.sampled_from(["comfort", "reach_avoid"]))
def test_planner_form_keeps_the_sign_of_rho_minus_kappa(ch, kappa, which):
    f = nnf.normalize(comfort() if which == "comfort" else reach_avoid())
    exact = monitor.robustness(f, 0.5, ch)
    assume(abs(exact - kappa) > 1e-6)
    planned = monitor.robustness(cx.planner_form(f, kappa), 0.5, ch)
    if planned > 0:  # what the planner certifies holds for the formula as written
        assert exact > kappa, (exact, planned)
    if which == "reach_avoid":  # boxes: exactly the same sign
        assert (planned > 0) == (exact > kappa), (exact, planned)


def test_planner_form_scales_box_faces_by_half_width():
    """The face x >= 0.5 of a box 0.3 wide becomes (x - 0.5 - κ) / 0.15."""
    f = cx.planner_form(_box((0.5, 0.5), (0.8, 0.9)), 0.01)
    face = f.args[0]
    ch = {"x": np.array([0.7]), "y": np.array([0.7])}
    assert math.isclose(float(monitor.eval_expr(face.expr, ch, {})[0]), (0.7 - 0.51) / 0.15)


def test_heading_planner_form_is_smooth_and_zero_at_hover():
    e = cx.planner_form(nnf.normalize(comfort()), 0.0).arg.args[3].args[0].expr
    vx, vy, psi = ca.SX.sym("vx"), ca.SX.sym("vy"), ca.SX.sym("psi")
    env = cx.ExprEnv({"vx": vx, "vy": vy, "psi": psi}, {}, 10.0)
    v = cx.lower_expr(e, env)
    fn = ca.Function("h", [vx, vy, psi], [v, ca.hessian(v, ca.vertcat(vx, vy))[0]])
    val, hess = fn(0.0, 0.0, 1.0)
    eps, v0, c = cx.HEADING_EPS, cx.HEADING_V0, math.cos(math.radians(30))
    assert math.isclose(float(val), -c * eps / (v0 * (1 - c)), rel_tol=1e-6)
    # curvature cos γ/(ε v0 (1 - cos γ)) at hover, where atan2's is unbounded
    assert np.max(np.abs(np.array(hess))) < 1.01 * c / (eps * v0 * (1 - c))
    # moving along the heading: (cos 0 - cos 30°) / (1 - cos 30°) ≈ 1 at speed ≫ v0
    val, _ = fn(2.0 * math.cos(1.0), 2.0 * math.sin(1.0), 1.0)
    assert math.isclose(float(val), 1.0, rel_tol=0.01)
    # at 45° off the heading (outside ±30°): (cos 45° - cos 30°) / (1 - cos 30°) < 0
    val, _ = fn(2.0 * math.cos(1.0 + math.pi / 4), 2.0 * math.sin(1.0 + math.pi / 4), 1.0)
    assert math.isclose(float(val), (math.cos(math.pi / 4) - c) / (1 - c), rel_tol=0.01)


def test_lam_scaling_sharpens_an_operator_by_one_plus_log_n():
    """always[0, 0.3] over 4 samples at dt = 0.1 smooths with λ(1 + ln 4)."""
    grid = TimeGrid.from_horizon(0.3, 0.1)
    a = np.array([0.3, 0.1, 0.2, 0.4])
    f = Always(0, 0.3, Pred(Sig("a")))
    low = lower_robustness(f, grid, {"a": ca.SX(a.reshape(1, -1))}, {}, 10.0,
                           lift=False, lam_scaling=True)
    lam = 10.0 * (1 + math.log(4))
    want = -math.log(np.sum(np.exp(-lam * a))) / lam
    assert math.isclose(float(ca.evalf(low.root)), want, rel_tol=1e-9)
