"""Clearance: the Euclidean distance from a vehicle's positions to the scenario's obstacles.

The report draws it per vehicle (the smallest distance to any world-frame obstacle at each
sample) with the vehicle's ``radius`` as the limit, and quotes its minimum and when.  It is
computed from the positions alone, independently of the formula (which keeps the radius
through ``pos not in R`` with R grown by it, ``stlc.semantics.check.formulas.inflated``).

**Between samples.**  The formula (and the monitor) see the samples only: a plan can pass a
box's corner between two samples that both keep the radius.  ``segment_box_distance`` is
the exact distance from the straight segment between consecutive samples to a box (the
distance to a convex set is convex along a segment, and piecewise a square root of a
quadratic between the ≤ 6 parameters where the segment crosses a face plane: the minimum
is at an end, at such a crossing, or at the stationary point of one piece).
``segment_clearance`` is its minimum over the obstacles per interval; verification notes
every vehicle whose segments come closer than its radius (``stlc.planning.verify``).

**Round obstacles** (cylinder, sphere, capsule): the distance of a point is the exact signed
distance clipped at 0 (``stlc.semantics.shapes``); along a segment it is convex too, so its
minimum is found by a golden-section search (``GOLDEN_STEPS`` steps: to 1e-12 of the
segment's length), all segments at once.
"""

from __future__ import annotations

import numpy as np

from stlc.semantics import model
from stlc.semantics.shapes import signed_distance

GOLDEN_STEPS = 60  #: 0.618^60 ≈ 3e-13


def region_distance(P: np.ndarray, box: model.Box) -> np.ndarray:
    """Euclidean distance from each row of ``P`` to a world-frame obstacle (0 inside)."""
    if box.shape is None:
        return box_distance(P, box.lo, box.hi)
    return np.maximum(signed_distance(P, box.lo, box.hi, box.shape), 0.0)


def segment_region_distance(P0: np.ndarray, P1: np.ndarray, box: model.Box) -> np.ndarray:
    """``segment_box_distance`` for any world-frame obstacle (a round one: golden section
    on the convex distance along each segment)."""
    if box.shape is None:
        return segment_box_distance(P0, P1, box.lo, box.hi)
    P0, P1 = np.atleast_2d(np.asarray(P0, float)), np.atleast_2d(np.asarray(P1, float))
    a, b = np.zeros(len(P0)), np.ones(len(P0))
    g = (np.sqrt(5.0) - 1) / 2

    def f(s):
        return region_distance(P0 + s[:, None] * (P1 - P0), box)

    for _ in range(GOLDEN_STEPS):
        c, d = b - g * (b - a), a + g * (b - a)
        left = f(c) <= f(d)
        a, b = np.where(left, a, c), np.where(left, d, b)
    return np.minimum.reduce([f((a + b) / 2), f(np.zeros(len(P0))), f(np.ones(len(P0)))])


def box_distance(P: np.ndarray, lo, hi) -> np.ndarray:
    """Euclidean distance from each row of ``P`` (n×3) to the closed box [lo, hi]
    (0 inside)."""
    gap = np.maximum(0.0, np.maximum(np.asarray(lo, float) - P, P - np.asarray(hi, float)))
    return np.linalg.norm(gap, axis=1)


def obstacle_clearance(scenario: model.Scenario, P: np.ndarray) -> np.ndarray | None:
    """Per sample, the distance to the nearest world-frame obstacle (None: no obstacle)."""
    boxes = [r.box for r in scenario.by_kind("obstacle") if r.box.frame is None]
    if not boxes or P.size == 0:
        return None
    return np.min(np.stack([region_distance(P, b) for b in boxes]), axis=0)


def segment_box_distance(P0: np.ndarray, P1: np.ndarray, lo, hi) -> np.ndarray:
    """Exact Euclidean distance from each segment [P0[i], P1[i]] (rows of two m×3 arrays)
    to the closed box [lo, hi] (0 if the segment touches or crosses it)."""
    P0, P1 = np.atleast_2d(np.asarray(P0, float)), np.atleast_2d(np.asarray(P1, float))
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    D = P1 - P0
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = np.concatenate([(lo - P0) / D, (hi - P0) / D], axis=1)  # face-plane crossings
    cross = np.where(np.isfinite(cross), np.clip(cross, 0.0, 1.0), 0.0)
    m = P0.shape[0]
    knots = np.sort(np.concatenate([np.zeros((m, 1)), cross, np.ones((m, 1))], axis=1), axis=1)
    a, b = knots[:, :-1], knots[:, 1:]
    mid = (a + b) / 2  # on each piece every axis is below, inside or above the box throughout
    Pm = P0[:, None, :] + mid[:, :, None] * D[:, None, :]
    below, above = Pm < lo, Pm > hi
    # gap_i(s) = c_i + d_i s on the piece: lo_i − p_i(s) below, p_i(s) − hi_i above, else 0
    c = np.where(below, lo - P0[:, None, :], np.where(above, P0[:, None, :] - hi, 0.0))
    d = np.where(below, -D[:, None, :], np.where(above, D[:, None, :], 0.0))
    dd = np.sum(d * d, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        star = np.where(dd > 0, -np.sum(c * d, axis=2) / dd, a)
    cand = np.concatenate([knots, np.clip(star, a, b)], axis=1)
    pts = P0[:, None, :] + cand[:, :, None] * D[:, None, :]
    gap = np.maximum(0.0, np.maximum(lo - pts, pts - hi))
    return np.min(np.linalg.norm(gap, axis=2), axis=1)


def segment_clearance(scenario: model.Scenario, P: np.ndarray) -> np.ndarray | None:
    """Per interval between consecutive samples (n−1), the exact distance of the straight
    segment to the nearest world-frame obstacle (None: no obstacle or fewer than 2 samples)."""
    boxes = [r.box for r in scenario.by_kind("obstacle") if r.box.frame is None]
    if not boxes or P.shape[0] < 2:
        return None
    return np.min(np.stack([segment_region_distance(P[:-1], P[1:], b) for b in boxes]), axis=0)
