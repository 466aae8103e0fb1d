"""CasADi building blocks of the smooth-robustness backend.

Two things live here, both operating on CasADi ``SX`` *rows* (1×L matrices, one entry per
time sample, so every operation is one vectorised CasADi call instead of a Python loop):

* the **smooth aggregations** — smooth min and the two smooth maxes — in a numerically
  stable, *associative* form (``MinAlg``, ``GklAlg``, ``LseAlg``);
* the lowering of IR **expressions** (``Const``/``Sig``/``Param``/``Neg``/``Bin``/``Call``)
  to SX with derivatives that stay finite wherever the optimiser can go.

Smooth aggregations (λ > 0, operands a_1..a_m, c a per-sample shift)::

    smin(a)    = c - (1/λ) log Σ exp(-λ (a_i - c)),       c = min_i a_i
    lse-max(a) = c + (1/λ) log Σ exp( λ (a_i - c)),       c = max_i a_i
    gkl-max(a) = Σ a_i exp(λ (a_i - c)) / Σ exp(λ (a_i - c))   (Gilpin-Kurtz-Lin mean)

With c the exact min/max every exponent is ≤ 0 and one is 0, so the sums lie in [1, m]:
no overflow for any |a| and λ.  The results do not depend on c, so the derivative through
the (non-smooth) ``fmin``/``fmax`` shift cancels exactly and gradients/Hessians are those of
the unshifted formula.

Associativity.  ``smin`` and ``lse-max`` are exactly associative (combining the log-sum-exp
values of disjoint blocks gives the log-sum-exp of the union).  The GKL mean is not, so a
GKL *block* carries the pair ``(s, μ)`` = (log-sum-exp max, GKL mean) of its operands; blocks
combine as ``s = lse-max(s_b)``, ``μ = Σ_b softmax(λ s)_b μ_b`` — because the block weights
softmax(λ s)_b equal Σ_{i∈b} e^{λ a_i} / Σ_i e^{λ a_i}, this is exactly the GKL mean of the
union.  A single operand a is the block ``(a, a)``.

Safe expression functions (``stlc.analysis.smooth``, the numpy reference, currently evaluates
expressions exactly; the two agree wherever abs/sqrt/log/atan2/min/max are not used):

==============  ====================================================================
``abs(a)``      ``sqrt(a² + ABS_EPS²)``  (smooth, bias ≤ ABS_EPS)
``sqrt(a)``     ``sqrt(max(a, 0) + SQRT_EPS)``
``log(a)``      ``log(max(a, LOG_EPS))``
``atan2(y,x)``  ``atan2(y, x)`` if ``x² + y² > ATAN2_EPS`` else ``0`` (gradient 0 there)
``angdiff``     ``atan2(sin(a-b), cos(a-b))`` (never at the origin)
``min``/``max`` the smooth min / smooth max (formula ``method``) with the same λ
``a ^ b``       CasADi ``power``; use a constant exponent (derivative of a variable
                exponent contains log(a))
``a / b``       plain division: the user must keep b away from 0
``sd_*``        signed distances, exact outside (``smooth_geometry``)
==============  ====================================================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import reduce

import casadi as ca
import numpy as np

from stlc.backends.nlp.smooth_geometry import SD_CASADI
from stlc.semantics import ir

#: stand-in for ±inf (true/false, empty windows, ``next`` past the end of the trace)
BIG = 1e3
ABS_EPS = 1e-4
SQRT_EPS = 1e-12
LOG_EPS = 1e-12
ATAN2_EPS = 1e-24

Num = ca.SX | float
Val = tuple[ca.SX, ...]


class LoweringError(Exception):
    """The formula or expression cannot be lowered (unknown name, not normalised, …)."""


# --------------------------------------------------------------------------- aggregations


def _sum(xs: Sequence[Num]) -> Num:
    return reduce(lambda p, q: p + q, xs)


def smin(xs: Sequence[Num], lam: Num) -> Num:
    """Stable smooth min ``-(1/λ) log Σ exp(-λ a_i)`` (elementwise over rows)."""
    if len(xs) == 1:
        return xs[0]
    c = reduce(ca.fmin, xs)
    return c - ca.log(_sum([ca.exp(-lam * (x - c)) for x in xs])) / lam


def lse_max(xs: Sequence[Num], lam: Num) -> Num:
    """Stable log-sum-exp max ``(1/λ) log Σ exp(λ a_i)`` (an over-approximation of max)."""
    if len(xs) == 1:
        return xs[0]
    c = reduce(ca.fmax, xs)
    return c + ca.log(_sum([ca.exp(lam * (x - c)) for x in xs])) / lam


def gkl_combine(blocks: Sequence[tuple[Num, Num]], lam: Num) -> tuple[Num, Num]:
    """Combine GKL blocks ``(s, μ)`` into the block of their union (see module docstring)."""
    if len(blocks) == 1:
        return blocks[0]
    c = reduce(ca.fmax, [s for s, _ in blocks])
    w = [ca.exp(lam * (s - c)) for s, _ in blocks]
    z = _sum(w)
    return c + ca.log(z) / lam, _sum([wi * mu for wi, (_, mu) in zip(w, blocks)]) / z


def gkl_max(xs: Sequence[Num], lam: Num) -> Num:
    """Stable GKL smooth max ``Σ a_i e^{λ a_i} / Σ e^{λ a_i}`` (a weighted mean ≤ max)."""
    return gkl_combine([(x, x) for x in xs], lam)[1]


class Alg:
    """A smooth aggregation over *blocks*: tuples of SX rows (``Val``), combinable
    associatively.  ``kinds`` says, per component, how a lifted copy is constrained:
    ``"ineq"`` (hypograph ``expr - r >= 0``) or ``"eq"`` (``expr - r == 0``)."""

    kinds: tuple[str, ...] = ("ineq",)
    empty: float = BIG
    #: nondecreasing in every operand (so an operand may be lifted by a hypograph)
    monotone: bool = True

    def leaf(self, a: ca.SX) -> Val:
        return (a,)

    def combine(self, vals: Sequence[Val], lam: Num) -> Val:
        raise NotImplementedError

    def value(self, v: Val) -> ca.SX:
        return v[-1]


class MinAlg(Alg):
    empty = BIG

    def combine(self, vals: Sequence[Val], lam: Num) -> Val:
        return (smin([v[0] for v in vals], lam),)


class LseAlg(Alg):
    empty = -BIG

    def combine(self, vals: Sequence[Val], lam: Num) -> Val:
        return (lse_max([v[0] for v in vals], lam),)


class GklAlg(Alg):
    """Blocks are ``(s, μ)``.  The GKL mean is not monotone in its operands (raising a low
    operand raises its weight), so a lifted ``s`` must be exact; given the ``s``, the
    combined mean is increasing in each block's ``μ``, which may therefore sit below its
    value."""

    kinds = ("eq", "ineq")
    empty = -BIG
    monotone = False

    def leaf(self, a: ca.SX) -> Val:
        return (a, a)

    def combine(self, vals: Sequence[Val], lam: Num) -> Val:
        return gkl_combine([(v[0], v[1]) for v in vals], lam)


MAX_ALGS: dict[str, type[Alg]] = {"gkl": GklAlg, "lse": LseAlg}


def max_alg(method: str) -> Alg:
    try:
        return MAX_ALGS[method]()
    except KeyError:
        raise LoweringError(f"unknown smooth max method {method!r} (use 'gkl' or 'lse')") from None


# --------------------------------------------------------------------------- expressions


@dataclass
class ExprEnv:
    """What expressions are evaluated against: full-length channel rows (1×n), parameters,
    λ and the smooth max to use for ``max(...)``.  ``memo`` shares sub-expressions."""

    channels: Mapping[str, ca.SX]
    params: Mapping[str, Num]
    lam: Num
    method: str = "gkl"
    memo: dict[ir.Expr, Num] = field(default_factory=dict)


def lower_expr(e: ir.Expr, env: ExprEnv) -> Num:
    """Lower an IR expression to an SX row over all n samples (or a scalar if constant)."""
    hit = env.memo.get(e)
    if hit is not None:
        return hit
    fn = EXPR_LOWER.get(type(e))
    if fn is None:
        raise LoweringError(f"not an expression node: {e!r}")
    out = fn(e, env)
    env.memo[e] = out
    return out


def _sig(e: ir.Sig, env: ExprEnv) -> Num:
    try:
        return env.channels[e.name]
    except KeyError:
        raise LoweringError(f"no channel for signal {e.name!r}") from None


def _param(e: ir.Param, env: ExprEnv) -> Num:
    try:
        return env.params[e.name]
    except KeyError:
        raise LoweringError(f"no value for parameter {e.name!r}") from None


BIN_OPS: dict[str, Callable[[Num, Num], Num]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": lambda a, b: a / b,
    "^": lambda a, b: a**b,
}


def _bin(e: ir.Bin, env: ExprEnv) -> Num:
    op = BIN_OPS.get(e.op)
    if op is None:
        raise LoweringError(f"unknown binary operator {e.op!r}")
    return op(lower_expr(e.left, env), lower_expr(e.right, env))


def _safe_atan2(y: Num, x: Num) -> Num:
    return ca.if_else(x * x + y * y > ATAN2_EPS, ca.atan2(y, x), 0.0)


CALLS: dict[str, Callable[[list[Num], ExprEnv], Num]] = {
    "abs": lambda a, env: ca.sqrt(a[0] * a[0] + ABS_EPS**2),
    "sqrt": lambda a, env: ca.sqrt(ca.fmax(a[0], 0.0) + SQRT_EPS),
    "sin": lambda a, env: ca.sin(a[0]),
    "cos": lambda a, env: ca.cos(a[0]),
    "exp": lambda a, env: ca.exp(a[0]),
    "log": lambda a, env: ca.log(ca.fmax(a[0], LOG_EPS)),
    "min": lambda a, env: smin(a, env.lam),
    "max": lambda a, env: (gkl_max if env.method == "gkl" else lse_max)(a, env.lam),
    "atan2": lambda a, env: _safe_atan2(a[0], a[1]),
    "angdiff": lambda a, env: ca.atan2(ca.sin(a[0] - a[1]), ca.cos(a[0] - a[1])),
}
CALLS.update(SD_CASADI)  # signed distances to boxes and round regions (``smooth_geometry``)
_ARITY = {"atan2": 2, "angdiff": 2, "sd_box": 6, "sd_cylinder": 5, "sd_capsule": 5}


def _call(e: ir.Call, env: ExprEnv) -> Num:
    fn = CALLS.get(e.fn)
    if fn is None:
        raise LoweringError(f"unknown function {e.fn!r}")
    want = _ARITY.get(e.fn, 1 if e.fn in ir.CALLS_1 else None)
    if (want is not None and len(e.args) != want) or not e.args:
        raise LoweringError(f"{e.fn} takes {want or 'at least 1'} argument(s), got {len(e.args)}")
    return fn([lower_expr(a, env) for a in e.args], env)


EXPR_LOWER: dict[type, Callable[..., Num]] = {
    ir.Const: lambda e, env: float(e.value),
    ir.Sig: _sig,
    ir.Param: _param,
    ir.Neg: lambda e, env: -lower_expr(e.arg, env),
    ir.Bin: _bin,
    ir.Call: _call,
}


# --------------------------------------------------------------------------- planner form
# The planner optimises ``P_κ(f)``: every predicate margin m is replaced by a smooth margin
# m' with sign(m') = sign(m - κ) (``planner_expr``), divided by a scale s > 0 (``_scales``).
# Robustness in NNF is a min/max tree over predicate values, so its sign depends only on
# the signs of the predicates: ρ(P_κ(f)) > 0  ⟺  ρ(f) > κ, and the (sound) smooth
# robustness ρ̃(P_κ(f)) > 0 certifies ρ(f) > κ for the formula as the user wrote it.

#: speed (m/s) below which the heading predicate's planner form fades to 0 (hover)
HEADING_V0 = 0.1
#: ε (m/s) in ‖v‖_ε = √(‖v‖² + ε²): bounds the curvature at hover (cos γ/ε) and makes the
#: planner form conservative (it asks cos Δ ≥ cos γ·‖v‖_ε/‖v‖, ≈ 0.5 % stricter at 0.1 m/s)
HEADING_EPS = 1e-2
#: divide each planner margin by its scale (box half-width, bound); else keep user units
SCALE_MARGINS = True


def _shift(e: ir.Expr, k: float) -> ir.Expr:
    """``e - k`` with k folded into a constant side of ``e``."""
    if k == 0:
        return e
    if isinstance(e, ir.Bin) and e.op == "-":
        if isinstance(e.left, ir.Const):
            return ir.Bin("-", ir.Const(e.left.value - k), e.right)
        if isinstance(e.right, ir.Const):
            return ir.Bin("-", e.left, ir.Const(e.right.value + k))
    return ir.Bin("-", e, ir.Const(k))


def _sqrt_bound(e: ir.Expr) -> tuple[ir.Expr, float] | None:
    """``c - sqrt(a)`` → ``(c² - a) / (c + sqrt(a + δ²))`` and ``sqrt(a) - c`` →
    ``(a - c²) / (c + sqrt(a + δ²))``, δ = c/10 (c > 0): the same sign, the same value up to
    δ near the bound, no infinite curvature at a = 0 (a speed at hover)."""
    if not (isinstance(e, ir.Bin) and e.op == "-"):
        return None
    for root, const, sign in ((e.right, e.left, -1.0), (e.left, e.right, 1.0)):
        if (isinstance(root, ir.Call) and root.fn == "sqrt" and isinstance(const, ir.Const)
                and const.value > 0):
            c = float(const.value)
            a = root.args[0]
            diff = ir.Bin("-", a, ir.Const(c * c)) if sign > 0 else ir.Bin("-", ir.Const(c * c), a)
            den = ir.Bin("+", ir.Const(c), ir.Call("sqrt", (ir.Bin("+", a, ir.Const(
                (c / 10) ** 2)),)))
            return ir.Bin("/", diff, den), c
    return None


def _heading_bound(e: ir.Expr) -> tuple[ir.Expr, float] | None:
    """``γ - abs(angdiff(ψ, atan2(y, x)))`` → ``(cos ψ·x + sin ψ·y - cos γ·‖v‖_ε) / ‖v‖₀``
    with v = (x, y), ‖v‖_ε = √(‖v‖² + ε²), ‖v‖₀ = √(‖v‖² + v0²): the angle between the
    heading vector and v is ≤ γ iff the projection is ≥ cos γ·‖v‖, so this is positive
    only where the predicate holds (conservative by ε), smooth with bounded curvature at
    hover instead of atan2's singularity, and ≈ cos Δ - cos γ when moving.  Scale 1 - cos γ
    (so that flying straight along the heading has margin ≈ 1)."""
    if not (isinstance(e, ir.Bin) and e.op == "-" and isinstance(e.left, ir.Const)):
        return None
    g, ab = float(e.left.value), e.right
    if not (0.0 < g < np.pi and isinstance(ab, ir.Call) and ab.fn == "abs"
            and isinstance(ab.args[0], ir.Call) and ab.args[0].fn == "angdiff"):
        return None
    a, b = ab.args[0].args
    if isinstance(a, ir.Call) and a.fn == "atan2":
        a, b = b, a
    if not (isinstance(b, ir.Call) and b.fn == "atan2"):
        return None
    y, x = b.args
    dot = ir.Bin("+", ir.Bin("*", ir.Call("cos", (a,)), x), ir.Bin("*", ir.Call("sin", (a,)), y))
    sq = ir.Bin("+", ir.Bin("*", x, x), ir.Bin("*", y, y))
    num = ir.Bin("-", dot, ir.Bin("*", ir.Const(float(np.cos(g))), ir.Call("sqrt", (
        ir.Bin("+", sq, ir.Const(HEADING_EPS**2)),))))
    den = ir.Call("sqrt", (ir.Bin("+", sq, ir.Const(HEADING_V0**2)),))
    return ir.Bin("/", num, den), float(1.0 - np.cos(g))


def planner_expr(e: ir.Expr, kappa: float = 0.0) -> tuple[ir.Expr, float | None]:
    """The margin the planner optimises for the predicate ``e >= κ`` (same sign as e - κ)
    and its natural scale (None: unknown)."""
    if isinstance(e, ir.Neg):
        inner, s = planner_expr(e.arg, -kappa)
        return ir.Neg(inner), s
    e = _shift(e, kappa)
    for rule in (_heading_bound, _sqrt_bound):
        out = rule(e)
        if out is not None:
            return out
    return e, None


def _pair_width(a: ir.Expr, b: ir.Expr, params: Mapping[str, float]) -> float | None:
    """w if ``a + b`` is the constant w > 0 for any signal values (a box's two faces)."""
    from stlc.analysis import monitor

    sigs = sorted({leaf.name for x in (a, b) for leaf in ir.expr_leaves(x)
                   if isinstance(leaf, ir.Sig)})
    rng = np.random.default_rng(0)
    ch = {s: rng.normal(0.0, 3.0, 3) for s in sigs}
    try:
        tot = np.asarray(monitor.eval_expr(a, ch, params) + monitor.eval_expr(b, ch, params))
    except Exception:  # noqa: BLE001 - anything unevaluable simply has no pair scale
        return None
    w = float(np.ravel(tot)[0])
    # to 12 digits: a box in a human's frame has the same scale for every pose (one build)
    return float(f"{abs(w):.12g}") if np.allclose(tot, w, rtol=1e-9, atol=1e-12) \
        and abs(w) > 1e-9 else None


def _scales(f: ir.Formula, params: Mapping[str, float], out: dict) -> None:
    """Half the width of a box (two predicates of one and/or summing to a constant)."""
    if isinstance(f, ir.And | ir.Or):
        preds = [a for a in f.args if isinstance(a, ir.Pred)]
        for i, p in enumerate(preds):
            for q in preds[i + 1:]:
                if p not in out and q not in out:
                    w = _pair_width(p.expr, q.expr, params)
                    if w is not None:
                        out[p] = out[q] = w / 2
    for c in ir.children(f):
        _scales(c, params, out)


def planner_form(f: ir.Formula, kappa: float = 0.0,
                 params: Mapping[str, float] | None = None) -> ir.Formula:
    """``P_κ(f)`` (NNF): each predicate m ≥ 0 becomes (planner_expr of m - κ) / s with s the
    half-width of its box, else the bound's own scale (``planner_expr``), else 1."""
    box: dict = {}
    _scales(f, params or {}, box)

    def go(g: ir.Formula) -> ir.Formula:
        match g:
            case ir.Pred(expr, label, span):
                new, s = planner_expr(expr, kappa)
                s = (box.get(g, s) or 1.0) if SCALE_MARGINS else 1.0
                return ir.Pred(new if s == 1.0 else ir.Bin("/", new, ir.Const(s)), label, span)
        return ir.map_children(g, go)

    return go(f)
