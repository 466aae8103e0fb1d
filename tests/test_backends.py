"""The backend interface: every backend declares its capabilities, maps its solver's codes
to the shared status, and refuses an unsupported construct with STL401 at the construct's
own line before doing any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from stlc.backends.registry import registry
from stlc.backends.base import Backend, Capabilities, SolverStatus, run_chain
from stlc.diagnostics import StlcError
from stlc.pipeline import load
from stlc.planning.problem import from_mission
from stlc.semantics import ir

SOURCE = """\
vehicle d1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  capacity = 1
  start { pos = (0, 0, 1) m }
}
mission m {
  vehicles = [d1]
  horizon = 4 s
  step = 0.5 s
  spec reach = eventually[0, 4] (d1.pos.x >= 1 m)
  spec carry = always[0, 4] (d1.payload > 0.5)
  spec order = (d1.pos.z >= 0.5 m) until[0, 4] (d1.pos.x >= 0.5 m)
  require reach and carry and order
  maximize robustness
}
"""
LINE_CARRY, LINE_ORDER = 12, 13


@pytest.fixture
def problem(tmp_path: Path):
    path = tmp_path / "m.stl"
    path.write_text(SOURCE, encoding="utf-8")
    program = load(str(path)).program
    return from_mission(program, program.missions["m"])


def check_backend_contract(cls) -> None:
    """What holds for any backend, whatever its solver: it derives from ``Backend``,
    declares capabilities within the IR's node set, and maps its solver's own codes into
    ``SolverStatus`` with at least one converging code; an unknown code is a failure."""
    assert issubclass(cls, Backend)
    cap = cls.capabilities
    assert isinstance(cap, Capabilities) and cap.vehicle_models and cap.nodes
    # every formula node of the IR after normalisation is either supported or refused
    assert cap.nodes <= {ir.Pred, ir.TrueF, ir.FalseF, ir.And, ir.Or, ir.Always,
                         ir.Eventually, ir.Until, ir.Release, ir.Next}
    assert cls.STATUS_MAP and all(isinstance(s, SolverStatus)
                                  for s in cls.STATUS_MAP.values())
    assert any(s.converged for s in cls.STATUS_MAP.values())
    assert cls.status(cls, "no such code from any solver") == SolverStatus.FAILED


@pytest.mark.parametrize("name", sorted(registry()))
def test_every_backend_declares_capabilities_and_statuses(name):
    check_backend_contract(registry()[name])


def test_ipopt_codes_of_the_casadi_backends():
    for name in ("casadi", "kinematic"):
        cls = registry()[name]
        assert cls.STATUS_MAP["Solve_Succeeded"].converged
        assert not cls.STATUS_MAP["Maximum_Iterations_Exceeded"].converged


def test_highs_codes_of_the_exact_milp():
    cls = registry()["milp"]
    assert cls.STATUS_MAP["Optimal"].converged
    assert cls.STATUS_MAP["Time limit reached"] == SolverStatus.MAX_TIME
    assert not SolverStatus.MAX_TIME.converged


def test_unplanned_signal_is_refused_at_its_predicate(problem):
    diags = registry()["casadi"]().accepts(problem)
    assert [d.code for d in diags] == ["STL401"]
    assert diags[0].span.line == LINE_CARRY and "d1.payload" in diags[0].message


class _NoUntil(Backend):
    """A backend without `until` (e.g. a future MILP encoding of a fragment)."""

    name = "no-until"
    capabilities = Capabilities(vehicle_models=frozenset({"point_mass"}),
                                nodes=frozenset({ir.Pred, ir.And, ir.Or, ir.Always,
                                                 ir.Eventually}),
                                functions=frozenset(), derived_signals=frozenset({"payload"}))

    def lower(self, problem):  # pragma: no cover - must never be reached
        raise AssertionError("lower() ran although accepts() refused the problem")


def test_unsupported_node_refused_before_any_work(problem):
    with pytest.raises(StlcError) as e:
        run_chain(problem, [_NoUntil()])
    diags = e.value.diagnostics
    assert {d.code for d in diags} == {"STL401"}
    assert any(d.span.line == LINE_ORDER and "until" in d.message for d in diags)


def test_unsupported_vehicle_model(problem):
    class MultirotorOnly(_NoUntil):
        capabilities = Capabilities(vehicle_models=frozenset({"multirotor"}),
                                    nodes=_NoUntil.capabilities.nodes, functions=frozenset(),
                                    derived_signals=frozenset({"payload"}))

    diags = MultirotorOnly().accepts(problem)
    assert any("point_mass" in d.message and d.span.line == 1 for d in diags)
