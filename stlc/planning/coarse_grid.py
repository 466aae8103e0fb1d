"""The coarse grid of a MILP seed: how coarse it may be, and its path on the mission grid.

``seed_factor`` is the largest factor m of the mission step such that every window of the
formula falls on the samples of the coarse grid (m·dt divides the horizon and every finite
bound of a temporal operator); ``refine`` samples a double-integrator path of the coarse
grid (piecewise-constant acceleration, exact between its samples) onto the mission grid.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.semantics import ir
from stlc.semantics.timegrid import TimeGrid

MAX_STEP_S = 0.5  #: the coarsest seed step (corner cuts between samples stay ≲ v·h/2)
MAX_SAMPLES = 61  #: a finer seed grid than this is coarsened past MAX_STEP_S if allowed
#: … but never past this: a 120 s patrol's grid went to 5 s, where the clearance that keeps
#: the path between samples out of obstacles (v·h/2 + a·h²/8) was 8 m and blocked every way
MAX_COARSE_S = 1.0
TOL = 1e-9


def bounds_of(f: ir.Formula) -> set[float]:
    """The finite bounds of the temporal operators of ``f`` (s)."""
    out: set[float] = set()
    for g in ir.nodes(f):
        for attr in ("lo", "hi"):
            v = getattr(g, attr, None)
            if isinstance(v, (int, float)) and math.isfinite(v) and not isinstance(v, bool):
                out.add(float(v))
    return out


def seed_factor(grid: TimeGrid, formula: ir.Formula, max_step: float = MAX_STEP_S,
                max_samples: int = MAX_SAMPLES) -> int:
    """The largest m such that m·dt ≤ ``max_step`` (or, when the grid would keep more than
    ``max_samples`` samples, m·dt ≤ ``MAX_COARSE_S``) divides the horizon's intervals and
    every finite bound of a temporal operator of ``formula`` on the grid."""
    dt, N = grid.dt, grid.n_intervals
    times = bounds_of(formula)

    def ok(m: int) -> bool:
        if N % m:
            return False
        h = m * dt
        return all(abs(t / h - round(t / h)) < 1e-6 for t in times)

    best = 1
    for m in range(2, N + 1):
        if not ok(m):
            continue
        if m * dt <= max_step + TOL or ((N // best) + 1 > max_samples
                                        and m * dt <= MAX_COARSE_S + TOL):
            best = m
        else:
            break
    return best


def refine(xs: np.ndarray, uu: np.ndarray, m: int, dt: float):
    """The seed path (exact between seed samples) on the mission grid."""
    kc = xs.shape[0] - 1
    n = kc * m + 1
    P, V, A = np.empty((3, n)), np.empty((3, n)), np.empty((3, n - 1))
    for j in range(n):
        k = min(j // m, kc - 1) if kc else 0
        r = j - k * m
        tau = r * dt
        a = uu[k] if kc else np.zeros(3)
        P[:, j] = xs[k, :3] + xs[k, 3:] * tau + a * tau * tau / 2
        V[:, j] = xs[k, 3:] + a * tau
        if j < n - 1:
            A[:, j] = a
    return P, V, A
