"""The planning problem: one frozen object between the checked ``Program`` and any backend.

A ``PlanningProblem`` says *what* to plan — the team, the time grid, the requirement in
negation normal form, the named specs reported for the mission, the objective, start-state
overrides, channels held fixed (e.g. other drones' plans, which appear only in the specs
that read them), a time window, and an optional seed ``Solution`` from an earlier backend
of the chain.  Backends read it and never the AST; replanning and team seeds are expressed
as new problems (``dataclasses.replace`` or the ``with_*`` helpers), never as flags on a
backend.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from stlc.semantics import ir, model, nnf
from stlc.semantics.specs import NamedSpec, mission_specs
from stlc.semantics.timegrid import TimeGrid

if TYPE_CHECKING:
    from stlc.planning.solution import Solution

__all__ = ["NamedSpec", "PlanningProblem", "from_mission", "mission_specs"]


def _frozen(d: Mapping | None = None) -> Mapping:
    return MappingProxyType(dict(d or {}))


@dataclass(frozen=True)
class PlanningProblem:
    program: model.Program  # vehicles, scenario, nominal parameters
    mission: model.Mission  # the declaration (options, risk, replan, compare variants)
    team: tuple[str, ...]
    grid: TimeGrid
    requirement: ir.Formula  # in negation normal form
    specs: Mapping[str, NamedSpec]
    objective: model.Objective
    threshold: float  # κ
    smoothing: model.Smoothing
    start_states: Mapping[str, np.ndarray] = field(default_factory=_frozen)
    fixed_channels: Mapping[str, np.ndarray] = field(default_factory=_frozen)
    window: tuple[float, float] | None = None  # (start, end) s of the part being planned
    seed: Solution | None = None

    @property
    def params(self) -> dict[str, float]:
        return self.program.params

    def vehicles(self) -> list[model.Vehicle]:
        return [self.program.vehicles[n] for n in self.team]

    def with_seed(self, seed: Solution | None) -> PlanningProblem:
        return replace(self, seed=seed)

    def with_objective(self, objective: model.Objective) -> PlanningProblem:
        return replace(self, objective=objective, seed=None)


def from_mission(program: model.Program, mission: model.Mission, *,
                 step: float | None = None, horizon: float | None = None) -> PlanningProblem:
    """The planning problem of a checked mission (``step``/``horizon`` override the
    mission's, e.g. a reduced horizon in tests)."""
    if step is not None or horizon is not None:
        mission = replace(mission, step=step or mission.step,
                          horizon=horizon or mission.horizon)
    grid = TimeGrid.from_horizon(mission.horizon, mission.step)
    return PlanningProblem(
        program=program, mission=mission, team=tuple(mission.vehicles), grid=grid,
        requirement=nnf.normalize(mission.requirement),
        specs=_frozen(mission_specs(program, mission)), objective=mission.objective,
        threshold=mission.threshold, smoothing=mission.smoothing)
