"""MILP seeds for the `nlp` chain (``stlc.backends.milp.seed``): the seed grid, the exact
sampling of the seed path onto the mission grid, the global choice of a homotopy class the
local guess does not find, and an impossible mission proved before the NLP runs."""

from __future__ import annotations

import numpy as np
import pytest

from stlc import pipeline
from stlc.analysis import monitor
from stlc.backends import strategy
from stlc.backends.milp import seed as milp_seed
from stlc.backends.nlp import schedule
from stlc.planning.problem import from_mission
from stlc.semantics import ir
from stlc.semantics.timegrid import TimeGrid
from tests.test_milp import INFEASIBLE

# a small box near the start (robustness ≤ 0.05) and a large one behind a wall (≤ 0.5):
# only the far one reaches κ = 0.2; the exact MILP backend's optimum is 0.5 (by hand: the
# far box's half-height, held for 1 s, the wall passed at its end)
TRAP = """\
vehicle p : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-6, -6, 0), (6, 6, 2)) m
  obstacle wall = box((1.5, -1.5, 0), (2, 1.5, 2)) m
  target near = box((0.9, -0.05, 0.95), (1.0, 0.05, 1.05)) m
  target far = box((3, -1, 0.5), (5, 1, 1.5)) m
}
mission trap {
  vehicles = [p]
  horizon = 9 s
  step = 0.25 s
  threshold = 0.2
  spec safe = always[0, 9] (p.pos in workspace and p.pos not in wall)
  spec reach = eventually[4, 8] always[0, 1] (p.pos in near or p.pos in far)
  require safe and reach
  maximize robustness
}
"""


def _problem(src: str, tmp_path, name: str):
    f = tmp_path / f"{name}.stl"
    f.write_text(src, encoding="utf-8")
    program = pipeline.load(str(f)).program
    return program, program.missions[name]


def _always(lo, hi):
    return ir.Always(lo, hi, ir.Pred(ir.Sig("x"), "x"))


@pytest.mark.parametrize("bounds, dt, n_int, want", [
    ((0.0, 17.0, 5.0, 2.0), 0.1, 170, 5),  # the handover: every bound a multiple of 0.5 s
    ((0.0, 0.3), 0.1, 30, 3),  # 0.3 s bounds: 0.3 s is the coarsest common step
    ((0.0, 1.05), 0.05, 42, 7),  # 1.05 s = 3 × 0.35 s, and 42 = 6 × 7
    ((0.0, 3.7), 0.1, 37, 1),  # 37 intervals (prime): only the mission step divides
])
def test_the_seed_step_divides_the_horizon_and_every_bound(bounds, dt, n_int, want):
    f = ir.And(tuple(_always(0.0, b) for b in bounds))
    m = milp_seed.seed_factor(TimeGrid(dt, n_int), f)
    assert m == want
    h = m * dt
    assert n_int % m == 0 and all(abs(b / h - round(b / h)) < 1e-9 for b in bounds)


def test_a_long_fine_grid_is_coarsened_past_the_step_cap():
    # 60 s at 0.1 s with bounds on whole seconds: 0.5 s would keep 121 samples, more than
    # MAX_SAMPLES (61), so the seed steps 1 s (61 samples), not 2 s
    f = _always(0.0, 60.0)
    assert milp_seed.MAX_SAMPLES == 61
    assert milp_seed.seed_factor(TimeGrid(0.1, 600), f) * 0.1 == pytest.approx(1.0)
    # 120 s: coarsened up to MAX_COARSE_S only (1 s, 121 samples): the clearance of a
    # coarser path (v·h/2 + a·h²/8) would close every passage
    from stlc.planning.coarse_grid import MAX_COARSE_S

    m = milp_seed.seed_factor(TimeGrid(0.1, 1200), f)
    assert m * 0.1 == pytest.approx(MAX_COARSE_S) and 1200 // m + 1 == 121


def test_the_seed_path_is_sampled_exactly_onto_the_mission_grid():
    # two seed intervals of h = 3·dt with constant accelerations: the fine samples obey the
    # fine double integrator exactly (the path between seed samples is the same parabola)
    rng = np.random.default_rng(0)
    dt, m = 0.1, 3
    uu = rng.uniform(-1, 1, (2, 3))
    xs = np.zeros((3, 6))
    xs[0] = rng.uniform(-1, 1, 6)
    h = m * dt
    for k in range(2):
        xs[k + 1, :3] = xs[k, :3] + h * xs[k, 3:] + h * h / 2 * uu[k]
        xs[k + 1, 3:] = xs[k, 3:] + h * uu[k]
    P, V, A = milp_seed.refine(xs, uu, m, dt)
    assert P.shape == (3, 7) and A.shape == (3, 6)
    for j in range(6):
        np.testing.assert_allclose(P[:, j + 1], P[:, j] + dt * V[:, j] + dt * dt / 2 * A[:, j],
                                   atol=1e-12)
        np.testing.assert_allclose(V[:, j + 1], V[:, j] + dt * A[:, j], atol=1e-12)
    np.testing.assert_allclose(P[:, [0, 3, 6]].T, xs[:, :3], atol=1e-12)


def test_the_seed_chooses_the_far_class_and_the_nlp_keeps_it(tmp_path):
    program, mission = _problem(TRAP, tmp_path, "trap")
    problem = from_mission(program, mission)
    paths, rec = milp_seed.plan(problem)
    assert rec["status"] == "Optimal" and rec["step_s"] == pytest.approx(0.5)
    # `reach` on the seed path and on its smoothing: ≥ κ = 0.2, so held in the far box (a
    # hold in the near box scores at most its half-width, 0.05)
    reach = problem.specs["reach"].normal
    for P, V, _ in (paths["p"], schedule.kinematic_guess(
            problem, path=paths)["p"]):
        ch = {f"p.{f}.{a}": X[i] for f, X in (("pos", P), ("vel", V))
              for i, a in enumerate("xyz")}
        assert monitor.robustness(reach, problem.grid.dt, ch, problem.params) >= 0.2
    # the whole `nlp` chain: satisfied (≥ κ = 0.2), so in the far box: a plan holding in
    # the near box scores at most its half-width, 0.05
    _, sol = pipeline.plan(program, mission, backend="nlp")
    assert sol.solver["chain"]["stages"][0]["backend"] == "milp seed"
    assert sol.status == "satisfied" and sol.robustness_exact >= 0.2


def test_an_impossible_mission_is_proved_before_the_nlp(tmp_path):
    program, mission = _problem(INFEASIBLE, tmp_path, "two_places")
    _, sol = pipeline.plan(program, mission, backend="nlp")
    assert sol.status == "infeasible"
    assert sorted(sol.conflict) == ["at_east", "at_west"]
    stages = sol.solver["chain"]["stages"]
    assert [(s["backend"], s["status"]) for s in stages] == [
        ("milp seed", "infeasible"), ("casadi/ipopt", "not_run")]  # the NLP never ran
    assert any(d.code == "STL504" for d in sol.diagnostics)


def test_a_start_inside_a_no_fly_box_is_proved_impossible_before_the_nlp(tmp_path):
    # the trap's vehicle starts inside the wall: `safe` fails at t = 0 on every path.  The
    # seed's encoding bounds ρ̂ by that start (−0.25 by hand: 0.25 m from the wall's nearer
    # x face) below κ, so its feasibility phase finds a path *at* that bound — not a proof,
    # but the cue to ask the relaxation for one before the NLP's λ schedule (a random
    # handover starting in the no-fly region behind the operator: 121 s → 4.9 s, exit 3)
    src = TRAP.replace("start { pos = (0, 0, 1) m }", "start { pos = (1.75, 0, 1) m }")
    program, mission = _problem(src, tmp_path, "trap")
    problem = from_mission(program, mission)
    _, rec = milp_seed.plan(problem)
    assert rec["bound"] == pytest.approx(-0.25) and rec["bound"] < problem.threshold
    _, sol = pipeline.plan(program, mission, backend="nlp")
    assert sol.status == "infeasible" and sol.conflict == ["safe"]
    stages = sol.solver["chain"]["stages"]
    assert [(s["backend"], s["status"]) for s in stages] == [
        ("milp seed", "infeasible"), ("casadi/ipopt", "not_run")]  # the NLP never ran


def test_the_next_seed_leaves_out_the_choices_of_the_violated_spec(tmp_path):
    from stlc.backends.milp.path_seed import MilpPathSeed
    from stlc.backends.milp.seed import conjuncts
    from stlc.planning.fallback import hover_solution

    program, mission = _problem(TRAP, tmp_path, "trap")
    problem = from_mission(program, mission)
    first = MilpPathSeed()
    first.invert(first.start(None, problem)(), None, problem)
    parts = conjuncts(milp_seed.seed_formula(problem))
    reach = next(i for i, c in enumerate(parts)
                 if any(isinstance(g, ir.Eventually) for g in ir.nodes(c)))
    # a plan that hovers at the start violates `reach` only: the next seed cuts its choices
    hover = hover_solution(problem, "test").channels
    nxt = first.next_seed(problem, hover)
    assert list(nxt.exclude[0]) == [reach]
    nxt.invert(nxt.start(None, problem)(), None, problem)
    assert nxt.choices[reach][1] != first.choices[reach][1]
    # a third seed excludes both earlier choices
    third = nxt.next_seed(problem, hover)
    assert len(third.exclude) == 2


def test_a_plan_that_misses_kappa_is_planned_again_from_other_seeds(tmp_path, monkeypatch):
    # the NLP's plan is replaced by a hover (violated): the pipeline tries the kinematic
    # guess, then the next MILP seed (NEXT_CHOICES in all), and records each try
    from stlc.backends.nlp.backend import CasadiNlp
    from stlc.planning.fallback import hover_solution

    calls = []

    def hovering(self, raw, inv, problem):
        calls.append(problem.seed.solver.get("seed", {}).get("excluded", "kinematic"))
        return hover_solution(problem, "test")

    monkeypatch.setattr(CasadiNlp, "solve", lambda self, lowered, problem: None)
    monkeypatch.setattr(CasadiNlp, "invert", hovering)
    program, mission = _problem(TRAP, tmp_path, "trap")
    _, sol = pipeline.plan(program, mission, backend="nlp")
    assert calls == [0, "kinematic", 1]  # the MILP seed, the local guess, one cut
    assert len(sol.solver["chain"]["next_choices"]) == strategy.NEXT_CHOICES
    assert sol.status == "violated"


def test_the_free_milp_run_apart_finds_what_it_finds_in_line(tmp_path):
    """``MilpPathSeed`` runs the MILP with its choices free beside the kinematic smoothing
    (``plan(..., defer_free=True)`` and the ``resume`` it returns): the seed it ends with is
    the one ``plan`` finds with that phase in line — the same phases, the same ρ̂, choices
    over the same binaries (an equally good optimum may set them differently)."""
    program, mission = _problem(TRAP, tmp_path, "trap")
    problem = from_mission(program, mission)
    _, rec = milp_seed.plan(problem)
    paths, early, resume = milp_seed.plan(problem, defer_free=True)
    labels = [p[0] for p in early["phases"]]
    assert paths is not None and resume is not None
    assert "better class (choices free)" not in labels
    better, more = resume()
    assert [p[0] for p in more][0] == "better class (choices free)"
    final = better[1] if better is not None else {**early, "phases": early["phases"] + more}
    assert [p[0] for p in final["phases"]] == [p[0] for p in rec["phases"]]
    assert final["robustness"] == pytest.approx(rec["robustness"], abs=1e-6)
    assert final["choices"].keys() == rec["choices"].keys()
    for k, (idx, _) in rec["choices"].items():
        assert list(final["choices"][k][0]) == list(idx)


def test_the_kinematic_nlp_built_in_a_thread_beside_the_milp_gives_the_same_guess(tmp_path):
    """``MilpPathSeed`` builds the seeded kinematic NLP (its choice rows as parameters) in
    a thread while HiGHS looks for the path (``kinematic.build_in_thread``): solved from the
    path, it gives exactly the guess ``kinematic_guess`` builds and solves in line."""
    from stlc.backends.nlp import kinematic

    program, mission = _problem(TRAP, tmp_path, "trap")
    problem = from_mission(program, mission)
    join = kinematic.build_in_thread(problem)
    paths, _ = milp_seed.plan(problem)
    nlp = join()
    assert nlp is not None and nlp.rows  # the far box's branch and window: parameters
    got, want = nlp.solve(paths), schedule.kinematic_guess(problem, path=paths)
    for name in want:
        for a, b in zip(got[name], want[name]):
            np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError):
        nlp.solve(None)  # a seeded NLP keeps a path's choices: it needs the path


# a straight 5 m run under `speed <= 1 m/s`: the seed's box inside the speed ball allows
# 1/√3 ≈ 0.58 m/s per axis, 4.3 m in 7.5 s — no path reaches the goal (x ≥ 4.55 for
# κ = 0.05); the box around the ball allows 1 m/s per axis, and the plan flies x at 0.9 m/s
RUN = """\
vehicle p : point_mass {
  vel_max = (2, 2, 2) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  workspace = box((-1, -2, 0), (7, 2, 2)) m
  target goal = box((4.5, -0.5, 0.5), (5.5, 0.5, 1.5)) m
}
mission run {
  vehicles = [p]
  horizon = 8 s
  step = 0.25 s
  threshold = 0.05
  spec safe = always[0, 8] (p.pos in workspace and p.speed <= 1 m/s)
  spec reach = eventually[0, 7.5] (p.pos in goal)
  require safe and reach
  maximize robustness
}
"""


def test_no_path_within_the_inner_bounds_is_looked_for_with_them_relaxed(tmp_path):
    program, mission = _problem(RUN, tmp_path, "run")
    problem = from_mission(program, mission)
    paths, rec = milp_seed.plan(problem)
    assert paths is None and rec["status"] == "Infeasible"
    loose, loose_rec = milp_seed.plan(problem, relaxed=True)
    assert loose is not None and loose_rec["relaxed"] == milp_seed.RELAX
    assert np.max(np.abs(loose["p"][1])) > 1 / np.sqrt(3)  # faster than the inner box
    _, sol = pipeline.plan(program, mission, backend="nlp")
    seed = sol.solver["chain"]["stages"][0]["seed"]
    assert seed["relaxed"] == milp_seed.RELAX and seed["inner_phases"][0][1] == "Infeasible"
    assert "proof_s" not in seed  # a path was found: nothing to prove
    assert sol.status == "satisfied"
    ch = {k: np.asarray(v) for k, v in sol.channels.items()}
    assert monitor.robustness(problem.requirement, problem.grid.dt, ch,
                              problem.params) >= problem.threshold
