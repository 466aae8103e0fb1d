"""What ``stlc simulate`` returns: the event log, the executed trajectory and its verdict.

The pipeline writes ``replan.json`` (``SimulationResult.to_json_dict``) and
``executed.csv`` from it, and the report draws the nominal, disturbed and replanned paths;
nothing downstream re-derives what the simulation knew.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from stlc.analysis import verdict
from stlc.strictjson import channels_csv, json_number, strict_dumps


@dataclass
class ReplanEvent:
    """One event instant (every T_e), or a drone failure.

    ``kind`` is ``"check"`` for an event instant of the disturbance scheme (``triggered``
    when the deviation exceeds ζ) and ``"failure"`` for a backup-drone takeover.
    """

    time: float  # s
    vehicle: str
    deviation: float  # ‖p̃ − p*‖ (m) against the reference being flown; 0 for a failure
    triggered: bool
    kind: str = "check"
    solve_s: float | None = None  # wall time of the replan (build excluded)
    status: str | None = None  # SolverStatus value of the replan, when triggered
    within_budget: bool | None = None  # solve_s <= budget (t_c, or the takeover goal)
    accepted: bool | None = None  # the replan was flown (converged, in budget, kept specs ok)
    segment: tuple[float, float] | None = None  # (start, end) s of the replanned segment
    kept: dict[str, float] = field(default_factory=dict)  # exact ρ of kept specs on it
    #: replanned channels on the segment (mission-level names, e.g. ``uav1.pos.x``)
    times: np.ndarray | None = None
    channels: dict[str, np.ndarray] = field(default_factory=dict)
    detail: dict[str, object] = field(default_factory=dict)  # iterations, targets, ...

    def to_json_dict(self) -> dict:
        d: dict = {"time": round(float(self.time), 6), "vehicle": self.vehicle,
                   "kind": self.kind, "deviation": json_number(self.deviation),
                   "triggered": bool(self.triggered)}
        if self.triggered:
            d.update({"solve_s": json_number(self.solve_s), "status": self.status,
                      "within_budget": self.within_budget, "accepted": self.accepted,
                      "segment": None if self.segment is None
                      else [round(float(s), 6) for s in self.segment],
                      "kept": {k: json_number(v) for k, v in self.kept.items()},
                      **({"detail": self.detail} if self.detail else {})})
        elif self.detail:  # e.g. an operator move that kept the plan: what it was kept on
            d["detail"] = self.detail
        return d


@dataclass
class SimulationResult:
    mission: str
    times: np.ndarray  # the mission grid (s)
    nominal: dict[str, np.ndarray]  # the compiled plan's channels
    executed: dict[str, np.ndarray]  # what was flown, same grid and names (+ backup's)
    events: list[ReplanEvent]
    budget: float  # s: t_c (disturbances) or the takeover goal
    #: exact robustness on the executed trajectory: ``mission`` (the requirement, for a
    #: takeover elaborated over the executed team) and each named spec
    executed_robustness: dict[str, float] = field(default_factory=dict)
    threshold: float = 0.0  # κ: a spec holds when its robustness >= κ
    disturbances: list = field(default_factory=list)  # model.Disturbance applied
    failures: list = field(default_factory=list)  # model.Failure applied
    notes: list[str] = field(default_factory=list)
    #: the names in ``executed_robustness`` the simulation must keep (set by the pipeline:
    #: the replan block's ``keep``, or ``mission`` for a takeover)
    kept: tuple[str, ...] = ()

    def ok(self) -> bool:
        """Every triggered replan was flown and the executed trajectory keeps the kept specs
        (robustness ≥ κ)."""
        if any(e.triggered and not e.accepted for e in self.events):
            return False
        return all(verdict.satisfied(self.executed_robustness.get(k, float("nan")),
                                     self.threshold) for k in self.kept)

    @property
    def triggered(self) -> list[ReplanEvent]:
        return [e for e in self.events if e.triggered]

    def to_json_dict(self) -> dict:
        solves = [e.solve_s for e in self.triggered if e.solve_s is not None]
        return {
            "mission": self.mission,
            "budget_s": json_number(self.budget),
            "events": [e.to_json_dict() for e in self.events],
            "replans": {"count": len(solves),
                        "median_s": json_number(float(np.median(solves))) if solves else None,
                        "max_s": json_number(max(solves)) if solves else None},
            "ok": self.ok(),
            "executed": {
                "kept": list(self.kept),
                "threshold": json_number(self.threshold),
                "robustness": {k: json_number(v) for k, v in self.executed_robustness.items()},
                "satisfied": {k: verdict.judge(v, self.threshold)
                              for k, v in self.executed_robustness.items()},
            },
            "notes": self.notes,
        }

    def to_json(self) -> str:
        return strict_dumps(self.to_json_dict(), indent=2)

    def executed_csv(self) -> str:
        return channels_csv(self.times, self.executed)
