"""Vehicle ``radius``: ``pos not in R`` keeps the body's clearance.

* a planned mission (``tests/missions/pole_radius.stl``, 0.4 m body past a pole): the
  Euclidean distance from the pole box to every position in ``trajectory.csv`` is ≥ 0.4 m
  (computed here from the file, not by stlc);
* two touching boxes: a path along their shared face is 0 from both (the seam: with κ = 0
  it "satisfies" without a radius); with the radius the same path is violated by exactly
  the radius (hand-computed), and every sample inside the grown union is negative;
* Hypothesis: for random boxes, radii and points, the robustness of ``pos not in box`` is
  ≥ 0 only where the point is ≥ r from the box (Euclidean, computed independently);
* ``d.radius`` is a constant a separation spec may use (sum of radii).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.analysis import monitor
from stlc.analysis.trace import read_trace
from stlc.frontend.syntax import parse
from stlc.semantics.check import check

ROOT = Path(__file__).resolve().parent.parent
POLE = ROOT / "tests" / "missions" / "pole_radius.stl"


def box_distance(P: np.ndarray, lo, hi) -> np.ndarray:
    """Euclidean distance from each row of P to the closed box [lo, hi]."""
    gap = np.maximum(0.0, np.maximum(np.asarray(lo) - P, P - np.asarray(hi)))
    return np.linalg.norm(gap, axis=1)


def test_planned_clearance_from_trajectory_csv(tmp_path):
    out = tmp_path / "o"
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(POLE), "-o", str(out),
                        "-q"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    tr = read_trace(str(out / "trajectory.csv"))
    P = np.stack([tr.channels[f"p.pos.{a}"] for a in "xyz"], axis=1)
    assert box_distance(P, (-0.3, -0.3, 0), (0.3, 0.3, 2)).min() >= 0.4 - 1e-9


SEAM = """\
vehicle p : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (2, 2, 2) m/s^2
  RADIUS
  start { pos = (-2, 0, 1) m }
}
scenario {
  obstacle left  = box((0, -4, 0), (1, 0, 2)) m
  obstacle right = box((0, 0, 0), (1, 2.5, 2)) m
}
spec clear = always (p.pos not in left and p.pos not in right)
"""


def _program(radius: str):
    return check(parse(SEAM.replace("RADIUS", radius), "seam.stl"))


def _straight_through_seam():
    x = np.linspace(-2, 3, 51)
    return {"p.pos.x": x, "p.pos.y": np.zeros_like(x), "p.pos.z": np.ones_like(x)}


def test_touching_boxes_leave_no_seam():
    ch = _straight_through_seam()
    bare = _program("")
    # without a radius the seam is a zero-thickness gap: robustness exactly 0
    assert float(monitor.robustness(bare.specs["clear"], 0.1, ch, {})) == 0.0
    grown = _program("radius = 0.4 m")
    # with it, a point on the shared face is 0.4 m inside both grown boxes
    assert abs(float(monitor.robustness(grown.specs["clear"], 0.1, ch, {})) + 0.4) < 1e-12


@settings(max_examples=60, deadline=None)
@given(st.floats(0.05, 1.0), st.lists(st.floats(-3, 3), min_size=3, max_size=3),
       st.lists(st.floats(0.1, 2), min_size=3, max_size=3),
       st.lists(st.lists(st.floats(-5, 5), min_size=3, max_size=3), min_size=1, max_size=8))
def test_not_in_is_a_clearance(r, lo, size, pts):
    hi = [a + b for a, b in zip(lo, size)]
    src = f"""vehicle p : point_mass {{
  vel_max = (1, 1, 1) m/s
  acc_max = (1, 1, 1) m/s^2
  radius = {r!r} m
  start {{ pos = (9, 9, 9) m }}
}}
scenario {{ obstacle o = box(({lo[0]!r}, {lo[1]!r}, {lo[2]!r}), ({hi[0]!r}, {hi[1]!r}, {hi[2]!r})) m }}
spec s = p.pos not in o
"""
    prog = check(parse(src, "h.stl"))
    for p in pts:
        ch = {f"p.pos.{a}": np.array([p[i]]) for i, a in enumerate("xyz")}
        rho = float(monitor.robustness(prog.specs["s"], 0.1, ch, {}))
        if rho >= 0:
            assert box_distance(np.array([p]), lo, hi)[0] >= r - 1e-9


def test_radius_in_a_separation_spec():
    src = """vehicle a : point_mass { vel_max = (1, 1, 1) m/s; acc_max = (1, 1, 1) m/s^2
  radius = 0.4 m; start { pos = (0, 0, 1) m } }
vehicle b : point_mass { vel_max = (1, 1, 1) m/s; acc_max = (1, 1, 1) m/s^2
  radius = 0.3 m; start { pos = (2, 0, 1) m } }
spec apart = always (dist(a.pos, b.pos) >= a.radius + b.radius)
"""
    prog = check(parse(src, "sep.stl"))
    d = np.array([0.69, 0.70, 0.71])
    ch = {"a.pos.x": np.zeros(3), "a.pos.y": np.zeros(3), "a.pos.z": np.ones(3),
          "b.pos.x": d, "b.pos.y": np.zeros(3), "b.pos.z": np.ones(3)}
    assert abs(float(monitor.robustness(prog.specs["apart"], 0.1, ch, {})) + 0.01) < 1e-9
