"""When the schedule's stages count as meeting κ, and what follows a miss.

* A stage's plan that does not meet the dynamics never counts as meeting κ.  An IPOPT stage
  that stops on its iteration limit before any iterate met the dynamics returns its last
  iterate; the exact monitor on that iterate's *states* may well say ρ ≥ κ (it teleports
  into the box), but it is no plan.  The schedule used to accept it (an energy-first stage
  at max_iter ended the schedule, the verification then found the dynamics defect and
  called the plan violated, and the whole mission was planned again from another seed: a
  random handover took 30 s instead of 4–14 s).  ``Stage.meets`` asks for both.
* A sweep instance warm-started from a neighbour's plan whose energy stage misses κ gets no
  constrained energy stage and no robustness schedule from that plan: it is planned from
  its own MILP seed, as its compile would be (``LibrarySeed.next_seed``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from stlc.backends.nlp import model as casadi_nlp
from stlc.backends.nlp import schedule
from stlc.backends.nlp.model import FEASIBLE_DEFECT, Stage
from stlc.pipeline import load
from stlc.planning.problem import from_mission

ROOT = Path(__file__).resolve().parents[1]


def test_a_stage_meets_kappa_only_with_a_feasible_plan():
    st = Stage("energy", 30.0, 99, "max_iter", 0.0, 0.2, 1.0, 0.0)
    assert st.meets(0.01) and st.score() == 0.2
    st.feasible = False
    assert not st.meets(0.01) and st.score() == -np.inf


def test_a_teleporting_last_iterate_is_marked_infeasible():
    program = load(str(ROOT / "tests" / "missions" / "hexa_climb.stl")).program
    problem = from_mission(program, program.missions["climb"])
    prob, inv = casadi_nlp.build(problem)
    n = inv.grid.n
    P = np.tile([[1.1], [0.0], [1.5]], n)  # the shelf's centre from the second sample on
    P[:, 0] = [0.0, 0.0, 1.0]  # the start: a 0.64 m jump in one step
    kin = {"uav1": (P, np.zeros((3, n)), np.zeros((3, n - 1)))}
    w0 = schedule.full_guess(program, prob, inv, kin, problem.smoothing.lam)
    assert casadi_nlp.exact_robustness(inv.formula, inv, w0, inv.params) >= problem.threshold
    assert casadi_nlp.dynamics_defect(w0, inv, problem.integrator) > FEASIBLE_DEFECT

    prob.progress.kappa = problem.threshold
    w, stats, _, _ = schedule._solve(prob, w0, [problem.smoothing.lam, 1.0, 0.5, 0.0], None,
                                     "test", 1, most_robust=False)
    defect = casadi_nlp.dynamics_defect(w, inv, problem.integrator)
    assert defect > FEASIBLE_DEFECT and stats["feasible"] is False
    # and a converged solve's plan is marked feasible, as the dynamics say
    w, stats, _, _ = schedule._solve(prob, w0, [problem.smoothing.lam, 1.0, 0.5, 0.0], None,
                                     "test", 300, most_robust=False)
    assert stats["feasible"] == (casadi_nlp.dynamics_defect(w, inv, problem.integrator)
                                 <= FEASIBLE_DEFECT)
    assert stats["feasible"]


def test_a_warm_energy_stage_that_misses_kappa_is_not_retried_constrained():
    # κ = 0.5 is beyond any plan of the climb (the shelf's half-height is 0.2 m), so every
    # energy stage misses it: from the seed's guess the constrained stage is tried too, from
    # a neighbour's plan (a sweep's warm start) it is not
    from dataclasses import replace

    program = load(str(ROOT / "tests" / "missions" / "hexa_climb.stl")).program
    problem = replace(from_mission(program, program.missions["climb"]), threshold=0.5)
    prob, inv = casadi_nlp.build(problem)
    n = inv.grid.n
    P = np.tile([[0.0], [0.0], [1.0]], n)
    kin = {"uav1": (P, np.zeros((3, n)), np.zeros((3, n - 1)))}
    w0 = schedule.full_guess(program, prob, inv, kin, problem.smoothing.lam)
    labels = {}
    for warm in (False, True):
        stages = []
        record = lambda label, *a, **k: stages.append(label) or Stage(  # noqa: E731
            label, 10.0, 0, "optimal", 0.0, 0.0, 0.0, 0.0)
        prob.progress.kappa = problem.threshold
        assert schedule._warm_energy(prob, inv, w0, problem.params, problem, record,
                                     retry=not warm)[2] is False
        labels[warm] = stages
    assert labels == {False: ["energy", "energy (constrained)"], True: ["energy"]}


def test_a_warm_start_that_misses_kappa_is_planned_from_the_instances_own_seed(monkeypatch):
    # a sweep instance started from a neighbour's plan (here: hovering at the start, which
    # violates `reach`) whose energy stage misses κ (forced: the warm stage — the one
    # without the constrained retry — hands back its start) stops there and is planned
    # again from its own MILP seed, as its compile would be; the row counts both tries'
    # iterations and says it was replanned
    from stlc import pipeline
    from stlc.backends.nlp.library import LibrarySeed
    from stlc.planning.fallback import hover_solution
    from stlc.sweeping import task

    path = str(ROOT / "tests" / "missions" / "hexa_climb.stl")
    source = Path(path).read_text(encoding="utf-8")
    program = load(path).program
    hover = hover_solution(from_mission(program, program.missions["climb"]), "test").channels
    real = schedule._warm_energy
    calls = []

    def missing(prob, inv, w0, params, problem, record, retry=True):
        w_e, lam_e, met = real(prob, inv, w0, params, problem, record, retry)
        calls.append(retry)
        return (w_e, lam_e, met) if retry else (w0, lam_e, False)

    monkeypatch.setattr(schedule, "_warm_energy", missing)
    sols = []
    real_plan = pipeline.plan
    monkeypatch.setattr(pipeline, "plan", lambda *a, **k: sols.append(real_plan(*a, **k))
                        or sols[-1])
    row = task._plan(source, path, "climb", [], {}, True, [({}, hover, "hover")])
    assert calls == [False, True]  # warm (missed), then the instance's own seed's guess
    assert row["warm"] == "plan library" and row["replanned"] == 1
    assert row["status"] == "satisfied" and row["robustness"] >= 0.0
    chain = sols[0][1].solver["chain"]
    assert chain["next_choices"][0]["seed"] == LibrarySeed.NEXT_LABEL
    first, again = chain["first_try"]["iterations"], chain["next_choices"][0]["iterations"]
    assert first > 0 and again > 0 and row["iterations"] == first + again
