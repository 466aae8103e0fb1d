"""The straight segment between two samples against a box (``stlc.analysis.clearance``):
exact distance against brute force and by hand, and the corner-cut note of verification."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.analysis.clearance import box_distance, segment_box_distance
from stlc.api import loads
from stlc.planning.problem import from_mission
from stlc.planning.verify import corner_cuts

coord = st.floats(-3, 3, allow_nan=False, width=32)
point = st.tuples(coord, coord, coord)


@settings(max_examples=200, deadline=None)
@given(point, point, point, st.tuples(*[st.floats(0.0625, 2, width=32)] * 3))
def test_segment_distance_is_the_minimum_over_the_segment(p0, p1, lo, size):
    """Never above the distance of any point of the segment (dense sampling), and within
    the sampling's resolution of their minimum."""
    lo = np.array(lo, float)
    hi = lo + np.array(size, float)
    d = float(segment_box_distance(np.array([p0]), np.array([p1]), lo, hi)[0])
    s = np.linspace(0.0, 1.0, 4001)[:, None]
    pts = np.array(p0, float) + s * (np.array(p1, float) - np.array(p0, float))
    brute = box_distance(pts, lo, hi).min()
    length = float(np.linalg.norm(np.subtract(p1, p0)))
    assert d <= brute + 1e-9
    assert d >= brute - length / 4000 - 1e-9


def test_corner_cut_by_hand():
    """Unit box; both ends 0.5 m (resp. 1 m) from it.  x + y = 2 at z = 0.5 passes through
    the edge x = y = 1: distance 0; x + y = 2.5: |1 + 1 − 2.5| / √2 = 0.35355 m; a
    segment along a face at 0.2 m: 0.2; a point (degenerate segment) at (2, 2, 2): √3."""
    P0 = np.array([[1.5, 0.5, 0.5], [2.0, 0.5, 0.5], [-1, 1.2, 0.5], [2, 2, 2]])
    P1 = np.array([[0.5, 1.5, 0.5], [0.5, 2.0, 0.5], [3, 1.2, 0.5], [2, 2, 2]])
    d = segment_box_distance(P0, P1, [0, 0, 0], [1, 1, 1])
    assert d == pytest.approx([0.0, 0.5 / math.sqrt(2), 0.2, math.sqrt(3)], abs=1e-12)


TEXT = """
vehicle d1 : point_mass {
  vel_max = (3, 3, 3) m/s
  acc_max = (3, 3, 3) m/s^2
  radius = RADIUS
  start { pos = (2, 0.5, 0.5) m }
}
scenario {
  workspace = box((-3, -3, 0), (3, 3, 3)) m
  obstacle block = box((0, 0, 0), (1, 1, 1)) m
}
mission m {
  vehicles = [d1]
  horizon = 1 s
  step = 0.5 s
  require always[0, 1] (d1.pos not in block)
}
"""


@pytest.mark.parametrize("radius, flagged", [("0 m", True), ("0.3 m", False),
                                             ("0.4 m", True)])
def test_verification_notes_a_corner_cut(radius, flagged):
    """Samples (2, 0.5) → (0.5, 2) → (0.5, 3): every sample ≥ 0.5 m ≥ the radius from the
    block, the first segment passes 0.354 m from its edge (by hand, above).  With radius 0
    the corner is not cut; the samples then stay ≥ 0.5 m from the box, so no note."""
    program = loads(TEXT.replace("RADIUS", radius))
    problem = from_mission(program, program.missions["m"])
    xs, ys = [2.0, 0.5, 0.5], [0.5, 2.0, 3.0]
    ch = {"d1.pos.x": np.array(xs), "d1.pos.y": np.array(ys), "d1.pos.z": np.full(3, 0.5)}
    notes = corner_cuts(problem, ch, np.array([0.0, 0.5, 1.0]))
    if radius == "0 m":  # radius 0: only a segment that touches the block is a cut
        assert notes == []
        ch["d1.pos.x"], ch["d1.pos.y"] = np.array([1.5, 0.5, 0.5]), np.array([0.5, 1.5, 3])
        notes = corner_cuts(problem, ch, np.array([0.0, 0.5, 1.0]))
    assert bool(notes) == flagged
    if flagged:
        assert "block" in notes[0] and "t = 0 s to 0.5 s" in notes[0]
