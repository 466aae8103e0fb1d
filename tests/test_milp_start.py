"""The coarse-grid start of the exact MILP (``milp_start``): on a fine grid the `milp` chain
first solves the mission on the coarse seed grid, and the exact backend starts HiGHS from
that path, repaired on its own grid.  The start only changes where the search begins: the
result is still judged by the exact monitor, and a small grid gets no start."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from stlc import pipeline, vehicles
from stlc.analysis import monitor
from stlc.backends.milp.backend import ExactMilp
from stlc.backends.milp.start import CoarseStart
from stlc.planning.problem import from_mission

BENCH = Path(__file__).parent.parent / "specs" / "benchmarks" / "reach_avoid.stl"


def _program(tmp_path, step: str):
    """stlpy's ReachAvoid at a finer step (the formula's bounds are whole seconds)."""
    src = re.sub(r"step = 1 s", f"step = {step} s", BENCH.read_text())
    f = tmp_path / "ra.stl"
    f.write_text(src)
    program = pipeline.load(str(f)).program
    return program, next(iter(program.missions.values()))


def test_the_start_is_a_point_of_the_fine_milp_whose_robustness_the_monitor_confirms(tmp_path):
    program, mission = _program(tmp_path, "0.1")  # 151 samples
    problem = from_mission(program, mission)
    cs = CoarseStart()
    raw = cs.solve(None, problem)
    seed = cs.invert(raw, None, problem)
    assert raw[1]["step_s"] == 0.5 and seed.channels  # the coarse grid: 0.5 s, 31 samples
    em = ExactMilp()
    low, _ = em.lower(problem)
    em.phases = []
    start = em._seed_start(low, problem.with_seed(seed), 30.0)
    assert start is not None
    names = [p[0] for p in em.phases]
    assert names[0] == "coarse start (its path)"
    assert set(names[1:]) == {"coarse start (choices fixed)"} and len(names) <= 4
    # the point's ρ̂ is the exact robustness of the trajectory it encodes
    (lv,) = low.vehicles
    xs, _ = lv.simulate(start.x)
    ch = {c: xs[:, i] for i, c in enumerate(lv.states)}
    v = problem.vehicles()[0]
    ch.update(vehicles.model_of(v).derived_channels(v, vehicles.state_matrix(v, ch)))
    rho = float(monitor.robustness(problem.requirement, problem.grid.dt, ch, problem.params))
    assert abs(rho - start.x[low.top]) < 1e-6
    assert rho >= problem.threshold


def test_the_milp_chain_plans_a_fine_grid_from_the_coarse_start(tmp_path):
    program, mission = _program(tmp_path, "0.1")
    _, sol = pipeline.plan(program, mission)
    chain = sol.solver["chain"]
    assert chain["name"] == "milp" and "fallback_from" not in chain
    assert [s["backend"] for s in chain["stages"]] == ["coarse MILP start", "exact MILP (HiGHS)"]
    assert any(p["phase"].startswith("coarse start") for p in sol.solver["phases"])
    assert sol.status == "satisfied" and sol.robustness_exact >= mission.threshold
    # ReachAvoid's optimum is 0.5 on the 1 s grid (by hand); a finer grid cannot do better
    assert sol.robustness_exact <= 0.5 + 1e-6
    if sol.solver["converged"]:
        assert np.isclose(sol.robustness_exact, sol.solver["objective"], atol=1e-6)


def test_a_small_grid_gets_no_start(tmp_path):
    program, mission = _program(tmp_path, "1")  # 16 samples
    problem = from_mission(program, mission)
    paths, rec = CoarseStart().solve(None, problem)
    assert paths is None and rec["status"].startswith("not needed")
    _, sol = pipeline.plan(program, mission)
    assert not any(p["phase"].startswith("coarse start") for p in sol.solver["phases"])
    assert np.isclose(sol.robustness_exact, 0.5, atol=1e-6)


_RA = {}


def _ra_milp():
    """ReachAvoid at its own 1 s step, built once: (problem, lowered MILP); without the
    holdable end's rows, so that any trajectory is a point."""
    if not _RA:
        program = pipeline.load(str(BENCH)).program
        problem = replace(from_mission(program, next(iter(program.missions.values()))),
                          hold_end=False)
        _RA["v"] = (problem, ExactMilp().lower(problem)[0])
    return _RA["v"]


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-0.12, 0.12), min_size=45, max_size=45))
def test_complete_gives_every_term_its_exact_robustness_and_a_feasible_point(u):
    """``Encoder.complete`` on any trajectory: the requirement's term equals the exact
    monitor's robustness, and the point satisfies every row of the MILP."""
    problem, low = _ra_milp()
    (lv,) = low.vehicles
    x = np.zeros(low.milp.n_cols)
    x[lv.u] = np.asarray(u).reshape(15, 3) * [1.0, 1.0, 0.1]  # z: the box is 2 m tall
    x[lv.x[0]] = np.asarray(low.milp.lo)[lv.x[0]]
    xs, _ = lv.simulate(x)
    x[lv.x] = xs
    low.encoder.complete(x)
    ch = {c: xs[:, i] for i, c in enumerate(lv.states)}
    rho = float(monitor.robustness(problem.requirement, problem.grid.dt, ch, problem.params))
    term = low.encoder.value(low.terms["requirement"], x)
    x[low.top] = term
    box = low.box or {}
    inside = all(box[c][0] <= xs[k, i] <= box[c][1] for i, c in enumerate(lv.states)
                 if c in box for k in range(len(xs)))
    assume(inside)  # the MILP's columns live in the invariant box (ExactMilp.lower)
    assert abs(term - rho) < 1e-9
    a = low.milp.matrix()
    ax = a @ x
    rlo = np.array([r[1] for r in low.milp.rows])
    rhi = np.array([r[2] for r in low.milp.rows])
    assert np.all(ax >= rlo - 1e-7) and np.all(ax <= rhi + 1e-7)
    lo, hi = np.asarray(low.milp.lo), np.asarray(low.milp.hi)
    assert np.all(x >= lo - 1e-7) and np.all(x <= hi + 1e-7)


def test_the_coarse_start_keeps_clear_of_regions_by_the_step_s_clearance(tmp_path):
    """The coarse MILP inflates every region the formula keeps the vehicle out of by the
    distance a path can stray from the nearer sample: v·h/2 + a·h²/8 per axis (by hand:
    ReachAvoid, |v| ≤ 1, |a| ≤ 0.5, h = 0.5 s: 0.25 + 0.015625), so its path, sampled
    finely, clears the obstacle by that much less at worst."""
    from stlc.backends.milp import seed as milp_seed

    program, mission = _program(tmp_path, "0.1")
    problem = from_mission(program, mission)
    assert milp_seed.clearance(problem, 0.5) == 0.25 + 0.5 * 0.25 / 8
    f = milp_seed.seed_formula(problem, 0.3)
    g = milp_seed.seed_formula(problem)
    # only the obstacle's faces (negated) move: by exactly 0.3 on any trace
    ch = {"robot.pos.x": np.linspace(0, 9, 151), "robot.pos.y": np.linspace(1, 9, 151),
          "robot.pos.z": np.full(151, 1.0)}
    avoid = problem.specs["avoid"].normal
    a_f = [c for c in f.args if "obs" in str(c)] if hasattr(f, "args") else []
    assert a_f, "the avoid conjunct is kept"
    assert monitor.robustness(a_f[0], 0.1, ch, problem.params) == pytest.approx(
        monitor.robustness(avoid, 0.1, ch, problem.params) - 0.3)
    reach = [c for c in g.args if "goal" in str(c)]
    reach_f = [c for c in f.args if "goal" in str(c)]
    assert monitor.robustness(reach_f[0], 0.1, ch, problem.params) == pytest.approx(
        monitor.robustness(reach[0], 0.1, ch, problem.params))
    paths, rec = CoarseStart().solve(None, problem)
    assert rec["clearance"] == pytest.approx(0.265625)
    P = paths["robot"][0]  # on the mission grid: every sample clear of the obstacle
    inside = (P[0] > 3) & (P[0] < 5) & (P[1] > 4) & (P[1] < 6)
    assert not inside.any()
