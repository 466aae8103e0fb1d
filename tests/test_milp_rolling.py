"""Relax-and-fix along the grid (``milp.rolling``): a point it returns meets every row and is
integral; a block that finds nothing is no proof — the whole MILP decides."""

from __future__ import annotations

import numpy as np
import pytest

from stlc.backends.milp import rolling
from stlc.backends.milp.model import Milp

N = 60  # samples


def _model(visits: int, gap: int = 10):
    """A walker on a line (|x_k − x_{k−1}| ≤ 1, x_0 = 0) that must stand at x ≥ 5 at
    ``visits`` samples (binary y_k: x_k ≥ 5 − 100 (1 − y_k)), never two within ``gap``
    samples, and a score column t ≤ 1 (the model's "ρ̂", asked ≥ 0.5)."""
    m = Milp()
    x = m.vars(N, -20.0, 20.0)
    y = m.vars(N, 0.0, 1.0, integer=True)
    m.row({x[0]: 1.0}, 0.0, 0.0)
    for k in range(1, N):
        m.row({x[k]: 1.0, x[k - 1]: -1.0}, -1.0, 1.0)
    for k in range(N):
        m.row({x[k]: 1.0, y[k]: -100.0}, 5.0 - 100.0, np.inf)
    for k in range(N - gap + 1):
        m.row({y[j]: 1.0 for j in range(k, k + gap)}, -np.inf, 1.0)
    m.row({j: 1.0 for j in y}, visits, np.inf)
    top = m.var(-1.0, 1.0)
    at = {**{c: k for k, c in enumerate(x)}, **{c: k for k, c in enumerate(y)}}
    return m, x, y, top, at


def _meets(m: Milp, v: np.ndarray, tol: float = 1e-6) -> bool:
    lo, hi = np.asarray(m.lo), np.asarray(m.hi)
    if np.any(v < lo - tol) or np.any(v > hi + tol):
        return False
    ints = np.flatnonzero(m.integer)
    if np.any(np.abs(v[ints] - np.round(v[ints])) > tol):
        return False
    for coefs, rlo, rhi in m.rows:
        s = sum(c * v[j] for j, c in coefs.items())
        if s < rlo - tol or s > rhi + tol:
            return False
    return True


@pytest.fixture
def small_blocks(monkeypatch):
    monkeypatch.setattr(rolling, "MIN_BINARIES", 10)
    monkeypatch.setattr(rolling, "BLOCK_BINARIES", 8)


@pytest.mark.parametrize("best", [False, True])
def test_blocks_give_a_point_of_the_whole_model(small_blocks, best):
    m, x, y, top, at = _model(visits=3)
    phases: list = []
    res = rolling.feasible(m, top, 0.5, 30.0, at, best, phases)
    assert res.x is not None and _meets(m, res.x)
    assert res.x[top] >= 0.5 - 1e-9
    assert sum(round(res.x[j]) for j in y) >= 3  # the visits, counted independently
    assert all(res.x[x[k]] >= 5 - 1e-6 for k in range(N) if round(res.x[y[k]]) == 1)
    assert phases[-1][0].startswith("feasibility in blocks")


@pytest.mark.parametrize("best", [False, True])
def test_no_point_is_decided_by_the_whole_model(small_blocks, best):
    # at most ⌈60 / 10⌉ = 6 visits fit, and the walker needs 5 samples to reach x = 5:
    # 6 visits at gaps of 10 would need one at sample ≤ 9 … 59 — the first at 5 leaves 5
    # more (15, …, 55): 6 in all; 7 are impossible.
    m, x, y, top, at = _model(visits=7)
    phases: list = []
    res = rolling.feasible(m, top, 0.5, 30.0, at, best, phases)
    assert res.x is None
    assert phases[-1] == ("feasibility", "Infeasible", phases[-1][2])  # the whole MILP's


def test_small_models_are_searched_whole():
    best = True
    m, x, y, top, at = _model(visits=3)
    phases: list = []
    res = rolling.feasible(m, top, 0.5, 30.0, at, best, phases)
    assert res.x is not None and _meets(m, res.x)
    assert [p[0] for p in phases] == ["feasibility"]
