"""Grouped derivatives (``derivatives.row_groups``, ``lagrangian_hessian``, ``rows_jacobian``).

Rows of a constraint vector that compute one function of different entries are grouped and
differentiated once; the values must equal CasADi's own derivatives of the whole vector, and
rows that differ anywhere — a constant in its 13th digit, a parameter read — must not be
grouped.  (The NLP's own derivatives against nlpsol's: ``test_derivatives``.)
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.backends.nlp import derivatives


def _rows():
    w, p = ca.SX.sym("w", 8), ca.SX.sym("p", 3)
    g = ca.vertcat(
        ca.exp(0.1 * w[0]) * w[1] + p[0],  # } one group: the same function of
        ca.exp(0.1 * w[2]) * w[3] + p[1],  # } (w_i, w_j, p_k)
        ca.exp(0.1 * w[1]) * w[0] + p[2],  # } (same function, entries in another order)
        ca.exp(0.1000000000001 * w[4]) * w[5] + p[0],  # a constant differs at 1e-13
        ca.exp(0.1 * w[6]) * w[7] + 2 * p[0],  # reads p differently
        ca.log(1 + w[0] ** 2 + w[3] ** 2) - w[7],  # } a second group, overlapping
        ca.log(1 + w[2] ** 2 + w[5] ** 2) - w[7],  # } entries of the first
        w[6] - w[7],  # linear: no Hessian
    )
    return w, p, g


def test_groups_are_exactly_the_rows_alike():
    w, p, g = _rows()
    groups, singles = derivatives.row_groups(w, p, g)
    got = sorted(sorted(rows.tolist()) for rows, _, _ in groups)
    assert got == [[0, 1], [5, 6]]
    assert sorted(singles) == [2, 3, 4, 7]
    for rows, W, P in groups:  # each member is the template of its own entries
        z, q, e = derivatives._template(g, w, p, int(rows[0]), W[0], P[0])
        for j, wj, pj in zip(rows, W, P):
            back = ca.substitute(e, ca.vertcat(z, q), ca.vertcat(w[wj.tolist()],
                                                                   p[pj.tolist()]))
            assert ca.is_equal(back, g[int(j)], 20)


def test_names_not_unique_make_every_row_single():
    a, b = ca.SX.sym("a"), ca.SX.sym("a")
    w, p = ca.vertcat(a, b), ca.SX.sym("p", 0)
    groups, singles = derivatives.row_groups(w, p, ca.vertcat(ca.sin(a), ca.sin(b)))
    assert groups == [] and singles == [0, 1]


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_grouped_derivatives_equal_casadis(seed):
    w, p, g = _rows()
    f = ca.sumsqr(w[:4]) * p[1] + ca.sin(w[7])
    x, pm = ca.MX.sym("x", w.numel()), ca.MX.sym("pm", p.numel())
    lf, lg = ca.MX.sym("lf"), ca.MX.sym("lg", g.numel())
    ours = ca.Function("h", [x, pm, lf, lg],
                       [derivatives.lagrangian_hessian(w, p, f, g, x, pm, lf, lg),
                        derivatives.rows_jacobian(w, p, g, x, pm)])
    sl, sg = ca.SX.sym("sl"), ca.SX.sym("sg", g.numel())
    ref = ca.Function("r", [w, p, sl, sg],
                      [ca.triu(ca.hessian(sl * f + ca.dot(sg, g), w)[0]), ca.jacobian(g, w)])
    rng = np.random.default_rng(seed)
    args = (rng.normal(size=w.numel()), rng.normal(size=p.numel()), rng.uniform(0.5, 2),
            rng.normal(size=g.numel()))
    (h1, j1), (h2, j2) = ours(*args), ref(*args)
    assert np.allclose(np.asarray(ca.densify(h1)), np.asarray(ca.densify(h2)),
                       rtol=1e-12, atol=1e-12)
    assert np.allclose(np.asarray(ca.densify(j1)), np.asarray(ca.densify(j2)),
                       rtol=1e-12, atol=1e-12)
