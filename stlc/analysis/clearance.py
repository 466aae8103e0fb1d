"""Clearance: the Euclidean distance from a vehicle's positions to the scenario's obstacles.

The report draws it per vehicle (the smallest distance to any world-frame obstacle at each
sample) with the vehicle's ``radius`` as the limit, and quotes its minimum and when.  It is
computed from the positions alone, independently of the formula (which keeps the radius
through ``pos not in R`` with R grown by it, ``stlc.semantics.check.formulas.inflated``).
"""

from __future__ import annotations

import numpy as np

from stlc.semantics import model


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
    return np.min(np.stack([box_distance(P, b.lo, b.hi) for b in boxes]), axis=0)
