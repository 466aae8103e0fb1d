"""The README's "Adding a vehicle model" and "Adding a backend" checklists, followed in a
test (in the spirit of ruff's ``scripts/add_rule.py``): a toy vehicle model and a toy
backend are added *only* through the steps the checklists name, and the mission that uses
them is checked, planned, verified by the exact monitor and written with its report.

* the toy vehicle ``drag``: a double integrator with linear drag, ṗ = v, v̇ = a − c·v,
  per-axis bounds on v and a (a new declared dataclass, a ``VehicleModel``, ``register``,
  a block reader in ``READERS``, and its kind in the capabilities of the CasADi backends);
* the toy backend ``hover``: plans "stay where you start" for point masses (``lower``,
  ``solve``, ``invert`` to a ``Solution``, a status map).

Every number asserted is computed here by hand.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import pytest

from stlc import vehicles
from stlc.backends.base import (ALL_FUNCTIONS, ALL_NODES, Backend, Capabilities,
                                SolverStatus, run_chain)
from stlc.backends.nlp.backend import CasadiNlp, KinematicGuess
from stlc.diagnostics import Span
from stlc.planning.problem import from_mission
from stlc.planning.solution import Solution, Verdict
from stlc.planning.verify import verify
from stlc.semantics.check import declarations, units
from stlc.vehicles import dynamics
from stlc.vehicles.declared import AXES, FormulaField

from test_backends import check_backend_contract

# ---------------------------------------------------------------- a toy vehicle model

DRAG = 0.5  # 1/s


@dataclass(frozen=True, slots=True)
class Drag:
    """Step 1: the declared data."""

    name: str
    vel_max: tuple[float, float, float]
    acc_max: tuple[float, float, float]
    start_pos: tuple[float, float, float]
    span: Span = field(default=Span.none(), compare=False)

    kind = "drag"


class DragModel:
    """Step 2: the model's behaviour, behind ``VehicleModel``."""

    kind = "drag"

    def state_size(self, v):
        return 6, 3

    def state_channels(self, v):
        return [f"{v.name}.{f}.{a}" for f in ("pos", "vel") for a in AXES]

    def input_channels(self, v):
        return [f"{v.name}.acc.{a}" for a in AXES]

    def derived_names(self, v):
        return [f"{v.name}.speed", f"{v.name}.course"]

    def all_channels(self, v):
        return self.state_channels(v) + self.input_channels(v) + self.derived_names(v)

    def pos_index(self):
        return slice(0, 3)

    def vel_index(self):
        return slice(3, 6)

    def ode(self, v):
        x, u = ca.SX.sym("x", 6), ca.SX.sym("u", 3)
        return ca.Function("drag", [x, u], [ca.vertcat(x[3:6], u - DRAG * x[3:6])])

    def bounds(self, v):
        vm, am = np.asarray(v.vel_max, float), np.asarray(v.acc_max, float)
        lo, hi = np.full(6, -np.inf), np.full(6, np.inf)
        lo[3:], hi[3:] = -vm, vm
        return dynamics.Bounds(lo, hi, -am, am.copy())

    def initial_state(self, v):
        return np.concatenate([v.start_pos, np.zeros(3)]).astype(float)

    def derived_channels(self, v, X):
        X = np.atleast_2d(np.asarray(X, float))
        return {f"{v.name}.speed": np.linalg.norm(X[:, 3:6], axis=1),
                f"{v.name}.course": np.arctan2(X[:, 4], X[:, 3])}

    def derived_channels_sx(self, v, x, eps=0.0):
        return {f"{v.name}.speed": ca.sqrt(ca.dot(x[3:6], x[3:6]) + eps**2),
                f"{v.name}.course": ca.atan2(x[4], x[3])}

    def energy_terms(self, v, x, dt):
        return None

    def energy_profile(self, v, X, dt):
        return np.zeros(np.atleast_2d(X).shape[0])

    def kinematic_limits(self, v):
        return np.array(v.vel_max, float), np.array(v.acc_max, float)

    def guess(self, v, P, V, A, dt):
        return np.vstack([P, V]), A + DRAG * V[:, :-1]

    def plot_bounds(self, v):
        return {}

    def formula_fields(self, v):
        acc = tuple(f"{v.name}.acc.{a}" for a in AXES)
        return {"acc": FormulaField(units.ACCEL, acc, acc, True)}

    def envelope(self, v, b):
        return b

    def fit_guess_inputs(self, v, U, lo, hi):
        return np.clip(U, lo[:, None], hi[:, None])

    def has_rotor_energy(self, v):
        return False

    def carries_payload(self, v):
        return False

    def axis_limits(self, v):
        return {"vel": tuple(v.vel_max), "acc": tuple(v.acc_max)}

    def rotor_forces(self, v):
        return None

    def linear_model(self, v, dt=None):
        eye, zero = np.eye(3), np.zeros((3, 3))
        return np.block([[zero, eye], [zero, -DRAG * eye]]), np.vstack([zero, eye])


def read_drag(ck, b):
    """Step 1 (checker): read the ``vehicle NAME : drag { ... }`` block."""
    f = ck.fields(b, {"vel_max": True, "acc_max": True}, sub_blocks=("start",))
    vmax = ck.vec(f, "vel_max", 3, units.SPEED)
    amax = ck.vec(f, "acc_max", 3, units.ACCEL)
    start = declarations._start(ck, b, {"pos": units.LENGTH})
    if vmax is None or amax is None or start.get("pos") is None:
        return None
    return Drag(b.name, vmax, amax, start["pos"], b.span)


@pytest.fixture
def with_drag(monkeypatch):
    """Steps 1–3: register the model and its reader, list its kind in the capabilities of
    the backends that can plan it (undone after the test)."""
    monkeypatch.setitem(vehicles._REGISTRY, Drag, DragModel())
    monkeypatch.setitem(declarations.READERS, "drag", read_drag)
    for cls in (KinematicGuess, CasadiNlp):
        cap = cls.capabilities
        monkeypatch.setattr(cls, "capabilities", Capabilities(
            vehicle_models=cap.vehicle_models | {"drag"}, nodes=cap.nodes,
            functions=cap.functions, team=cap.team, derived_signals=cap.derived_signals))


DRAG_SOURCE = """\
vehicle r1 : drag {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0, 0, 1) m }
}
scenario {
  target goal = box((1.5, -0.5, 0.5), (2.5, 0.5, 1.5)) m
}
mission reach {
  vehicles = [r1]
  horizon = 4 s
  step = 0.25 s
  threshold = 0.05
  spec reach = eventually[0, 4] (r1.pos in goal)
  spec slow = always[0, 4] (r1.speed <= 1 m/s and r1.acc.x <= 2 m/s^2)
  require reach and slow
  maximize robustness
}
"""


def test_a_toy_vehicle_model_compiles_end_to_end(with_drag, tmp_path):
    from stlc.analysis import monitor
    from stlc.output.compile import write_outputs
    from stlc.pipeline import load, plan

    path = tmp_path / "drag.stl"
    path.write_text(DRAG_SOURCE, encoding="utf-8")
    out = tmp_path / "out"
    program = load(str(path)).program
    problem, sol = plan(program, program.missions["reach"])
    write_outputs(str(out), program, program.missions["reach"], sol)
    data = json.loads((out / "solution.json").read_text())
    assert data["status"] == "satisfied" and (out / "report.html").is_file()
    ch = sol.channels
    # the plan obeys the toy dynamics (RK4 of ṗ = v, v̇ = a − c v, inputs held) ...
    X = np.stack([ch[f"r1.{f}.{a}"] for f in ("pos", "vel") for a in AXES], axis=1)
    U = np.stack([ch[f"r1.acc.{a}"] for a in AXES], axis=1)
    F = dynamics.discrete_dynamics(DragModel().ode(None), 0.25, "rk4", 3)
    pred = np.array([np.asarray(F(X[k], U[k])).ravel() for k in range(len(X) - 1)])
    assert np.max(np.abs(pred - X[1:])) < 1e-5
    # ... and reaches the box: exact robustness by hand = best depth inside the goal box
    depth = np.minimum.reduce([X[:, 0] - 1.5, 2.5 - X[:, 0], X[:, 1] + 0.5, 0.5 - X[:, 1],
                               X[:, 2] - 0.5, 1.5 - X[:, 2]])
    slow = np.minimum(1.0 - np.linalg.norm(X[:, 3:6], axis=1), 2.0 - U[:, 0])
    assert sol.specs["reach"].robustness == pytest.approx(depth.max(), abs=1e-9)
    assert sol.specs["slow"].robustness == pytest.approx(slow.min(), abs=1e-9)
    assert sol.robustness_exact >= 0.05
    assert data["robustness"]["exact"] == pytest.approx(
        float(monitor.robustness(problem.requirement, 0.25, ch, problem.params)))


def test_an_unregistered_kind_is_an_input_error(tmp_path):
    from stlc.diagnostics import StlcError
    from stlc.pipeline import load

    path = tmp_path / "drag.stl"
    path.write_text(DRAG_SOURCE, encoding="utf-8")
    with pytest.raises(StlcError) as e:
        load(str(path))
    assert [d.code for d in e.value.diagnostics][:1] == ["STL105"]


# ---------------------------------------------------------------- a toy backend


class Hover(Backend):
    """Plans every point mass to stay at its start (the plan a seedless fallback could
    offer); ``solve`` is trivial, the verdict is the verification pass's."""

    name = "hover"
    capabilities = Capabilities(vehicle_models=frozenset({"point_mass"}), nodes=ALL_NODES,
                                functions=ALL_FUNCTIONS, derived_signals=frozenset({"payload"}))
    STATUS_MAP = {"done": SolverStatus.OPTIMAL, "nothing": SolverStatus.FAILED}

    def lower(self, problem):
        starts = {v.name: vehicles.model_of(v).initial_state(v) for v in problem.vehicles()}
        return starts, problem.grid.n

    def solve(self, lowered, problem):
        return "done", lowered

    def invert(self, raw, inverse, problem):
        code, starts = raw
        n = inverse
        ch = {}
        for v in problem.vehicles():
            vm = vehicles.model_of(v)
            for c, x in zip(vm.state_channels(v), starts[v.name]):
                ch[c] = np.full(n, x)
            for c in vm.input_channels(v):
                ch[c] = np.zeros(n)
        return Solution(mission=problem.mission.name, status=Verdict.VIOLATED,
                        robustness_exact=float("nan"), robustness_smooth=float("nan"),
                        specs={}, energy=0.0, times=problem.grid.times(), channels=ch,
                        solver={"name": self.name, "status": str(self.status(code)),
                                "converged": self.status(code).converged})


HOVER_SOURCE = """\
vehicle d1 : point_mass {
  vel_max = (1, 1, 1) m/s
  acc_max = (2, 2, 2) m/s^2
  start { pos = (0.25, 0, 1.5) m }
}
mission stay {
  vehicles = [d1]
  horizon = 3 s
  step = 0.5 s
  spec high = always[0, 3] (d1.pos.z >= 1 m)
  spec away = eventually[0, 3] (d1.pos.x >= 1 m)
  require high
  maximize robustness
}
"""


def test_a_toy_backend_plans_through_the_interface(tmp_path):
    from stlc.pipeline import load

    check_backend_contract(Hover)
    path = tmp_path / "stay.stl"
    path.write_text(HOVER_SOURCE, encoding="utf-8")
    program = load(str(path)).program
    problem = from_mission(program, program.missions["stay"])
    sol, sols = run_chain(problem, [Hover()])
    verify(problem, sol)
    # by hand: z stays 1.5 → always(z ≥ 1) = 0.5; x stays 0.25 → eventually(x ≥ 1) = −0.75
    assert sol.robustness_exact == pytest.approx(0.5)
    assert sol.specs["high"].robustness == pytest.approx(0.5)
    assert sol.specs["away"].robustness == pytest.approx(-0.75)
    assert sol.status == Verdict.SATISFIED and sol.solver["converged"]
    # the binding predicate's source line comes from its span
    assert (sol.specs["high"].binding_line, sol.specs["away"].binding_line) == (10, 11)
    assert np.allclose(sol.channels["d1.speed"], 0.0)  # derived signals recomputed
