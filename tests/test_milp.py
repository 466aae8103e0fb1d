"""The exact STL→MILP backend, the chain selection and the infeasibility proof.

Property tests (Hypothesis): for random small formulas over a point mass, the MILP's optimum
equals the exact monitor's robustness of its own plan, and no random dynamically feasible
trajectory has a higher robustness (brute force through the same discrete model)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stlc.analysis import monitor
from stlc.backends.base import run_chain
from stlc.backends.milp.backend import ExactMilp
from stlc.backends.strategy import select
from stlc.diagnostics import StlcError
from stlc.pipeline import load
from stlc.planning.problem import from_mission
from stlc.semantics import ir, nnf

BASE = """\
vehicle d1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
mission m {
  vehicles = [d1]
  horizon = 3 s
  step = 0.5 s
  end = free                  # the optima by hand below assume no final hover
  require always[0, 3] (d1.pos.z >= 0 m)
  maximize robustness
}
"""


@pytest.fixture(scope="module")
def base_problem(tmp_path_factory):
    p = tmp_path_factory.mktemp("milp") / "base.stl"
    p.write_text(BASE, encoding="utf-8")
    prog = load(str(p)).program
    return from_mission(prog, prog.missions["m"])


def _pred(sig: str, lower: bool, c: float) -> ir.Pred:
    e = (ir.Bin("-", ir.Sig(sig), ir.Const(c)) if lower
         else ir.Bin("-", ir.Const(c), ir.Sig(sig)))
    return ir.Pred(e, f"{sig} {'>=' if lower else '<='} {c}")


SIGS = ("d1.pos.x", "d1.pos.y", "d1.vel.x")
preds = st.builds(_pred, st.sampled_from(SIGS), st.booleans(),
                  st.sampled_from([-1.5, -0.5, 0.0, 0.4, 1.0, 1.6]))
windows = st.sampled_from([(0.0, 1.0), (0.5, 1.5), (0.0, 2.0), (1.0, 1.0)])


def _extend(children):
    return st.one_of(
        st.builds(lambda a, b: ir.And((a, b)), children, children),
        st.builds(lambda a, b: ir.Or((a, b)), children, children),
        st.builds(lambda a, b, c: ir.Or((a, b, c)), children, children, children),
        st.builds(lambda w, a: ir.Always(*w, a), windows, children),
        st.builds(lambda w, a: ir.Eventually(*w, a), windows, children),
        st.builds(lambda w, a, b: ir.Until(*w, a, b), windows, children, children),
        st.builds(lambda a: ir.Not(a), children),
        st.builds(lambda a: ir.Next(a), children),
    )


formulas = st.recursive(preds, _extend, max_leaves=5)


def _random_plans(problem, count: int, seed: int) -> list[dict]:
    """Random dynamically feasible trajectories: random inputs in bounds (bang-bang and
    uniform), integrated exactly, velocities kept in bounds by clipping the inputs."""
    rng = np.random.default_rng(seed)
    n, dt = problem.grid.n, problem.grid.dt
    out = []
    for i in range(count):
        p = np.array([0.0, 0.0, 1.0])
        v = np.zeros(3)
        P, V, A = [p.copy()], [v.copy()], []
        for _ in range(n - 1):
            a = rng.choice([-2.0, 0.0, 2.0], 3) if i % 2 else rng.uniform(-2, 2, 3)
            a = np.clip(a, (-1 - v) / dt, (1 - v) / dt)  # next velocity within ±1
            p = p + v * dt + 0.5 * a * dt * dt
            v = v + a * dt
            P.append(p.copy()), V.append(v.copy()), A.append(a)
        A.append(A[-1])
        P, V, A = map(np.array, (P, V, A))
        ch = {}
        for j, ax in enumerate("xyz"):
            ch[f"d1.pos.{ax}"], ch[f"d1.vel.{ax}"], ch[f"d1.acc.{ax}"] = P[:, j], V[:, j], A[:, j]
        out.append(ch)
    return out


def _one_hot(log: bool) -> int:
    """The widest disjunction encoded one-hot: 2 (the logarithmic encoding from three
    operands on) or every one."""
    return 2 if log else 1_000_000


@pytest.mark.parametrize("log", [False, True])
def test_the_plan_is_the_point_of_the_optimum(base_problem, log):
    """Found by the property test below (log encoding): HiGHS returned the MIP start's point
    (pos.x(1 s) = 0: ρ = 1.5) beside the optimum's objective 2.25 (pos.x(1 s) = 0.75 by
    hand: accelerate at 2 m/s² for 0.5 s, then coast at 1 m/s); the point is now checked."""
    f = ir.Or((ir.Eventually(0.0, 2.0, ir.Pred(ir.Bin("-", ir.Sig("d1.vel.x"), ir.Const(1.0)),
                                               "a")),
               ir.Always(1.0, 1.0, ir.Pred(ir.Bin("-", ir.Sig("d1.pos.x"), ir.Const(-1.5)),
                                           "b"))))
    req = nnf.normalize(f)
    problem = replace(base_problem, requirement=req)
    sol, _ = run_chain(problem, [ExactMilp(time_limit=60, one_hot=_one_hot(log))])
    rho = float(monitor.robustness(req, problem.grid.dt, sol.channels, problem.params))
    assert abs(sol.solver["objective"] - 2.25) < 1e-6 and abs(rho - 2.25) < 1e-6


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(f=formulas, log=st.booleans())
def test_milp_optimum_is_the_monitor_value_and_nothing_beats_it(base_problem, f, log):
    """Both disjunction encodings: one binary per operand, and the logarithmic one."""
    req = nnf.normalize(f)
    problem = replace(base_problem, requirement=req)
    sol, _ = run_chain(problem, [ExactMilp(time_limit=60, one_hot=_one_hot(log))])
    assert sol.solver["return_status"] == "optimal"
    dt = problem.grid.dt
    rho = float(monitor.robustness(req, dt, sol.channels, problem.params))
    obj = sol.solver["objective"]
    if math.isinf(rho) or math.isnan(obj):
        # a formula whose value is a constant (an empty window): the plan's value is it
        assert math.isnan(obj) or math.isinf(obj) or rho == obj
    else:
        assert abs(rho - obj) <= 1e-6, (rho, obj)
    for ch in _random_plans(problem, 30, seed=hash(f) & 0xFFFF):
        other = float(monitor.robustness(req, dt, ch, problem.params))
        assert other <= rho + 1e-6, (other, rho)


@pytest.mark.parametrize("log, binaries", [(True, 3), (False, 7)])
def test_log_binaries_for_a_wide_disjunction(base_problem, log, binaries):
    """An `eventually` over 7 samples uses ⌈log2 7⌉ = 3 binaries (Gray code) or 7."""
    f = ir.Eventually(0.0, 3.0, _pred("d1.pos.x", True, 1.0))
    problem = replace(base_problem, requirement=f)
    sol, _ = run_chain(problem, [ExactMilp(one_hot=_one_hot(log))])
    assert sol.problem_size["binaries"] == binaries
    # by hand: from rest with |v| ≤ 1 m/s, |a| ≤ 2 m/s²: 0.5 s at 2 m/s² (0.25 m, 1 m/s),
    # then 2.5 s at 1 m/s: x(3 s) = 2.75 m, so the margin of x ≥ 1 m is 1.75 m
    assert abs(sol.solver["objective"] - 1.75) < 1e-9
    assert abs(monitor.robustness(f, 0.5, sol.channels, {}) - 1.75) < 1e-9


def test_nonlinear_predicate_refused_at_its_span(tmp_path):
    src = BASE.replace("require always[0, 3] (d1.pos.z >= 0 m)",
                       "require always[0, 3] (d1.speed <= 0.5 m/s)")
    p = tmp_path / "s.stl"
    p.write_text(src, encoding="utf-8")
    prog = load(str(p)).program
    problem = from_mission(prog, prog.missions["m"])
    diags = ExactMilp().accepts(problem)
    assert diags and all(d.code == "STL401" and d.span.line == 11 for d in diags)
    assert select(problem).name == "nlp"  # chosen by capability: the NLP plans it
    with pytest.raises(StlcError):
        run_chain(problem, select(problem, "milp").backends)


def test_selection_by_capability():
    root = Path(__file__).parent.parent
    hand = load(str(root / "specs" / "handover.stl")).program
    m = next(iter(hand.missions.values()))
    assert select(from_mission(hand, m)).name == "timed"  # a multirotor is not linear
    team = load(str(root / "specs" / "bird_diverter_2x7.stl")).program
    m = next(iter(team.missions.values()))
    assert select(from_mission(team, m)).name == "team"
    assert select(from_mission(team, m), "casadi").name == "nlp"  # forced by backend name


def _compile(path: Path, out: Path, *extra: str) -> tuple[int, dict, str]:
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).parent.parent))
    r = subprocess.run([sys.executable, "-m", "stlc", "compile", str(path), "-o", str(out),
                        "--no-risk", *extra], capture_output=True, text=True, env=env,
                       timeout=300)
    sol = json.loads((out / "solution.json").read_text()) if (out / "solution.json").exists() \
        else {}
    return r.returncode, sol, r.stderr


INFEASIBLE = """\
vehicle d1 : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (3, 3, 3) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-10, -10, 0), (10, 10, 3)) m
  region east = box((3, -1, 0.5), (5, 1, 1.5)) m
  region west = box((-5, -1, 0.5), (-3, 1, 1.5)) m
}
spec safe = always[0, 12] (d1.pos in workspace)
mission two_places {
  vehicles = [d1]
  horizon = 12 s
  step = 0.5 s
  spec at_east = always[5, 6] (d1.pos in east)
  spec at_west = always[5, 6] (d1.pos in west)
  spec high = always[0, 12] (d1.pos.z <= 2.5 m)
  require safe and at_east and at_west and high
  maximize robustness
}
"""


def test_two_places_at_once_is_proved_infeasible(tmp_path):
    p = tmp_path / "inf.stl"
    p.write_text(INFEASIBLE, encoding="utf-8")
    code, sol, err = _compile(p, tmp_path / "out")
    assert code == 3
    assert sol["status"] == "infeasible"
    assert sorted(sol["conflict"]) == ["at_east", "at_west"]  # minimal: not safe, not high
    assert "STL504" in err and "chain `milp`" in err
    assert "No plan exists" in (tmp_path / "out" / "report.html").read_text()
    assert sol["solver"]["chain"]["name"] == "milp"


def test_feasible_variant_is_planned_and_not_called_infeasible(tmp_path):
    # 2 s apart instead of at the same time: 8 m in 2 s at 2 m/s... too tight with the
    # acceleration phase, so 5 s apart: feasible, satisfied by the exact backend
    src = INFEASIBLE.replace("always[5, 6] (d1.pos in west)", "always[11, 12] (d1.pos in west)")
    p = tmp_path / "ok.stl"
    p.write_text(src, encoding="utf-8")
    code, sol, _ = _compile(p, tmp_path / "out", "-q")
    assert code == 0 and sol["status"] == "satisfied" and "conflict" not in sol
    assert abs(sol["robustness"]["exact"] - sol["solver"]["objective"]) < 1e-6


def test_mission_field_forces_a_backend(tmp_path):
    src = INFEASIBLE.replace("  maximize robustness\n}", "  maximize robustness\n  backend = nope\n}")
    p = tmp_path / "f.stl"
    p.write_text(src, encoding="utf-8")
    prog = load(str(p)).program
    problem = from_mission(prog, prog.missions["two_places"])
    with pytest.raises(StlcError) as e:
        select(problem)
    assert e.value.diagnostics[0].code == "STL207"


BENCH = Path(__file__).parent.parent / "specs" / "benchmarks"


@pytest.mark.parametrize("path", sorted(BENCH.glob("*.stl")), ids=lambda p: p.name)
def test_stlpy_reencodings_check_and_choose_the_exact_backend(path):
    program = load(str(path)).program
    for m in program.missions.values():
        assert select(from_mission(program, m)).name == "milp"


def test_reach_avoid_benchmark_is_planned_to_its_optimum():
    """stlpy's ReachAvoid: the best margin is the goal's half-width 0.5 (by hand: the goal
    is a 1 m square reachable in 15 s, the obstacle is avoidable with more margin)."""
    program = load(str(BENCH / "reach_avoid.stl")).program
    from stlc.pipeline import plan

    _, sol = plan(program, program.missions["reach_avoid"])
    assert sol.status == "satisfied" and sol.solver["return_status"] == "optimal"
    assert sol.robustness_exact == pytest.approx(0.5, abs=1e-6)
    assert sol.solver["objective"] == pytest.approx(sol.robustness_exact, abs=1e-6)


DASH = """\
vehicle d1 : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (1, 1, 1) m/s^2
  start { pos = (0, 0, 1) m }
}
mission dash {
  vehicles = [d1]
  horizon = 4 s
  step = 0.5 s
  threshold = 0.1
  spec far = eventually[4, 4] (d1.pos.x >= 5 m)
  require far
  maximize robustness
}
"""


def test_a_mission_only_a_moving_end_satisfies_is_planned_not_called_impossible(tmp_path):
    # by hand: from rest with |a| <= 1 m/s², a plan at rest again at 4 s covers at most
    # 4 m (accelerate 2 s, brake 2 s), so no plan *ending at rest* reaches x >= 5 m; one
    # that may end moving covers 6 m (1 m/s² to 2 m/s by 2 s, then 2 m/s: 2 + 4 m) —
    # ρ = 1.  The holdable end is the planner's preference, not the verdict's: the exact
    # MILP plans without it and the proof does not call the mission impossible
    from stlc.backends.milp.conflict import prove_infeasible

    p = tmp_path / "dash.stl"
    p.write_text(DASH, encoding="utf-8")
    program = load(str(p)).program
    problem = from_mission(program, program.missions["dash"])
    assert problem.hold_end
    assert prove_infeasible(problem) is None
    code, sol, _ = _compile(p, tmp_path / "out", "-q")
    assert code == 0 and sol["status"] == "satisfied" and "conflict" not in sol
    assert sol["robustness"]["exact"] == pytest.approx(1.0, abs=1e-6)
    assert sol["solver"]["objective"] == pytest.approx(1.0, abs=1e-6)
    assert any("cannot hold" in n for n in sol["notes"])  # the end is noted, not hidden
    # and with the end at rest required by hand (x >= 5 by 4 s at rest): proved impossible
    held = DASH.replace("require far", "spec stop = always[4, 4] (d1.vel.x <= 0.05 m/s)\n"
                        "  require far and stop")
    p.write_text(held, encoding="utf-8")
    code, sol, _ = _compile(p, tmp_path / "out2", "-q")
    assert code == 3 and sol["status"] == "infeasible"
    assert sorted(sol["conflict"]) == ["far", "stop"]


def test_a_speed_limit_takes_part_in_the_proof(tmp_path):
    # by hand: with |v| <= 1 m/s at every sample and |a| <= 1 m/s², Δt = 0.5 s, the point
    # mass covers at most 0.125 + 0.375 m in its first two steps (v: 0 → 0.5 → 1 m/s), then
    # 0.5 m a step (a ≤ 0 at v = 1): 3.5 m by 4 s < 5 m, so no plan exists.  The limit is a
    # norm (not affine): the proof keeps it as the box around its ball, |v_i| <= 1 m/s.
    # At 2 m/s (the vehicle's own limit) the dash of the test above is possible again
    from stlc.backends.milp.conflict import prove_infeasible

    p = tmp_path / "slow.stl"
    for limit, possible in (("1 m/s", False), ("2 m/s", True)):
        p.write_text(DASH.replace("require far", f"spec slow = always[0, 4] (d1.speed <= {limit})"
                                  "\n  require far and slow"), encoding="utf-8")
        program = load(str(p)).program
        proof = prove_infeasible(from_mission(program, program.missions["dash"]))
        if possible:
            assert proof is None
        else:
            assert proof is not None and sorted(proof.conflict) == ["far", "slow"]
