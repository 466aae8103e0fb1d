"""The result of compiling a mission, in mission-level names only.

Backends ``invert`` their raw solver output into a ``Solution``; the report, ``solution.json``
and ``trajectory.csv`` are written from it and never see a solver object.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

STATUSES = ("satisfied", "violated", "solver_failed")


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
class Solution:
    mission: str
    status: str  # satisfied | violated | solver_failed
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
    extra: dict[str, object] = field(default_factory=dict)  # e.g. energy_profile, comparisons

    def to_json_dict(self) -> dict:
        num = json_number
        return {
            "mission": self.mission,
            "status": self.status,
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
            "comparisons": [{k: v for k, v in c.items() if k != "energy_profile"}
                            for c in self.extra.get("comparisons", [])],
            "peak": {"speed": _peak(self.channels, ".speed"),
                     "rotor_speed": _peak(self.channels, ".rotor_speed.")},
        }

    def to_json(self) -> str:
        return strict_dumps(self.to_json_dict(), indent=2)

    def trajectory_csv(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        names = list(self.channels)
        w.writerow(["t", *names])
        for k, t in enumerate(self.times):
            w.writerow([f"{t:.6g}", *(f"{self.channels[c][k]:.9g}" for c in names)])
        return buf.getvalue()


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
