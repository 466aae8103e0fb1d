"""The planning problem: one frozen object between the checked ``Program`` and any backend.

A ``PlanningProblem`` says *what* to plan — the team, the time grid, the requirement in
negation normal form, the named specs reported for the mission, the objective, the threshold
κ, the smoothing, the discrete model (``integrator``), whether the end state must be
holdable, the comparison variants, start-state overrides, channels held fixed (e.g. other
drones' plans, which appear only in the specs that read them), a time window, and an
optional seed ``Solution`` from an earlier backend of the chain.  Backends read these typed
fields and never the mission as written (``mission`` is kept for its name, span and the
declarations of the passes after planning: risk, replanning); a problem derived with
``dataclasses.replace`` (another requirement, threshold, objective, start state) is planned
as it says.  Replanning and team seeds are expressed as new problems (``replace`` or the
``with_*`` helpers), never as flags on a backend.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from stlc import vehicles
from stlc.semantics import ir, model, nnf
from stlc.semantics.specs import NamedSpec, mission_specs
from stlc.semantics.timegrid import TimeGrid

if TYPE_CHECKING:
    from stlc.planning.solution import Solution

__all__ = ["NamedSpec", "PlanningProblem", "from_mission", "mission_specs"]


def frozen(d: Mapping | None = None) -> Mapping:
    return MappingProxyType(dict(d or {}))


@dataclass(frozen=True)
class PlanningProblem:
    program: model.Program  # vehicles, scenario, nominal parameters
    mission: model.Mission  # the declaration: name, span, risk, replan (not read to plan)
    team: tuple[str, ...]
    grid: TimeGrid
    requirement: ir.Formula  # in negation normal form
    specs: Mapping[str, NamedSpec]
    objective: model.Objective
    threshold: float  # κ
    smoothing: model.Smoothing
    integrator: str = "rk4"  # the discrete model: "rk4" or "euler"
    hold_end: bool = True  # the last sample must be a state the vehicle can hold
    max_iter: int = 1000  # the NLP's iteration limit per stage
    #: other objectives planned for comparison (name, objective; None: not plannable)
    comparisons: tuple[tuple[str, model.Objective | None], ...] = ()
    time_limit: float | None = None  # s of wall time for a solve (`--time-limit` wins)
    #: a vehicle's start state (its model's state vector) other than the declared one
    start_states: Mapping[str, np.ndarray] = field(default_factory=frozen)
    fixed_channels: Mapping[str, np.ndarray] = field(default_factory=frozen)
    window: tuple[float, float] | None = None  # (start, end) s of the part being planned
    #: a team problem's targets to install and refilling stations to use (names; None: all
    #: the scenario's) — a takeover's pending targets and free stations
    targets: tuple[str, ...] | None = None
    stations: tuple[str, ...] | None = None
    #: the ``--set`` values of this instance (SI, by name as written), already applied to
    #: ``program`` (its params and vehicle starts are the NLP's parameters: nlp_cache.bind)
    values: Mapping[str, float] = field(default_factory=frozen)
    seed: Solution | None = None
    #: a replanning segment whose start already breaks a kept spec: it first leaves the
    #: spec's violation set by the shortest way back to κ, then keeps it
    recover: bool = False

    @property
    def params(self) -> dict[str, float]:
        return self.program.params

    @property
    def name(self) -> str:
        return self.mission.name

    def vehicles(self) -> list[model.Vehicle]:
        return [self.program.vehicles[n] for n in self.team]

    def start_state(self, name: str) -> np.ndarray:
        """The vehicle's start state: the problem's override, else the declared one."""
        if name in self.start_states:
            return np.asarray(self.start_states[name], dtype=float)
        v = self.program.vehicles[name]
        return np.asarray(vehicles.model_of(v).initial_state(v), dtype=float)

    def with_seed(self, seed: Solution | None) -> PlanningProblem:
        return replace(self, seed=seed)

    def with_objective(self, objective: model.Objective) -> PlanningProblem:
        return replace(self, objective=objective, seed=None)


def from_mission(program: model.Program, mission: model.Mission, *,
                 step: float | None = None, horizon: float | None = None,
                 values: Mapping[str, float] | None = None) -> PlanningProblem:
    """The planning problem of a checked mission (``step``/``horizon`` override the
    mission's, e.g. a reduced horizon in tests)."""
    if step is not None or horizon is not None:
        mission = replace(mission, step=step or mission.step,
                          horizon=horizon or mission.horizon)
    grid = TimeGrid.from_horizon(mission.horizon, mission.step)
    return PlanningProblem(
        program=program, mission=mission, team=tuple(mission.vehicles), grid=grid,
        requirement=nnf.normalize(mission.requirement),
        specs=frozen(mission_specs(program, mission)), objective=mission.objective,
        threshold=mission.threshold, smoothing=mission.smoothing,
        integrator=str(mission.options.get("integrator", "rk4")),
        hold_end=str(mission.options.get("end", "hover")) != "free",
        max_iter=int(mission.options.get("max_iter", 1000)),  # type: ignore[call-overload]
        comparisons=tuple(mission.options.get("compare") or ()),  # type: ignore[arg-type]
        time_limit=mission.options.get("time_limit"),  # type: ignore[arg-type]
        values=frozen(values))
