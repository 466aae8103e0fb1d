"""The seed's timing kept (``stlc.backends.knots.windows``): each rewrite keeps one term of
a max (with a slack, a subset of its terms), so the fixed formula is never more robust than
the requirement on any trace, and on the seed's own trace it is exactly as robust (every
choice is the argmax there).  Values by hand and by the exact monitor."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.analysis import monitor
from stlc.backends.knots.windows import fix_windows
from stlc.semantics import ir
from tests.strategies import DTS, formulas, traces


def ge(sig: str, c: float) -> ir.Pred:
    return ir.Pred(ir.Bin("-", ir.Sig(sig), ir.Const(c)), f"{sig} >= {c:g}")


def rho(f, dt, ch):
    return float(monitor.robustness(f, dt, ch, {}))


def test_an_eventually_closes_on_the_seed_sample_where_its_operand_is_best():
    dt = 0.5
    x = np.array([0.0, 1.0, 3.0, 2.0, 5.0, 4.0, 0.0, 0.0])
    # always[0, 0.5] (x >= 1) at k: min(x[k], x[k+1]) = 0, 1, 2, 2, 4, 0, 0 → best at k = 4
    f = ir.Eventually(0.0, 3.0, ir.Always(0.0, 0.5, ge("x", 1.0)))
    fixed = fix_windows(f, dt, {"x": x}, {}, len(x))
    assert fixed == ir.Eventually(2.0, 2.0, ir.Always(0.0, 0.5, ge("x", 1.0)))
    assert rho(fixed, dt, {"x": x}) == rho(f, dt, {"x": x}) == 3.0
    # another trace: the fixed window only looks at samples 4–5
    y = np.array([9.0, 9.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert rho(fixed, dt, {"x": y}) == -1.0 < rho(f, dt, {"x": y}) == 8.0


def test_an_or_keeps_its_best_operand_and_an_until_its_best_sample():
    dt = 1.0
    x = np.array([2.0, 2.0, 2.0, -1.0, 2.0])
    y = np.array([-3.0, 0.0, 1.5, 9.0, 9.0])
    f = ir.And((ir.Or((ge("x", 0.0), ge("y", 0.0))), ir.Until(0.0, 4.0, ge("x", 0.0),
                                                                 ge("y", 0.0))))
    fixed = fix_windows(f, dt, {"x": x, "y": y}, {}, 5)
    # or at 0: x 2 > y −3; until: min(y[k'], min x[0..k']) = −3, 0, 1.5, −1, −1 → k' = 2
    assert fixed == ir.And((ge("x", 0.0), ir.And((ir.Eventually(2.0, 2.0, ge("y", 0.0)),
                                                   ir.Always(0.0, 2.0, ge("x", 0.0))))))
    assert rho(fixed, dt, {"x": x, "y": y}) == rho(f, dt, {"x": x, "y": y}) == 1.5


def test_nothing_needed_at_one_sample_is_nothing_fixed():
    f = ir.Always(0.0, 2.0, ir.Eventually(0.0, 1.0, ge("x", 0.0)))
    assert fix_windows(f, 1.0, {"x": np.zeros(4)}, {}, 4) is None


def test_a_node_the_seed_cannot_evaluate_is_left_as_written():
    f = ir.And((ir.Eventually(0.0, 2.0, ge("x", 0.0)), ir.Eventually(0.0, 2.0, ge("att", 0.0))))
    fixed = fix_windows(f, 1.0, {"x": np.array([0.0, 5.0, 1.0])}, {}, 3)
    assert fixed == ir.And((ir.Eventually(1.0, 1.0, ge("x", 0.0)),
                            ir.Eventually(0.0, 2.0, ge("att", 0.0))))


@st.composite
def seeded(draw):
    dt = draw(st.sampled_from(DTS))
    f = draw(formulas(dt, negation=False, next_=False))
    seed = draw(traces(min_len=2, max_len=30))
    n = len(seed["x"])
    other = {k: np.array(draw(st.lists(st.floats(-4, 4), min_size=n, max_size=n)))
             for k in seed}
    return f, dt, seed, other


@settings(max_examples=300, deadline=None)
@given(seeded())
def test_the_fixed_formula_is_never_more_robust_and_as_robust_on_the_seed(case):
    f, dt, seed, other = case
    n = len(seed["x"])
    fixed = fix_windows(f, dt, seed, {}, n)
    if fixed is None:
        return
    assert rho(fixed, dt, seed) == rho(f, dt, seed)
    assert rho(fixed, dt, other) <= rho(f, dt, other)


def test_with_slack_a_window_is_narrowed_around_the_seed_sample_not_closed():
    dt = 0.5
    x = np.array([0.0, 1.0, 3.0, 2.0, 5.0, 4.0, 0.0, 0.0])
    f = ir.Eventually(0.0, 3.0, ir.Always(0.0, 0.5, ge("x", 1.0)))
    # the seed's sample is k = 4 (offset 2 s, as above): ±1 s within [0, 3] is [1, 3]
    fixed = fix_windows(f, dt, {"x": x}, {}, len(x), slack=1.0)
    assert fixed == ir.Eventually(1.0, 3.0, ir.Always(0.0, 0.5, ge("x", 1.0)))
    # a trace best at k = 3 (offset 1.5 s): inside the narrowed window, outside the closed one
    z = np.array([0.0, 0.0, 0.0, 3.0, 3.0, 0.0, 0.0, 0.0])
    closed = fix_windows(f, dt, {"x": x}, {}, len(x))
    assert rho(fixed, dt, {"x": z}) == rho(f, dt, {"x": z}) == 2.0
    assert rho(closed, dt, {"x": z}) == -1.0


def test_with_slack_an_until_keeps_its_window_around_the_seed_sample():
    dt = 1.0
    x = np.array([2.0, 2.0, 2.0, -1.0, 2.0])
    y = np.array([-3.0, 0.0, 1.5, 9.0, 9.0])
    f = ir.Until(0.0, 4.0, ge("x", 0.0), ge("y", 0.0))
    # the seed's sample is k' = 2 (as above): the window [1, 3], the until kept
    fixed = fix_windows(f, dt, {"x": x, "y": y}, {}, 5, slack=1.0)
    assert fixed == ir.Until(1.0, 3.0, ge("x", 0.0), ge("y", 0.0))
    assert rho(fixed, dt, {"x": x, "y": y}) == rho(f, dt, {"x": x, "y": y}) == 1.5


@settings(max_examples=200, deadline=None)
@given(seeded(), st.sampled_from([0.1, 0.5, 1.0, 2.5]))
def test_a_narrowed_formula_is_never_more_robust_and_as_robust_on_the_seed(case, slack):
    f, dt, seed, other = case
    n = len(seed["x"])
    fixed = fix_windows(f, dt, seed, {}, n, slack=slack)
    if fixed is None:
        return
    assert rho(fixed, dt, seed) == rho(f, dt, seed)
    assert rho(fixed, dt, other) <= rho(f, dt, other)
