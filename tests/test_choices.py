"""Fixed disjunction choices (``stlc.backends.nlp.choices``) against the exact monitor.

Each branch a_i of an ``or`` of predicates becomes ``a_i − (1−mix)(1−c_i)·OFF``.  By hand:
with mix = 1 the branches are as written; with mix = 0 the ``or`` is max(chosen branch,
others − OFF), which is the chosen branch (margins here are far below OFF): for the
per-sample argmax choice that is the max again, for any other one-hot choice a branch value,
never above the max — so the exact robustness of the fixed form is ≤ that of the formula,
with equality for the argmax choice.
"""

from __future__ import annotations

import numpy as np

from stlc.analysis import monitor
from stlc.backends.nlp import choices
from stlc.semantics import ir

N = 40
DT = 0.1


def pred(sig: str, c: float) -> ir.Pred:
    return ir.Pred(ir.Bin("-", ir.Sig(sig), ir.Const(c)), f"{sig} >= {c:g}")


def formula() -> ir.Formula:
    # always (x >= 1 or y >= 2 or z >= 0.5) and eventually (x >= 3 or y >= 3)
    return ir.And((ir.Always(0.0, 3.0, ir.Or((pred("x", 1), pred("y", 2), pred("z", 0.5)))),
                   ir.Eventually(0.0, 3.0, ir.Or((pred("x", 3), pred("y", 3))))))


def trace(seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {s: rng.normal(1.5, 1.0, N) for s in "xyz"}


def test_rewrites_each_disjunction_of_predicates():
    fixed, nodes = choices.choice_form(formula())
    assert [len(ex) for ex in nodes] == [3, 2]
    ors = [g for g in ir.nodes(fixed) if isinstance(g, ir.Or)]
    assert [len(g.args) for g in ors] == [3, 2]
    assert all(isinstance(a, ir.Pred) for g in ors for a in g.args)
    assert choices.signals(nodes) == [choices.MIX] + [choices.name(0, i) for i in range(3)] \
        + [choices.name(1, i) for i in range(2)]


def test_written_and_argmax_choice_equal_the_formula_other_choices_are_below():
    f = formula()
    fixed, nodes = choices.choice_form(f)
    for seed in range(20):
        ch = trace(seed)
        rho = monitor.robustness(f, DT, ch, {})
        w = monitor.robustness(fixed, DT, {**ch, **choices.written(nodes, N)}, {})
        assert np.isclose(w, rho, atol=1e-12)
        best = choices.choose(nodes, ch, {}, N)
        assert np.isclose(monitor.robustness(fixed, DT, {**ch, **best}, {}), rho, atol=1e-12)
        # any other one-hot choice: robustness never above the formula's
        rng = np.random.default_rng(100 + seed)
        other = {choices.MIX: np.zeros(N)}
        for j, ex in enumerate(nodes):
            pick = rng.integers(0, len(ex), N)
            other.update({choices.name(j, i): (pick == i).astype(float) for i in range(len(ex))})
        assert monitor.robustness(fixed, DT, {**ch, **other}, {}) <= rho + 1e-12


def test_choose_is_the_per_sample_argmax():
    _, nodes = choices.choice_form(formula())
    ch = trace(3)
    best = choices.choose(nodes, ch, {}, N)
    want = np.argmax(np.array([ch["x"] - 1, ch["y"] - 2, ch["z"] - 0.5]), axis=0)
    for i in range(3):
        np.testing.assert_array_equal(best[choices.name(0, i)], (want == i).astype(float))
    assert np.all(best[choices.MIX] == 0)


# ---- fixed windows: ``eventually`` keeps the samples the plan uses

def nested() -> ir.Formula:
    # eventually[0,2] (x >= 1 and eventually[0,1] (y >= 2 or z >= 0.5)) and
    # always[0,1] eventually[0,1] (x >= 2)
    return ir.And((
        ir.Eventually(0.0, 2.0, ir.And((pred("x", 1), ir.Eventually(
            0.0, 1.0, ir.Or((pred("y", 2), pred("z", 0.5))))))),
        ir.Always(0.0, 1.0, ir.Eventually(0.0, 1.0, pred("x", 2)))))


def test_windows_add_one_row_per_eventually():
    fixed, nodes = choices.choice_form(nested(), windows=True)
    kinds = [type(x).__name__ for x in nodes]
    assert kinds == ["Window", "Window", "tuple", "Window"]
    assert len(choices.signals(nodes)) == 1 + 1 + 1 + 2 + 1
    assert sum(isinstance(g, ir.Eventually) for g in ir.nodes(fixed)) == 3


def test_fixed_windows_keep_the_robustness_and_never_exceed_it():
    """As written (mix = 1) the robustness is the formula's; with the chosen samples it is
    the formula's too (the argmax of every window that matters is kept); with any other
    gate rows it is never above (a max over fewer samples)."""
    f = nested()
    fixed, nodes = choices.choice_form(f, windows=True)
    for seed in range(30):
        ch = trace(seed)
        rho = monitor.robustness(f, DT, ch, {})
        w = monitor.robustness(fixed, DT, {**ch, **choices.written(nodes, N)}, {})
        assert np.isclose(w, rho, atol=1e-12)
        best = choices.choose(nodes, ch, {}, N, f, DT)
        assert np.isclose(monitor.robustness(fixed, DT, {**ch, **best}, {}), rho, atol=1e-12)
        rng = np.random.default_rng(200 + seed)
        other = dict(best)
        for name in choices.signals(nodes)[1:]:
            other[name] = rng.integers(0, 2, N).astype(float)
        assert monitor.robustness(fixed, DT, {**ch, **other}, {}) <= rho + 1e-12


def test_window_choice_by_hand():
    """eventually[0,2] (x >= 1) at sample 0 keeps the one sample of 0..20 where x is
    largest; a window inside always[0,1] is kept at the best sample of each start's window."""
    x = np.zeros(N)
    x[7], x[15] = 3.0, 5.0
    ch = {"x": x, "y": np.zeros(N), "z": np.zeros(N)}
    f = ir.And((ir.Eventually(0.0, 2.0, pred("x", 1)),
                ir.Always(0.0, 0.2, ir.Eventually(0.0, 0.5, pred("x", 1)))))
    _, nodes = choices.choice_form(f, windows=True)
    best = choices.choose(nodes, ch, {}, N, f, DT)
    rows = [best[n] for n in choices.signals(nodes)[1:]]
    assert np.flatnonzero(rows[0]).tolist() == [15]
    # starts 0, 1, 2: windows 0..5, 1..6, 2..7 -> best samples 0 (all zero: the first), 1, 7
    assert np.flatnonzero(rows[1]).tolist() == [0, 1, 7]
