"""Planning end to end (``stlc.pipeline.plan``) against independently computed values.

* small point-mass missions whose optimal exact robustness follows from the per-axis
  velocity/acceleration bounds by hand;
* a mission that no plan can satisfy;
* the shipped handover missions (paper A's hexarotor, full dynamics) at a coarser step;
* every file in ``specs/`` is checked and either planned or refused with a clear diagnostic;
* the dynamics of a multirotor plan, re-simulated with scipy from its ``trajectory.csv``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from stlc import vehicles
from stlc.analysis import monitor
from stlc.analysis.trace import read_trace
from stlc.diagnostics import StlcError
from stlc.output.solution import trajectory_csv
from stlc.pipeline import compile_file, load, plan
from stlc.vehicles import dynamics
from stlc.semantics import model, nnf

ROOT = Path(__file__).resolve().parent.parent
SPECS = ROOT / "specs"

#: 1 m/s and 2 m/s² per axis, at rest at the origin
POINT_MASS = """\
vehicle p : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 0) m }
}
"""


def mission_source(require: str, horizon: float, step: float = 0.1, name: str = "m",
                   end: str = "free") -> str:
    """A point-mass mission; the optima below are for a free end state (``end = free``)."""
    return POINT_MASS + f"""
mission {name} {{
  vehicles = [p]
  horizon = {horizon:g} s
  step = {step:g} s
  end = {end}
  spec goal = {require}
  require goal
  minimize -robustness
}}
"""


def load_source(tmp_path: Path, text: str) -> model.Program:
    path = tmp_path / "mission.stl"
    path.write_text(text, encoding="utf-8")
    return load(str(path)).program


# ------------------------------------------------------------------ known optima
#
# With |v| <= 1 m/s and |a| <= 2 m/s² per axis from rest, the fastest way forward is 0.5 s
# at full acceleration (0.25 m, reaching 1 m/s) then 1 m/s.  The point mass is a double
# integrator with zero-order-hold acceleration, which RK4 integrates exactly, so on the
# 0.1 s grid (0.5 s = 5 steps) these continuous-time optima are attained exactly:
#
# * hold_interval: be in x ∈ [2, 3] for 2 s starting by t = 3 s.  The best is to sit at the
#   centre 2.5 m (robustness 0.5 = distance to both faces); it is reachable at rest exactly
#   at t = 3 s (0.5 s accelerate 0.25 m, 2 s cruise 2 m, 0.5 s brake 0.25 m).  ρ* = 0.5.
# * max_reach: x ≥ 2 m by t = 3 s; x(3) ≤ 0.25 + 2.5 = 2.75 m.  ρ* = 0.75.
# * better_branch: x ≥ 2 m (ρ ≤ 0.75) or y ≤ -2.5 m (ρ ≤ 0.25) by 3 s: max = 0.75.
# * keep_still: always |x| ≤ 1 (and |y| ≤ 1) for 5 s: staying at the origin gives 1.0.

KNOWN_OPTIMA = [
    ("hold_interval", "eventually[0, 3] always[0, 2] (p.pos.x in [2, 3])", 5.0, 0.5, 0.45),
    ("max_reach", "eventually[0, 3] (p.pos.x >= 2 m)", 3.0, 0.75, 0.70),
    ("better_branch", "eventually[0, 3] (p.pos.x >= 2 m or p.pos.y <= -2.5 m)", 3.0, 0.75,
     0.70),
    ("keep_still", "always[0, 5] (p.pos.x in [-1, 1] and p.pos.y in [-1, 1])", 5.0, 1.0,
     0.95),
]


@pytest.mark.parametrize("name, require, horizon, optimum, good_enough", KNOWN_OPTIMA,
                         ids=[k[0] for k in KNOWN_OPTIMA])
def test_known_optimal_robustness_exact_milp(tmp_path, name, require, horizon, optimum,
                                             good_enough):
    """The exact backend (chosen by capability for a point mass) attains each optimum."""
    program = load_source(tmp_path, mission_source(require, horizon))
    _, sol = plan(program, program.missions["m"])
    assert sol.solver["chain"]["name"] == "milp" and sol.solver["return_status"] == "optimal"
    assert sol.status == "satisfied"
    assert sol.robustness_exact == pytest.approx(optimum, abs=1e-6)
    assert sol.solver["objective"] == pytest.approx(sol.robustness_exact, abs=1e-6)


@pytest.mark.parametrize("name, require, horizon, optimum, good_enough", KNOWN_OPTIMA,
                         ids=[k[0] for k in KNOWN_OPTIMA])
def test_known_optimal_robustness(tmp_path, name, require, horizon, optimum, good_enough):
    program = load_source(tmp_path, mission_source(require, horizon))
    _, sol = plan(program, program.missions["m"], backend="nlp")
    assert sol.status == "satisfied"
    # the optimum bounds every plan from above (up to the solver's tolerance) ...
    assert sol.robustness_exact <= optimum + 1e-6
    # ... and the planner gets close to it
    assert sol.robustness_exact >= good_enough
    # GKL smooth robustness is sound: it never over-estimates the exact robustness
    assert sol.robustness_smooth <= sol.robustness_exact + 1e-9
    assert sol.specs["goal"].satisfied
    assert sol.specs["goal"].robustness == pytest.approx(sol.robustness_exact, abs=1e-12)
    # the exact monitor on the returned channels agrees with the Solution
    f = nnf.normalize(program.missions["m"].requirement)
    assert monitor.robustness(f, 0.1, sol.channels) == pytest.approx(sol.robustness_exact)
    # the plan respects the vehicle's bounds and start state
    vx = np.asarray(sol.channels["p.vel.x"])
    ax = np.asarray(sol.channels["p.acc.x"])
    assert np.max(np.abs(vx)) <= 1.0 + 1e-6
    assert np.max(np.abs(ax)) <= 2.0 + 1e-6
    assert sol.channels["p.pos.x"][0] == 0.0 and sol.channels["p.vel.x"][0] == 0.0
    assert sol.problem_size["samples"] == round(horizon / 0.1) + 1
    for key in ("build_s", "guess_s", "solve_s"):
        assert sol.timing[key] >= 0.0


def _reach_at_rest(n: int = 30, dt: float = 0.1, v_end: float = 0.05) -> float:
    """The farthest x_N of the point mass (|v| ≤ 1, |a| ≤ 2 per axis, zero-order hold) that
    ends with |v_N| ≤ v_end: a linear program over the accelerations (scipy, independent of
    stlc).  x_N = Σ_i a_i·dt²·(n − 1 − i + 1/2), v_k = dt·Σ_{i<k} a_i."""
    from scipy.optimize import linprog

    c = -np.array([dt * dt * (n - 1 - i + 0.5) for i in range(n)])
    rows, rhs = [], []
    for k in range(1, n + 1):
        row = np.zeros(n)
        row[:k] = dt
        bound = v_end if k == n else 1.0
        rows += [row, -row]
        rhs += [bound, bound]
    res = linprog(c, A_ub=np.array(rows), b_ub=rhs, bounds=[(-2, 2)] * n)
    return float(-res.fun)


def test_holdable_end_is_the_default(tmp_path):
    """Without ``end = free`` the plan ends at rest (|v_N| ≤ 0.05 m/s): x ≥ 2 m by 3 s then
    has the optimum x_N − 2 from the LP (2.5225 m: ρ* = 0.5225, not 0.75)."""
    optimum = _reach_at_rest() - 2.0
    assert abs(optimum - 0.5225) < 1e-6  # hand check: 0.25 + 2.025 + 0.2475 m
    program = load_source(tmp_path, mission_source("eventually[0, 3] (p.pos.x >= 2 m)", 3.0,
                                                   end="hover"))
    _, sol = plan(program, program.missions["m"])
    assert sol.status == "satisfied"
    assert optimum - 0.03 <= sol.robustness_exact <= optimum + 1e-6
    speed = np.sqrt(sum(sol.channels[f"p.vel.{a}"][-1] ** 2 for a in "xyz"))
    assert sol.end_state["p"]["holdable"] and speed <= 0.05 * np.sqrt(3) + 1e-6
    assert not any("cannot hold" in n for n in sol.notes)


def test_impossible_mission_is_violated(tmp_path):
    """x ≥ 100 m in 3 s at ≤ 1 m/s: the farthest reachable is 2.75 m, so ρ* = -97.25.  The
    MILP seed of the `nlp` chain finds no path reaching κ, the relaxation proves no plan
    exists before the NLP runs, and the plan shown is the hover at x = 0 (ρ = -100)."""
    program = load_source(tmp_path, mission_source("eventually[0, 3] (p.pos.x >= 100 m)", 3.0))
    _, sol = plan(program, program.missions["m"], backend="nlp")
    assert sol.status == "infeasible" and sol.conflict == ["goal"]
    assert sol.robustness_exact == -100.0
    goal = sol.specs["goal"]
    assert not goal.satisfied and goal.robustness == -100.0
    assert goal.binding_predicate.startswith("p.pos.x >= 100")
    assert goal.line > 0
    stages = sol.solver["chain"]["stages"]
    assert [s["status"] for s in stages] == ["infeasible", "not_run"]  # no NLP solve


# ------------------------------------------------------------------ shipped handover missions
#
# Every time bound in specs/handover.stl is a multiple of 0.5 s, so the missions can be
# planned on a coarser grid than their 0.1 s step to keep the suite fast.  Measured on this
# code (single-threaded MUMPS, 2 shared cores), exact robustness and wall time:
#
#   mission           step 0.5 s (35 samples)         step 0.25 s (69 samples)
#   handover_front    satisfied +0.056, 8 s           satisfied +0.059, 35 s  ← used
#   handover_left_tb  VIOLATED  -0.050, 20 s           satisfied +0.062, 15 s  ← used
#                     (visibility/approach fail
#                     in all 4 λ stages)
#   handover_left     VIOLATED  -0.000, 23 s           satisfied +0.016, 85 s  ← used
#                     (approach exactly 0 after        (only the 4th λ stage, λ = 270,
#                     4 λ stages, 300 it. each)        succeeds)
#
# Step 1.0 s (18 samples) is worse: left_tb -0.16, left -0.40, front solver_failed.
# (Table above: the code before the planner form.)  With the planner form (branch nlp),
# handover_front at 0.5 s ended at exact ≈ 0 (violated) under two of three hash seeds, so it
# is planned at 0.25 s too; at 0.25 s all three passed with PYTHONHASHSEED=1, handover_left
# failed (local optimum, -0.49) with PYTHONHASHSEED=2.  After the pair-width test stopped
# depending on set order (and the checker's elaboration changed), handover_left at 0.25 s
# and 0.2 s ends in that local optimum for every seed tried (-0.75, -6.98), at 0.5 s it is
# satisfied (+0.062) and at the mission's own 0.1 s step satisfied (+0.042): planned at 0.5 s.
# Coarse-grid fragility of the planner form is a known open problem (issue 12 note).
# With the holdable end state (issue 22: the last sample hovers), handover_front at 0.25 s
# and 0.5 s ends at exact ≈ 0 (visibility −4e-10 against approach +4e-10: a local optimum of
# the coarse grid); at 0.2 s it is satisfied (+0.063), at its own 0.1 s step +0.064.
HANDOVER_STEPS = {"handover_left_tb": 0.25, "handover_front": 0.2, "handover_left": 0.25}


@pytest.fixture(scope="module")
def handover_program() -> model.Program:
    return load(str(SPECS / "handover.stl")).program


@pytest.fixture(scope="module")
def handover_plans(handover_program):
    """Plans computed on demand and shared by the tests of this module."""
    cache: dict[str, tuple] = {}

    def get(name: str):
        if name not in cache:
            t0 = time.perf_counter()
            out = plan(handover_program, handover_program.missions[name],
                       step=HANDOVER_STEPS[name])
            cache[name] = (*out, time.perf_counter() - t0)
        return cache[name]
    return get


@pytest.mark.parametrize("name", list(HANDOVER_STEPS))
def test_handover_mission_plans_satisfying(handover_plans, handover_program, name):
    _, sol, wall = handover_plans(name)
    stages = ", ".join(f"{s['label']} λ={s['lam']:g} {s['iterations']} it {s['status']} "
                       f"exact {s['exact']:+.4f} ({s['solve_s']:.1f} s)"
                       for s in sol.solver["stages"])
    print(f"\n{name} at step {HANDOVER_STEPS[name]:g} s: {sol.status}, exact "
          f"{sol.robustness_exact:+.4f}, smooth {sol.robustness_smooth:+.4f}, energy "
          f"{sol.energy:.1f} J; {wall:.1f} s (build {sol.timing['build_s']:.1f}, guess "
          f"{sol.timing['guess_s']:.1f}, solve {sol.timing['solve_s']:.1f}); {stages}")
    assert sol.status == "satisfied", stages
    # energy first (paper A eq. 6 from the seed, schedule.ENERGY_FIRST; the robustness
    # schedule only if that misses κ); the `compare no_energy` plan is then solved on its own
    labels = [s["label"] for s in sol.solver["stages"]]
    kappa = handover_program.missions[name].threshold
    assert labels[0] == "energy"
    if sol.solver["stages"][0]["exact"] >= kappa:
        assert labels[1:] == ["compare no_energy"], labels
    assert sol.robustness_exact >= handover_program.missions[name].threshold  # the contract
    assert sol.robustness_smooth <= sol.robustness_exact + 1e-9
    # every named spec of the mission holds, and the requirement is their conjunction
    assert set(sol.specs) >= {"safety", "visibility", "approach", "comfort", "handover"}
    assert all(s.satisfied for s in sol.specs.values())
    assert min(s.robustness for s in sol.specs.values()) == pytest.approx(
        sol.robustness_exact, abs=1e-9)
    assert sol.problem_size["samples"] == round(17.0 / HANDOVER_STEPS[name]) + 1
    assert np.isfinite(sol.energy) and sol.energy > 0
    # no warnings about the plan (STLW02) and its final state can be held
    assert not [d for d in sol.diagnostics if d.code.startswith("STLW")]
    assert all(e["holdable"] for e in sol.end_state.values()), sol.end_state


# ------------------------------------------------------------------ dynamics of a plan
#
# A plan's trajectory.csv holds the states at the samples and the rotor-force rates
# ``dforce`` (the inputs, held constant over each interval).  Re-simulating every interval
# from its sample's state checks the transcription independently of the CasADi code:
#
# * against a hand-written classic RK4 step on the plain-numpy ODE: the NLP's own scheme,
#   so the defect is the solver's feasibility tolerance (≤ 1e-6) — this is exact;
# * against scipy's DOP853 at tight tolerances (the continuous dynamics): the defect is
#   RK4's discretisation error.  At the missions' own 0.1 s step it is ~1e-6 m.  Coarser
#   grids are integrated with RK4 sub-steps of at most 0.1 s (``casadi_nlp.substeps``);
#   with one step per 0.5 s interval the defect was 3-4 cm.

from stlc.backends.nlp.model import substeps  # noqa: E402

CLIMB = ROOT / "tests" / "missions" / "hexa_climb.stl"


def rk4_step(f, x: np.ndarray, u: np.ndarray, h: float) -> np.ndarray:
    k1 = f(x, u)
    k2 = f(x + h / 2 * k1, u)
    k3 = f(x + h / 2 * k2, u)
    k4 = f(x + h * k3, u)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def plan_trace(sol, tmp_path: Path):
    """The plan as ``stlc compile`` writes it (trajectory.csv), read back as a trace."""
    path = tmp_path / "trajectory.csv"
    path.write_text(trajectory_csv(sol), encoding="utf-8")
    return read_trace(path)


def interval_defects(trace, v: model.Multirotor, method: str) -> np.ndarray:
    """|simulated state at t_{k+1} from (x_k, u_k) − x_{k+1}| for every interval k."""
    f = dynamics.multirotor_ode_np(v)
    X = np.column_stack([trace.channels[c] for c in v.channels()])
    U = np.column_stack([trace.channels[c] for c in v.input_channels()])
    assert X.shape == (trace.n, 12 + len(v.rotors))
    np.testing.assert_allclose(X[0], vehicles.model_of(v).initial_state(v), atol=1e-8)
    F = X[:, 12:]  # the plan stays inside the rotor-force bounds
    assert F.min() >= v.force_min - 1e-6 and F.max() <= v.force_max + 1e-6
    out = []
    for k in range(trace.n - 1):
        if method == "rk4":  # the transcription: substeps(dt) RK4 steps per interval
            m = substeps(trace.dt)
            x_next = X[k]
            for _ in range(m):
                x_next = rk4_step(f, x_next, U[k], trace.dt / m)
        else:
            r = solve_ivp(lambda _t, x, u=U[k]: f(x, u), (0.0, trace.dt), X[k],
                          method="DOP853", rtol=1e-11, atol=1e-11)
            assert r.success
            x_next = r.y[:, -1]
        out.append(np.abs(x_next - X[k + 1]))
    return np.array(out)


def report_defects(label: str, d: np.ndarray) -> dict[str, float]:
    parts = {"position": d[:, 0:3].max(), "attitude": d[:, 3:6].max(),
             "velocity": d[:, 6:9].max(), "rates": d[:, 9:12].max(), "forces": d[:, 12:].max()}
    print(f"\n{label}: max defect over {len(d)} intervals: "
          + ", ".join(f"{k} {v:.2e}" for k, v in parts.items()))
    return parts


def test_multirotor_plan_matches_its_rk4_transcription(handover_plans, handover_program,
                                                      tmp_path):
    _, sol, _ = handover_plans("handover_front")  # planned at HANDOVER_STEPS' coarse step
    trace = plan_trace(sol, tmp_path)
    assert trace.dt == pytest.approx(HANDOVER_STEPS["handover_front"])
    d = report_defects(f"handover_front, {trace.dt:g} s, numpy RK4",
                       interval_defects(trace, handover_program.vehicles["uav1"], "rk4"))
    assert max(d.values()) < 1e-5  # FEASIBLE_DEFECT 1e-6 plus the CSV's 9 digits


def test_multirotor_plan_resimulates_at_full_step(tmp_path):
    program = load(str(CLIMB)).program
    _, sol = plan(program, program.missions["climb"])  # the mission's own 0.1 s step
    assert sol.status == "satisfied"
    trace = plan_trace(sol, tmp_path)
    assert trace.dt == pytest.approx(0.1)
    d = report_defects("climb, 0.1 s, scipy DOP853",
                       interval_defects(trace, program.vehicles["uav1"], "ivp"))
    assert d["position"] < 1e-3
    assert d["velocity"] < 1e-3
    assert d["forces"] < 2e-6  # ξ̇ = u is integrated exactly: IPOPT's constr_viol_tol


def test_multirotor_plan_resimulates_at_half_second(handover_plans, handover_program,
                                                    tmp_path):
    _, sol, _ = handover_plans("handover_front")
    trace = plan_trace(sol, tmp_path)
    d = report_defects("handover_front, 0.5 s, scipy DOP853",
                       interval_defects(trace, handover_program.vehicles["uav1"], "ivp"))
    assert d["forces"] < 2e-6  # FEASIBLE_DEFECT (IPOPT's constr_viol_tol) plus the CSV's digits
    assert d["position"] < 1e-3


def test_plan_cut_short_is_never_reported_satisfied_when_infeasible(tmp_path):
    """A plan whose status is ``satisfied`` must be dynamically feasible: stop IPOPT after
    3 iterations (``max_iter``) and check the reported trajectory against its own RK4 step."""
    text = CLIMB.read_text(encoding="utf-8").replace("step = 0.1 s", "step = 0.1 s\n  max_iter = 3")
    program = load_source(tmp_path, text)
    _, sol = plan(program, program.missions["climb"])
    d = interval_defects(plan_trace(sol, tmp_path), program.vehicles["uav1"], "rk4")
    print(f"\nmax_iter = 3: {sol.status}, exact {sol.robustness_exact:+.4f}, "
          f"max dynamics defect {d.max():.2e}")
    assert sol.status != "satisfied" or d.max() < 1e-5


# ------------------------------------------------------------------ every shipped spec

#: what compiling each file of specs/ does today.  A new spec file fails
#: ``test_every_spec_is_classified`` until it is added here.
SPEC_OUTCOME = {
    "handover.stl": "planned",  # each mission in test_handover_mission_plans_satisfying
    "bird_diverter_2x7.stl": "team",
    "bird_diverter_4x11.stl": "team",
    "monitor_example.stl": "STL109",
    "tower_inspection.stl": "geometry",  # planned in tests/test_geometry.py
}
SPEC_FILES = sorted(p.name for p in SPECS.glob("*.stl"))


def test_every_spec_is_classified():
    assert SPEC_FILES, "no specs found"
    assert set(SPEC_FILES) == set(SPEC_OUTCOME)


@pytest.mark.parametrize("fname", SPEC_FILES)
def test_every_spec_checks_and_compiles(fname):
    path = SPECS / fname
    program = load(str(path)).program  # parse + check: no diagnostics
    outcome = SPEC_OUTCOME[fname]
    if outcome == "planned":
        # the handover tests plan each of these missions; make sure none is missed
        assert set(program.missions) == set(HANDOVER_STEPS)
    elif outcome == "team":
        # the full mission, planned by the team chain with the standard objective (the
        # forward-speed stage is the slow part; `stlc compile` runs it, see the README)
        from stlc.backends.base import run_chain
        from stlc.pipeline import backend_chain
        from stlc.planning.problem import from_mission
        from stlc.planning.verify import verify

        for m in program.missions.values():
            problem = from_mission(program, m).with_objective(model.Objective())
            sol, sols = run_chain(problem, backend_chain(problem))
            verify(problem, sol)
            assert sol.status == "satisfied", {k: v.robustness for k, v in sol.specs.items()}
            assert sol.robustness_exact >= m.threshold
            installed = sorted(e.region for e in sol.events if e.kind == "install")
            assert installed == sorted(r.name for r in program.scenario.by_kind("target"))
    elif outcome == "geometry":  # round regions and distances: one point-mass mission
        assert set(program.missions) == {"inspect"}
    elif outcome == "STL109":
        assert not program.missions
        with pytest.raises(StlcError) as e:
            compile_file(str(path), out=None, quiet=True)
        assert [d.code for d in e.value.diagnostics] == ["STL109"]
    else:  # pragma: no cover
        raise AssertionError(outcome)


@pytest.mark.parametrize("path", sorted((ROOT / "tests" / "missions").glob("*.stl")),
                         ids=lambda p: p.name)
def test_benchmark_missions_check(path):
    """The missions the benchmarks plan (unseen handovers, larger teams) stay valid input."""
    program = load(str(path)).program
    assert program.missions
