"""Long missions: budgets that scale with the problem and the machine, the multirotor's guess
limits taken from its declaration, and plans on knots simulated on the mission grid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stlc import deadline, pipeline, vehicles
from stlc.backends.knots import backend as knots
from stlc.planning import effort
from stlc.planning.problem import from_mission
from stlc.vehicles import dynamics, multirotor

QUAD = """\
vehicle q1 : multirotor {{
  mass    = 1.4 kg
  inertia = diag(1.2e-2, 1.2e-2, 2.2e-2) kg*m^2
  c_f     = 11.5e-4
  c_tau   = 2.38e-5
  force   = [0.2 N, {fmax} N]
  rotors  = quadrotor(arm = 0.23 m)
  {extra}
  start {{ pos = (0, 0, 1) m }}
}}
scenario {{
  workspace = box((-5, -5, 0), (5, 5, 4)) m
  region a = box((1, -0.5, 0.5), (2, 0.5, 1.5)) m
}}
mission m {{
  vehicles = [q1]
  horizon = {horizon} s
  step = 0.1 s
  spec stay = always[0, {horizon}] (q1.pos in workspace)
  spec visit = eventually[0, {last}] always[0, 2] (q1.pos in a)
  require stay and visit
  maximize robustness
}}
"""


def _load(tmp_path, fmax=9, extra="", horizon=6, last=4):
    f = tmp_path / "q.stl"
    f.write_text(QUAD.format(fmax=fmax, extra=extra, horizon=horizon, last=last))
    program = pipeline.load(str(f)).program
    return program, program.missions["m"]


def test_seed_budget_scales_with_binaries_and_load():
    small, large = effort.seed_budget(10, factor=1.0), effort.seed_budget(2000, factor=1.0)
    assert small == pytest.approx(effort.SEED_BASE_S)
    assert large == pytest.approx(effort.SEED_PER_BINARY_S * 2000)
    assert effort.seed_budget(2000, factor=3.0) == pytest.approx(3 * large)


def test_seed_budget_leaves_time_for_the_stages_after_it():
    with deadline.limited(10.0):
        b = effort.seed_budget(2000, factor=1.0)
    assert b <= effort.SHARE * 10.0 + 1e-9


def test_guess_limits_come_from_the_declaration(tmp_path):
    program, _ = _load(tmp_path, extra="vel_max = (3, 3, 1) m/s")
    v = program.vehicles["q1"]
    vel, acc = vehicles.model_of(v).kinematic_limits(v)
    assert np.allclose(vel, multirotor.GUESS_VEL_SHARE * np.array([3, 3, 1]))
    # by hand: 4 rotors × 9 N = 36 N against 1.4 kg × 9.81; tilt limited to 60°:
    # horizontal g·tan 60° = 16.99, climbing 36/1.4 − 9.81 = 15.90 m/s²
    a = min(multirotor.GUESS_ACC_SHARE * (36 / 1.4 - 9.81), multirotor.GUESS_ACC)
    assert acc == pytest.approx(np.full(3, a), abs=2e-3)
    # the declared top speed bounds the NLP's velocity too
    b = vehicles.model_of(v).envelope(v, vehicles.model_of(v).bounds(v))
    assert np.allclose(b.x_hi[6:9], [3, 3, 1])


def test_a_weak_multirotor_guesses_gentler_acceleration(tmp_path):
    program, _ = _load(tmp_path, fmax=4.4)  # thrust/weight 17.6 / 13.73 = 1.28
    v = program.vehicles["q1"]
    _, acc = vehicles.model_of(v).kinematic_limits(v)
    tw = 4 * 4.4 / (1.4 * 9.81)
    horizontal = 9.81 * math.tan(math.acos(1 / tw))
    climb = 4 * 4.4 / 1.4 - 9.81
    assert acc[0] == pytest.approx(min(multirotor.GUESS_ACC_SHARE * min(horizontal, climb),
                                       multirotor.GUESS_ACC), abs=2e-3)
    assert acc[0] < 0.5


def test_knot_plan_is_the_full_model_on_the_mission_grid(tmp_path):
    """A plan on knots (inputs held between them) on the mission grid: every mission-grid
    interval obeys the mission's own discrete model (checked here by one RK4 step per
    interval, independently of ``refine``), and the plan passes through the knots."""
    program, mission = _load(tmp_path)
    problem = from_mission(program, mission)
    m = knots.knot_factor(problem)
    # bounds 6, 4, 2 s: every step divides them; a multirotor's knots are ≤ 0.2 s apart
    assert m == round(multirotor.KNOT_STEP / 0.1) == 2
    cp = knots.coarse_problem(problem, m)
    v = program.vehicles["q1"]
    vm = vehicles.model_of(v)
    rng = np.random.default_rng(1)
    Uc = rng.uniform(-2, 2, (4, cp.grid.n))  # force rates on the knots
    h = m * 0.1
    Fc = dynamics.discrete_dynamics(vm.ode(v), h, "rk4", dynamics.substeps(h))
    Xc = [problem.start_state("q1")]
    for j in range(cp.grid.n_intervals):  # a dynamically exact knot plan
        Xc.append(np.asarray(Fc(Xc[-1], Uc[:, j])).ravel())
    Xc = np.array(Xc).T
    ch = {c: Uc[i] for i, c in enumerate(vm.input_channels(v))}
    ch.update({c: Xc[i] for i, c in enumerate(vm.state_channels(v))})
    fine, energy, prof = knots.refine(problem, ch, m)
    assert fine["q1.pos.x"].shape == (problem.grid.n,)
    X = vehicles.state_matrix(v, fine)  # (n, nx)
    F = dynamics.discrete_dynamics(vm.ode(v), 0.1, "rk4", 1)
    for k in range(problem.grid.n_intervals):
        u = Uc[:, k // m]
        assert np.allclose(np.asarray(F(X[k], u)).ravel(), X[k + 1], atol=1e-8)
    assert np.allclose(X[::m].T, Xc)
    assert energy == pytest.approx(prof.sum())


def test_long_missions_take_the_knot_chain(tmp_path):
    from stlc.backends.strategy import select

    program, mission = _load(tmp_path, horizon=6)
    assert select(from_mission(program, mission)).name == "timed"  # 61 samples
    program, mission = _load(tmp_path, horizon=45, last=40)
    assert select(from_mission(program, mission)).name == "knots"  # 451 samples


def test_long_specs_check_and_pick_their_chains():
    """``specs/long``: the quadrotor inspection takes the knot chain, the point-mass patrol
    the exact MILP's."""
    from pathlib import Path

    from stlc.backends.strategy import select

    root = Path(__file__).resolve().parent.parent / "specs" / "long"
    want = {"tower_inspection_60s.stl": "knots", "patrol_60s.stl": "milp"}
    for name, chain in want.items():
        program = pipeline.load(str(root / name)).program
        (mission,) = program.missions.values()
        assert select(from_mission(program, mission)).name == chain
