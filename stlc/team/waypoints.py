"""Waypoint trajectories: cubic Hermite segments between knots, as fixed linear maps.

A drone's trajectory along one axis is given by its position ``p_i`` and velocity ``v_i`` at
knot times ``t_i = i·h`` (i = 0 … K−1). Between two knots it is the unique cubic with those
end values (C¹ across knots; the acceleration is linear inside a segment and may jump at a
knot). Every sampled quantity — position, velocity or acceleration at any time — is then a
*fixed* linear function of the knot vector ``[p_0 … p_{K−1}, v_0 … v_{K−1}]``: a sparse
matrix with at most four non-zeros per row, built once (``hermite_map``). The refinement
optimises the knots and reads the dense 20 Hz trajectory through these matrices.

Facts used by the refinement (all follow from the cubic form, with s = (t − t_i)/h ∈ [0, 1]):

* acceleration is linear in s, so ``|a| ≤ ā`` at both ends of every segment bounds it
  everywhere (``segment_end_acc_map``);
* velocity is quadratic with |v''| = |a_end − a_start|/h ≤ 2ā/h, so between check points δ
  apart it exceeds the larger end value by at most (2ā/h)·δ²/8 (``overshoot``);
* with ``v_i = v_{i+1} = 0`` the segment moves monotonically on the chord ``p_i → p_{i+1}``
  (a hover knot pair whose positions coincide is a hover).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def knot_times(horizon: float, knot_dt: float) -> np.ndarray:
    """Knots 0, h, …, horizon with h ≤ knot_dt chosen so that the last knot is the horizon."""
    if horizon <= 0 or knot_dt <= 0:
        raise ValueError("horizon and knot spacing must be positive")
    segments = max(1, int(np.ceil(horizon / knot_dt - 1e-9)))
    return np.linspace(0.0, horizon, segments + 1)


def locate(knots: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    h = float(knots[1] - knots[0])
    seg = np.clip(np.floor((times - knots[0]) / h + 1e-9).astype(int), 0, len(knots) - 2)
    s = np.clip((times - knots[seg]) / h, 0.0, 1.0)
    return seg, s, h


def hermite_weights(s: np.ndarray, h: float, order: int) -> tuple[np.ndarray, ...]:
    """Weights of (p_i, v_i, p_{i+1}, v_{i+1}) for the ``order``-th derivative at s."""
    if order == 0:
        return (2 * s**3 - 3 * s**2 + 1, h * (s**3 - 2 * s**2 + s),
                -2 * s**3 + 3 * s**2, h * (s**3 - s**2))
    if order == 1:
        return ((6 * s**2 - 6 * s) / h, 3 * s**2 - 4 * s + 1,
                (-6 * s**2 + 6 * s) / h, 3 * s**2 - 2 * s)
    if order == 2:
        return ((12 * s - 6) / h**2, (6 * s - 4) / h,
                (-12 * s + 6) / h**2, (6 * s - 2) / h)
    raise ValueError("order must be 0, 1 or 2")


def hermite_map(knots: np.ndarray, times: np.ndarray, order: int) -> sp.csr_matrix:
    """Sparse (len(times), 2K) map from ``[p; v]`` knot values to the derivative samples."""
    k = len(knots)
    seg, s, h = locate(knots, np.asarray(times, dtype=float))
    w = hermite_weights(s, h, order)
    rows = np.repeat(np.arange(len(seg)), 4)
    cols = np.stack([seg, k + seg, seg + 1, k + seg + 1], axis=1).ravel()
    vals = np.stack(w, axis=1).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(seg), 2 * k))


def segment_end_acc_map(knots: np.ndarray) -> sp.csr_matrix:
    """Accelerations at the start and at the end of every segment, (2(K−1), 2K)."""
    k = len(knots)
    h = float(knots[1] - knots[0])
    seg = np.arange(k - 1)
    rows, cols, vals = [], [], []
    for end, s in ((0, 0.0), (1, 1.0)):
        w = hermite_weights(np.full(k - 1, s), h, 2)
        r = 2 * seg + end
        for c, wi in zip((seg, k + seg, seg + 1, k + seg + 1), w, strict=True):
            rows.append(r)
            cols.append(c)
            vals.append(wi)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(2 * (k - 1), 2 * k))


def check_times(knots: np.ndarray, per_segment: int) -> np.ndarray:
    """``per_segment`` equally spaced points in every segment, plus the last knot."""
    h = float(knots[1] - knots[0])
    frac = np.arange(per_segment) / per_segment
    return np.concatenate([(knots[:-1, None] + h * frac[None, :]).ravel(), knots[-1:]])


def overshoot(acc_max: float, h: float, delta: float) -> tuple[float, float]:
    """Bounds on how far velocity / position can exceed their values at check points δ apart.

    Velocity is quadratic with |v''| ≤ 2ā/h, position has |p''| ≤ ā; a function with
    |f''| ≤ M that is ≤ c at two points δ apart is ≤ c + Mδ²/8 between them.
    """
    return (2 * acc_max / h) * delta**2 / 8, acc_max * delta**2 / 8


def evaluate(knots: np.ndarray, p: np.ndarray, v: np.ndarray,
             times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration (each (len(times), 3)) of knot arrays (K, 3)."""
    maps = [hermite_map(knots, times, o) for o in (0, 1, 2)]
    out = []
    for m in maps:
        out.append(np.stack([m @ np.concatenate([p[:, j], v[:, j]]) for j in range(3)],
                            axis=1))
    return out[0], out[1], out[2]
