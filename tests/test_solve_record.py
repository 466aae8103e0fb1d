"""The typed solve record (``stlc.planning.record``): what backends record is read back
typed, written to ``solution.json`` unchanged, and the notes a user is shown come from it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.backends import strategy
from stlc.planning.record import Assignment, ChainRecord, SolveRecord, StopReason
from stlc.planning.solution import Solution, Verdict
from stlc.solvers.status import SolverStatus


def _solution(solver: dict) -> Solution:
    t = np.linspace(0.0, 1.0, 3)
    return Solution("m", Verdict.VIOLATED, float("nan"), float("nan"), {}, 0.0, t,
                    {"uav1.pos.x": np.zeros(3)}, solver=solver, routes={"uav1": ["a"]})


def test_a_dict_is_read_typed_and_written_back_as_it_was():
    raw = {"name": "HiGHS MILP (highspy)", "return_status": "max_time", "objective": -1.5,
           "status": "max_time", "converged": False, "iterations": 12,
           "chain": {"name": "milp", "forced": False,
                     "stages": [{"backend": "exact MILP (HiGHS)", "status": "max_time",
                                 "converged": False}]},
           "stopped_by": "time_limit", "phases": [["feasibility", "Optimal", 0.1]]}
    rec = SolveRecord.of(raw)
    assert rec.status is SolverStatus.MAX_TIME and not rec.status.converged
    assert isinstance(rec.chain, ChainRecord) and rec.chain.stages[0].converged is False
    assert rec.stopped_by is StopReason.TIME_LIMIT and rec.iterations == 12
    assert rec.details == {"objective": -1.5, "phases": [["feasibility", "Optimal", 0.1]]}
    out = rec.to_json()
    assert out == raw and list(out) == list(raw)  # same keys, same order


keys = st.sampled_from(["name", "status", "return_status", "converged", "iterations",
                        "objective", "gap", "nodes", "rounds", "message"])
values = {"name": st.text(max_size=5), "status": st.sampled_from([str(s) for s in SolverStatus]),
          "return_status": st.text(max_size=5), "converged": st.booleans(),
          "iterations": st.integers(0, 10**6)}


@settings(deadline=None)
@given(st.lists(keys, unique=True), st.data())
def test_any_record_round_trips(order, data):
    raw = {k: data.draw(values.get(k, st.floats(allow_nan=False)), label=k) for k in order}
    assert SolveRecord.of(raw).to_json() == raw
    assert list(SolveRecord.of(raw).to_json()) == order


def test_a_solution_reads_a_dict_into_a_record():
    sol = _solution({"name": "x", "status": "optimal"})
    assert isinstance(sol.solver, SolveRecord) and sol.solver.status is SolverStatus.OPTIMAL
    sol.solver = {}
    assert isinstance(sol.solver, SolveRecord) and not sol.solver


def _team(method: str, incumbent: str) -> tuple[Solution, Solution]:
    seed = _solution({"name": "task-assignment MILP", "status": "max_time",
                      "assignment": Assignment(method, incumbent), "incumbent": incumbent})
    final = _solution({"name": "team refinement"})
    strategy._team_comparisons([seed, final])
    return seed, final


def test_a_budget_stop_with_the_milp_s_own_incumbent_is_not_called_the_heuristic():
    """The assignment MILP stopped on its budget holding its own incumbent: the note says
    so; it does not say the routes come from the heuristic."""
    seed, final = _team("greedy", "milp")
    assert seed.solver.to_json()["assignment"] == "greedy"  # the contract's value
    assert len(final.notes) == 1
    assert "its best incumbent" in final.notes[0] and "heuristic" not in final.notes[0]
    assert final.solver["seed"]["incumbent"] == "milp"


def test_the_notes_follow_where_the_routes_came_from():
    assert "the heuristic" in _team("greedy", "heuristic")[1].notes[0]
    assert "greedy rule" in _team("greedy", "greedy")[1].notes[0]
    assert _team("milp", "")[1].notes == []  # optimal: nothing to say


def test_a_record_crosses_a_process_boundary():
    """A solve apart (``stlc.apart``) or a sweep worker pickles its record."""
    import copy
    import pickle

    rec = SolveRecord.of({"name": "x", "status": "optimal", "objective": 1.0,
                          "chain": {"name": "nlp", "forced": False,
                                    "stages": [{"backend": "a", "status": "optimal",
                                                "converged": True}]}})
    for other in (pickle.loads(pickle.dumps(rec)), copy.deepcopy(rec)):
        assert other.to_json() == rec.to_json() and other.status is SolverStatus.OPTIMAL
