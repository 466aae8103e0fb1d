"""The result of compiling a mission, in mission-level names only.

Backends ``invert`` their raw solver output into a ``Solution``; the report, ``solution.json``
and ``trajectory.csv`` are written from it and never see a solver object.
"""

from __future__ import annotations

import csv
import enum
import io
import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

STATUSES = ("satisfied", "violated", "solver_failed", "stopped")


class Verdict(enum.StrEnum):
    """What the exact monitor says of a plan (``Solution.status``)."""

    SATISFIED = "satisfied"
    VIOLATED = "violated"
    SOLVER_FAILED = "solver_failed"  # no dynamically feasible plan came out of the solver
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

    def to_json_dict(self) -> dict:
        return {"label": self.label, "energy": json_number(self.energy),
                "robustness_exact": json_number(self.robustness_exact),
                "specs": {k: json_number(v) for k, v in self.specs.items()},
                "peak_speed": json_number(self.peak_speed),
                "peak_rotor_speed": json_number(self.peak_rotor_speed)}


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
    solver: dict[str, object] = field(default_factory=dict)  # name iterations return_status ...
    smoothing: dict[str, object] = field(default_factory=dict)  # method, lam, schedule
    problem_size: dict[str, int] = field(default_factory=dict)  # variables, constraints, samples
    notes: list[str] = field(default_factory=list)
    #: energy of each sample (J, summing to ``energy``), None without an energy model
    energy_profile: np.ndarray | None = None
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
    #: per vehicle: can it hold the final state (``stlc.planning.holdable``)
    end_state: dict[str, dict] = field(default_factory=dict)

    def to_json_dict(self) -> dict:
        num = json_number
        return {
            "mission": self.mission,
            "status": str(self.status),
            "robustness": {"exact": num(self.robustness_exact),
                           "smooth": num(self.robustness_smooth)},
            "specs": {
                k: {**asdict(v), "robustness": num(v.robustness), "smooth": num(v.smooth)}
                for k, v in self.specs.items()
            },
            "energy": num(self.energy),
            "timing": {k: round(float(v), 4) for k, v in self.timing.items()},
            "solver": self.solver,
            "smoothing": self.smoothing,
            "problem_size": self.problem_size,
            "notes": self.notes,
            "comparisons": [c.to_json_dict() for c in self.comparisons],
            **({"team": {"routes": self.routes,
                         "events": [_event(e) for e in self.events]}} if self.routes else {}),
            "peak": {"speed": _peak(self.channels, ".speed"),
                     "rotor_speed": _peak(self.channels, ".rotor_speed.")},
            "end_state": self.end_state,
        }

    def to_json(self) -> str:
        return strict_dumps(self.to_json_dict(), indent=2)

    def trajectory_csv(self) -> str:
        return channels_csv(self.times, self.channels)


def channels_csv(times, channels: dict[str, np.ndarray]) -> str:
    """A trace as CSV: ``t`` and one column per channel (``trajectory.csv``,
    ``executed.csv``)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    names = list(channels)
    w.writerow(["t", *names])
    for k, t in enumerate(times):
        w.writerow([f"{t:.6g}", *(f"{channels[c][k]:.9g}" for c in names)])
    return buf.getvalue()


def _event(e) -> dict:
    return {"drone": e.drone, "kind": e.kind, "region": e.region,
            "start": round(float(e.start), 6), "end": round(float(e.end), 6)}


def _peak(channels: dict[str, np.ndarray], key: str) -> float | None:
    """Largest value over the channels whose name contains ``key``."""
    vals = [float(np.max(v)) for k, v in channels.items() if key in k]
    return max(vals) if vals else None


def json_number(x) -> float | str | None:
    """A number as strict JSON (RFC 8259 has no NaN or Infinity): finite values as numbers,
    +∞ and −∞ as the strings ``"inf"`` and ``"-inf"`` (``float()`` reads them back), an
    undefined value (NaN) as ``null``."""
    if x is None:
        return None
    x = float(x)
    if math.isfinite(x):
        return x
    return None if math.isnan(x) else ("inf" if x > 0 else "-inf")


def strict(o):
    """``o`` with every float (also numpy scalars and arrays) made strict JSON by
    ``json_number``; containers are copied, other values kept."""
    if isinstance(o, dict):
        return {k: strict(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [strict(v) for v in o]
    if isinstance(o, np.ndarray):
        return strict(o.tolist())
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float):
        return json_number(o)
    return o


def strict_dumps(o, **kw) -> str:
    """``json.dumps`` that never writes NaN or Infinity (see ``json_number``)."""
    return json.dumps(strict(o), allow_nan=False, default=_json_default, **kw)


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o)}")
