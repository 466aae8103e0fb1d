"""A multirotor's mission on its own grid planned with the MILP seed's timing kept
(``stlc.backends.knots.timed``): the default chain of a handover; every window is narrowed
around the seed's sample, the exact monitor judges the plan against the requirement as
written, and a plan that misses κ is planned again by the ``nlp`` chain with the times
free."""

from __future__ import annotations

from pathlib import Path

import pytest

from stlc import deadline, pipeline
from stlc.analysis import monitor
from stlc.backends import strategy
from stlc.backends.knots.timed import TIMING_SLACK_S
from stlc.planning.problem import from_mission

SPEC = Path(__file__).resolve().parent.parent / "specs" / "handover.stl"
LIMIT_S = 240


@pytest.fixture(scope="module")
def handover():
    program = pipeline.load(str(SPEC)).program
    return program, program.missions["handover_left_tb"]


def _exact(problem, sol) -> float:
    return float(monitor.robustness(problem.requirement, problem.grid.dt, sol.channels,
                                     problem.params))


def test_a_handover_is_planned_with_the_seeds_timing_and_satisfied(handover):
    program, mission = handover
    assert strategy.select(from_mission(program, mission)).name == "timed"
    with deadline.limited(LIMIT_S):
        problem, sol = pipeline.plan(program, mission)
    rec = sol.solver["chain"]
    assert rec["name"] == "timed" and rec["stages"][0]["backend"] == "timed nlp"
    assert sol.solver["seed_timing"] == {"kept": True, "slack_s": TIMING_SLACK_S}
    seed = sol.solver["seed"]
    assert isinstance(seed, dict) and seed["status"] == "Optimal"
    # the MILP with its choices free looked for a better class, as in the `nlp` chain
    assert any(p[0] == "better class (choices free)" for p in seed["phases"])
    # judged against the requirement as written, by the exact monitor
    assert sol.status == "satisfied"
    assert _exact(problem, sol) == sol.robustness_exact >= problem.threshold
    # the NLP carried smaller smooth-max trees than the formula as written's
    assert sol.problem_size["aux"] < 1200


def test_a_plan_with_the_seeds_timing_that_misses_kappa_is_planned_with_the_times_free(
        handover, monkeypatch):
    # the timed chain's plan is replaced by a hover (violated): the `nlp` chain plans the
    # mission again, the exact monitor judges its plan, and the record says what ran
    from stlc.backends.knots.timed import TimedNlp
    from stlc.planning.fallback import hover_solution

    def hovering(self, raw, inv, problem):
        sol = hover_solution(problem, "test")
        sol.solver["seed_timing"] = {"kept": True, "slack_s": TIMING_SLACK_S}
        return sol

    monkeypatch.setattr(TimedNlp, "solve", lambda self, lowered, problem: None)
    monkeypatch.setattr(TimedNlp, "invert", hovering)
    program, mission = handover
    with deadline.limited(LIMIT_S):
        problem, sol = pipeline.plan(program, mission)
    rec = sol.solver["chain"]
    assert rec["name"] == "nlp" and rec["fallback_from"]["name"] == "timed"
    assert any("planned with the times free" in n for n in sol.notes)
    assert sol.status == "satisfied"
    assert _exact(problem, sol) == sol.robustness_exact >= problem.threshold


def test_a_forced_nlp_chain_decides_the_times_itself(handover):
    program, mission = handover
    chain = strategy.select(from_mission(program, mission), "nlp")
    assert [b.name for b in chain.backends] == ["milp seed", "casadi/ipopt"]


SLOW = """\
vehicle q : multirotor {
  mass    = 1.4 kg
  inertia = diag(1.2e-2, 1.2e-2, 2.2e-2) kg*m^2
  c_f     = 11.5e-4
  c_tau   = 2.38e-5
  force   = [0.2 N, 9 N]
  rotors  = quadrotor(arm = 0.23 m)
  start { pos = (0, 0, 1) m; att = (0, 0, 0) deg }
}
scenario {
  workspace = box((-1, -1, 0), (4, 4, 3)) m
  region far = box((1.6, 1.6, 0.8), (2.0, 2.0, 1.2)) m
}
mission slow {
  vehicles = [q]
  horizon = 6 s
  step = 0.1 s
  spec safe = always[0, 6] (q.pos in workspace and q.speed <= 0.3 m/s)
  spec reach = eventually[4, 5] always[0, 1] (q.pos in far)
  require safe and reach
  minimize 0.5 * energy - robustness
}
"""


def test_without_a_seed_path_that_reaches_kappa_no_timing_is_kept_nor_planned_twice(
        tmp_path, monkeypatch):
    # the far box (at least 2.26 m away) in at most 5 s at 0.3 m/s (1.5 m) is out of
    # reach, and the proof's relaxation does not show it: the MILP finds no path, so there
    # is no timing to keep; the plan is the `nlp` chain's first one, and the `nlp` chain
    # does not plan the mission again (its seed has no choices to try others of)
    from stlc.backends.nlp.backend import CasadiNlp

    calls = []
    real = CasadiNlp.solve

    def counted(self, lowered, problem):
        calls.append(problem.name)
        return real(self, lowered, problem)

    monkeypatch.setattr(CasadiNlp, "solve", counted)
    f = tmp_path / "slow.stl"
    f.write_text(SLOW)
    program = pipeline.load(str(f)).program
    with deadline.limited(LIMIT_S):
        problem, sol = pipeline.plan(program, program.missions["slow"])
    assert sol.solver["seed_timing"]["kept"] is False
    rec = sol.solver["chain"]
    assert rec["name"] == "timed" and rec.get("fallback_from") is None
    assert len(calls) == 1
    assert sol.status == "violated"
    assert _exact(problem, sol) == sol.robustness_exact < problem.threshold
