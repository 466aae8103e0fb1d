"""The notebook-style tour (``examples/notebook_tour.py``) runs in the suite: it compiles,
looks at the plan, simulates a push, sweeps a start position and plots from Python, and
renders the plan's HTML the way Jupyter does (``_repr_html_``).  Its results are checked
against the exact monitor and the spec file's numbers."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

import stlc

TOUR = Path(__file__).resolve().parents[1] / "examples" / "notebook_tour.py"


@pytest.fixture(scope="module")
def tour():
    return runpy.run_path(str(TOUR), run_name="tour")["RESULTS"]


def test_the_tour_compiles_a_verified_plan(tour):
    plan = tour["plan"]
    assert plan.status == "satisfied"
    assert plan.robustness == pytest.approx(
        stlc.monitor(plan.program, plan.trajectory)["reach_avoid"], abs=1e-9)
    assert np.array_equal(tour["robot"].pos[:, 2], plan.trajectory["robot.pos.z"])
    assert tour["table"].shape == (16, 1 + len(plan.solution.channels))


def test_the_tour_plots_and_renders_html(tour):
    scene, speed = tour["scene"], tour["speed"]
    assert scene.layout.title.text == "3D view" and any(t.type == "mesh3d" for t in scene.data)
    vel = tour["robot"].vel
    assert list(speed.data[0].y) == pytest.approx(np.linalg.norm(vel, axis=1), rel=1e-4,
                                                  abs=1e-6)
    html = tour["html"]
    assert "reach_avoid" in html and "κ = 0.1" in html and "<table>" in html
    # what IPython calls for a displayed object
    assert getattr(tour["plan"], "_repr_html_")() == html


def test_the_tour_simulates_and_sweeps(tour):
    flight = tour["flight"]
    assert [e["time"] for e in flight.events if e["triggered"]] == [4.0]
    assert flight.robustness["mission"] == pytest.approx(
        stlc.monitor(flight.plan.program, flight.executed)["reach_avoid"], abs=1e-9)
    rows = tour["rows"]
    assert list(rows["robot.start.pos.x"]) == [100.0, 150.0]
    assert all(rows["status"] == "satisfied")
