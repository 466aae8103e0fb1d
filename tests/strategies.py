"""Hypothesis strategies for random IR formulas and traces, shared by the test modules.

* ``exprs`` / ``predicates``: scalar expressions over a few signals (and optional params),
  always defined (no log of negatives, no division by a signal);
* ``intervals(dt)``: time bounds in seconds, aligned to ``dt`` (computed as ``i * dt``, so
  float error is exercised) or not, sometimes unbounded;
* ``formulas(dt)``: random formulas with every formula node; flags switch off ``not`` /
  ``implies``, ``next``, ``until`` or temporal operators altogether;
* strategies are cached per argument tuple (building and validating a fresh strategy tree
  on every draw is slow);
* ``traces`` and ``cases``: a sampling period, channels of 1–40 samples (values on a coarse
  grid so that ties happen, or arbitrary floats) and a formula to evaluate on them.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
from hypothesis import strategies as st

from stlc.semantics import ir
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
    Until,
)

SIGNALS = ("x", "y", "z")
DTS = (0.1, 0.25, 1.0, 0.05)

consts = st.sampled_from([-2.0, -1.0, -0.5, 0.0, 0.25, 1.0, 1.5, 3.0])


@cache
def exprs(signals: tuple[str, ...] = SIGNALS, params: tuple[str, ...] = (),
          depth: int = 2) -> st.SearchStrategy[Expr]:
    """Arithmetic over signals, params and constants, defined everywhere."""
    leaves = [st.sampled_from(signals).map(ir.Sig), consts.map(Const)]
    if params:
        leaves.append(st.sampled_from(params).map(Param))
    leaf = st.one_of(*leaves)
    if depth == 0:
        return leaf
    sub = exprs(signals, params, depth - 1)
    return st.one_of(
        leaf,
        st.builds(Bin, st.sampled_from(["+", "-", "*"]), sub, sub),
        st.builds(lambda a, c: Bin("/", a, Const(c)), sub, st.sampled_from([2.0, -4.0, 0.5])),
        st.builds(lambda a: Bin("^", a, Const(2.0)), sub),
        sub.map(Neg),
        st.builds(lambda fn, a: Call(fn, (a,)), st.sampled_from(["abs", "sin", "cos"]), sub),
        sub.map(lambda a: Call("sqrt", (Call("abs", (a,)),))),
        st.builds(lambda fn, xs: Call(fn, tuple(xs)), st.sampled_from(["min", "max"]),
                  st.lists(sub, min_size=1, max_size=3)),
        st.builds(lambda fn, a, b: Call(fn, (a, b)), st.sampled_from(["atan2", "angdiff"]),
                  sub, sub),
    )


@cache
def predicates(signals: tuple[str, ...] = SIGNALS,
               params: tuple[str, ...] = ()) -> st.SearchStrategy[Pred]:
    """Mostly ``signal >= c`` / ``signal <= c`` / ``x >= y``, sometimes a general expression."""
    sig = st.sampled_from(signals).map(ir.Sig)
    simple = st.one_of(
        st.builds(lambda s, c: Pred(Bin("-", s, Const(c)), f"{s.name} >= {c}"), sig, consts),
        st.builds(lambda s, c: Pred(Bin("-", Const(c), s), f"{s.name} <= {c}"), sig, consts),
        st.builds(lambda s, t: Pred(Bin("-", s, t), f"{s.name} >= {t.name}"), sig, sig),
    )
    if params:
        simple = st.one_of(simple, st.builds(
            lambda s, p: Pred(Bin("-", s, Param(p)), f"{s.name} >= {p}"), sig,
            st.sampled_from(params)))
    return st.one_of(simple, simple, simple, exprs(signals, params).map(Pred))


@st.composite
def intervals(draw, dt: float = 0.1, max_steps: int = 8) -> tuple[float, float]:
    """``(lo, hi)`` seconds: multiples of ``dt`` (as ``i * dt``), shifted off the grid or not,
    sometimes ``hi = inf``."""
    i = draw(st.integers(0, max_steps // 2))
    j = draw(st.integers(0, max_steps))
    lo_jit = draw(st.sampled_from([0.0, 0.0, 0.0, 0.3, 0.5, -0.4]))
    hi_jit = draw(st.sampled_from([0.0, 0.0, 0.0, 0.3, 0.5, 0.999]))
    lo = max(0.0, (i + lo_jit) * dt) if i or lo_jit > 0 else 0.0
    if draw(st.integers(0, 9)) == 0:
        return lo, math.inf
    hi = max(lo, (i + j + hi_jit) * dt)
    return lo, hi


@cache
def formulas(dt: float = 0.1, signals: tuple[str, ...] = SIGNALS, params: tuple[str, ...] = (),
             depth: int = 3, negation: bool = True, next_: bool = True, until: bool = True,
             temporal: bool = True) -> st.SearchStrategy[Formula]:
    """Random formulas over ``signals``; windows from ``intervals(dt)``.

    The operator is drawn explicitly (``sampled_from``) at each level: with ``one_of`` over
    mapped sub-strategies Hypothesis overwhelmingly picks the cheap unary branches."""
    kinds = ["pred", "pred", "const", "and", "or"]
    if negation:
        kinds += ["not", "implies"]
    if temporal:
        kinds += ["always", "eventually", "always", "eventually"]
        kinds += ["until", "until"] if until else []
        kinds += ["next"] if next_ else []
    return _formula(dt, signals, params, depth, tuple(kinds))


@st.composite
def _formula(draw, dt: float, signals: tuple[str, ...], params: tuple[str, ...], depth: int,
             kinds: tuple[str, ...]) -> Formula:
    kind = draw(st.sampled_from(kinds)) if depth > 0 else draw(
        st.sampled_from(["pred"] * 5 + ["const"]))

    def sub() -> Formula:
        return draw(_formula(dt, signals, params, depth - 1, kinds))
    match kind:
        case "pred":
            return draw(predicates(signals, params))
        case "const":
            return draw(st.sampled_from([ir.TrueF(), FalseF()]))
        case "and" | "or":
            args = tuple(sub() for _ in range(draw(st.integers(2, 3))))
            return And(args) if kind == "and" else Or(args)
        case "not":
            return Not(sub())
        case "implies":
            return Implies(sub(), sub())
        case "next":
            return Next(sub())
        case "until":
            return Until(*draw(intervals(dt)), sub(), sub())
    op = Always if kind == "always" else Eventually
    return op(*draw(intervals(dt)), sub())


values = st.one_of(st.integers(-8, 8).map(lambda i: i / 4.0),
                   st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False))


@st.composite
def traces(draw, signals: tuple[str, ...] = SIGNALS, min_len: int = 1,
           max_len: int = 40) -> dict[str, np.ndarray]:
    n = draw(st.integers(min_len, max_len))
    return {s: np.array(draw(st.lists(values, min_size=n, max_size=n))) for s in signals}


@st.composite
def cases(draw, params: tuple[str, ...] = (), max_len: int = 40,
          **kw) -> tuple[Formula, float, dict[str, np.ndarray]]:
    """``(formula, dt, channels)``; keyword arguments go to ``formulas``."""
    dt = draw(st.sampled_from(DTS))
    f = draw(formulas(dt, params=params, **kw))
    return f, dt, draw(traces(max_len=max_len))
