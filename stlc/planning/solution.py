"""The result every planner returns, in mission-level names only: ``Solution`` and its
companion types (``Verdict``, ``SpecResult``, ``Comparison``, ``Window``).

This is the other half of the planning contract (``stlc.planning.problem.PlanningProblem``
in, ``Solution`` out): backends ``invert`` their raw solver output into a ``Solution``; the
verification pass (``stlc.planning.verify``) judges it; the report, ``solution.json`` and
``trajectory.csv`` are written from it by the output layer (``stlc.output.solution``) and
never see a solver object.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from stlc.planning.record import SolveRecord
from stlc.semantics.origin import Origin


class Verdict(enum.StrEnum):
    """What the exact monitor says of a plan (``Solution.status``)."""

    SATISFIED = "satisfied"
    VIOLATED = "violated"
    SOLVER_FAILED = "solver_failed"  # no dynamically feasible plan came out of the solver
    INFEASIBLE = "infeasible"  # proved: no plan can satisfy the mission (``conflict``)
    STOPPED = "stopped"  # the run's time limit ended the search before a satisfying plan


@dataclass
class SpecResult:
    """Exact (and smooth) robustness of one named spec at t = 0, and where it is tightest."""

    robustness: float
    smooth: float | None = None
    satisfied: bool = False
    tightest_time: float | None = None  # time of the sample whose predicate binds
    binding_predicate: str = ""  # label of the predicate that decides the robustness
    line: int = 0  # source line of the spec definition
    binding_line: int = 0  # source line of that predicate (from its span; 0 if unknown)
    #: what that predicate is (a box face, a range side, negated or not), as data
    binding_origin: Origin | None = None


@dataclass
class Comparison:
    """A second plan of the same mission (``compare NAME { ... }``, or a team seed)."""

    label: str
    channels: dict[str, np.ndarray]
    energy: float = 0.0
    energy_profile: np.ndarray | None = None
    robustness_exact: float | None = None  # set by verification
    specs: dict[str, float] = field(default_factory=dict)  # exact robustness per named spec
    peak_speed: float | None = None
    peak_rotor_speed: float | None = None

@dataclass(frozen=True, slots=True)
class Window:
    """The outermost time window of a named spec (shaded on the report's plots)."""

    spec: str
    start: float
    end: float


@dataclass
class Solution:
    mission: str
    status: str  # satisfied | violated | solver_failed | stopped
    robustness_exact: float
    robustness_smooth: float
    specs: dict[str, SpecResult]
    energy: float
    times: np.ndarray  # (n,)
    channels: dict[str, np.ndarray]  # every state/input/derived channel, each (n,)
    #: parse_s check_s build_s solve_s total_s
    timing: dict[str, float] = field(default_factory=dict)
    #: what the planners did (``stlc.planning.record``); a dict given is read into one
    solver: SolveRecord = field(default_factory=SolveRecord)
    smoothing: dict[str, object] = field(default_factory=dict)  # method, lam, schedule
    problem_size: dict[str, int] = field(default_factory=dict)  # variables, constraints, samples
    notes: list[str] = field(default_factory=list)
    #: energy of each sample (J, summing to ``energy``), None without an energy model
    energy_profile: np.ndarray | None = None
    #: energy per vehicle (J), for the vehicles with an energy model (set by verification)
    energy_by_vehicle: dict[str, float] = field(default_factory=dict)
    comparisons: list[Comparison] = field(default_factory=list)
    #: limits drawn on the report's signal plots, from the vehicles and the predicates
    bounds: dict[str, object] = field(default_factory=dict)
    windows: list[Window] = field(default_factory=list)
    feasible: bool = True  # the plan obeys the vehicles' dynamics (backend's own test)
    risk: dict | None = None  # risk.json contents, when the mission's risk cases ran
    risk_results: list | None = None  # per-realisation samples (in memory, for the report)
    #: located findings about the plan (e.g. STL501 at the failing spec), shown in the report
    diagnostics: list = field(default_factory=list)
    #: team missions: each drone's ordered targets and stations (from the assignment), the
    #: planned dwells (``stlc.team.Visit``) and the payload events that verification
    #: recomputed from the positions (``stlc.team.PayloadEvent``)
    routes: dict[str, list[str]] = field(default_factory=dict)
    visits: list = field(default_factory=list)
    events: list = field(default_factory=list)
    #: an infeasible mission: a minimal set of named specs that cannot hold together
    conflict: list[str] = field(default_factory=list)
    #: per vehicle: can it hold the final state (``stlc.planning.holdable``)
    end_state: dict[str, dict] = field(default_factory=dict)
    #: the solver's own state samples, before ``channels`` re-simulated them from the
    #: inputs (``stlc.planning.boundary``: a plan on the boundary judged on its own numbers)
    solver_states: dict[str, np.ndarray] = field(default_factory=dict)

    def __setattr__(self, key: str, value) -> None:
        if key == "solver":
            value = SolveRecord.of(value)
        object.__setattr__(self, key, value)
