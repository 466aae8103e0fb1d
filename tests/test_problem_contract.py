"""The planning problem is load-bearing (issue 18): a backend plans the ``PlanningProblem``
it is handed — its requirement, threshold, objective, start states — never the mission as
written.  A problem derived with ``dataclasses.replace`` (a replanning window, a seed, a
sweep instance) must be planned as it says; the exact monitor judges the plans here."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from stlc.analysis import monitor
from stlc.backends.nlp import cache as nlp_cache
from stlc.backends.nlp import schedule
from stlc.backends.base import run_chain
from stlc.backends.nlp.backend import CasadiNlp, KinematicGuess
from stlc.pipeline import load
from stlc.planning.problem import from_mission
from stlc.semantics import nnf

SOURCE = """\
vehicle d1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
spec east = eventually[2, 4] (d1.pos.x >= 1 m)
spec west = eventually[2, 4] (d1.pos.x <= -1 m)
mission m {
  vehicles = [d1]
  horizon = 4 s
  step = 0.25 s
  require east
  maximize robustness
  threshold = 0.05
}
"""


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    path: Path = tmp_path_factory.mktemp("contract") / "m.stl"
    path.write_text(SOURCE, encoding="utf-8")
    program = load(str(path)).program
    return program, from_mission(program, program.missions["m"])


def _x(sol) -> np.ndarray:
    return np.asarray(sol.channels["d1.pos.x"])


def test_nlp_plans_the_problems_requirement_not_the_missions(loaded):
    """The mission requires `east`; the problem says `west` with κ = 0.3.  The NLP chain's
    plan satisfies `west` by κ (exact monitor) and so violates `east`."""
    program, problem = loaded
    west = nnf.normalize(program.specs["west"])
    other = replace(problem, requirement=west, threshold=0.3)
    sol, _ = run_chain(other, [KinematicGuess(), CasadiNlp()])
    dt = problem.grid.dt
    rho_west = monitor.robustness(west, dt, sol.channels, program.params)
    rho_east = monitor.robustness(nnf.normalize(program.specs["east"]), dt, sol.channels,
                                  program.params)
    assert rho_west >= 0.3 - 1e-6
    assert rho_east < 0
    assert sol.smoothing["threshold"] == 0.3
    # the flight goes west: its most western sample is beyond −1 m
    assert _x(sol).min() <= -1.0


def test_guess_reads_the_problem(loaded):
    """The kinematic guess restricts the problem's requirement (here `west`) and starts from
    the problem's start state (here x = 0.5 m, not the declared 0)."""
    program, problem = loaded
    west = nnf.normalize(program.specs["west"])
    x0 = np.array([0.5, 0.0, 1.0, 0.0, 0.0, 0.0])
    other = replace(problem, requirement=west, start_states={"d1": x0})
    P, V, _ = schedule.kinematic_guess(other)["d1"]
    assert np.allclose(P[:, 0], x0[:3]) and np.allclose(V[:, 0], 0.0)
    assert P[0].min() < -0.5  # heads west for `west`


def test_start_state_and_threshold_reach_the_built_nlp(loaded):
    """``start_states`` is the first sample's bounds; κ is part of the structure key (the
    planner form depends on it), the start state is not (it is bound per instance)."""
    program, problem = loaded
    x0 = np.array([-0.5, 0.2, 1.0, 0.0, 0.0, 0.0])
    moved = replace(problem, start_states={"d1": x0})
    assert nlp_cache.structure_key(moved) == nlp_cache.structure_key(problem)
    assert nlp_cache.structure_key(replace(problem, threshold=0.3)) != \
        nlp_cache.structure_key(problem)
    prob, inv, _ = nlp_cache.lowered(moved)
    L = inv.layouts[0]
    first = slice(L.x_slice.start, L.x_slice.start + L.nx)
    assert np.allclose(prob.lbx[first], x0) and np.allclose(prob.ubx[first], x0)
    nlp_cache.lowered(problem)  # the declared start is bound back on the shared build
    assert np.allclose(prob.lbx[first], [0, 0, 1, 0, 0, 0])


def test_nlp_plans_from_the_problems_start_state(loaded):
    """A plan of a problem with another start state begins there and still satisfies the
    requirement (exact monitor)."""
    program, problem = loaded
    x0 = np.array([-0.5, 0.0, 1.0, 0.0, 0.0, 0.0])
    moved = replace(problem, start_states={"d1": x0})
    sol, _ = run_chain(moved, [KinematicGuess(), CasadiNlp()])
    assert np.isclose(_x(sol)[0], -0.5)
    rho = monitor.robustness(problem.requirement, problem.grid.dt, sol.channels,
                             program.params)
    assert rho >= problem.threshold - 1e-6


def test_a_windowed_problem_is_refused_by_a_whole_horizon_backend(loaded):
    """``window`` is read: the full NLP plans the whole horizon and says so (STL401) before
    any work; the segment backend declares that it plans windows."""
    from stlc.backends.replan.segment import SegmentBackend

    _, problem = loaded
    diags = CasadiNlp().accepts(replace(problem, window=(1.0, 2.0)))
    assert [d.code for d in diags] == ["STL401"] and "window" in diags[0].message
    assert CasadiNlp().accepts(problem) == []
    assert SegmentBackend.capabilities.windows
