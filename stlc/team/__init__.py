"""Discrete team planning for paper B (bird diverters): shared data types and errors.

The package splits the initial guess of paper B §IV-B into independent pieces:

* :mod:`stlc.team.payload` — the payload rule: the diverters on board as a function of the
  positions alone, plus the list of install / refill events;
* :mod:`stlc.team.milp` — the task assignment (eq. 7): set partitioning over routes by
  column generation (:mod:`stlc.team.colgen`, :mod:`stlc.team.pricing`,
  :mod:`stlc.team.trips`), the arc model with lazy cuts (:mod:`stlc.team.lazy`), a trip
  model (:mod:`stlc.team.partition`), horizon bounds (:mod:`stlc.team.horizon`);
* :mod:`stlc.team.primitives` — closed-form rest-to-rest motion primitives with per-axis
  velocity and acceleration bounds;
* :mod:`stlc.team.seed` — the seed trajectory of every drone on the dense grid, and the
  adapter from a checked ``stlc.semantics.model.Program`` / ``Mission``.

The dataclasses below are the interface shared with ``stlc.team.refine`` (see
notes/TEAM_INTERFACE.md); keep them identical there.  Units are SI throughout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

Vec3 = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Box:  # axis-aligned region, world frame, metres
    name: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Drone:
    name: str
    start: tuple[float, float, float]
    vel_max: tuple[float, float, float]  # per axis, m/s
    acc_max: tuple[float, float, float]  # per axis, m/s^2
    capacity: int


@dataclass(frozen=True, slots=True)
class TeamScenario:  # everything the discrete planner needs, SI units
    drones: tuple[Drone, ...]
    targets: tuple[Box, ...]
    stations: tuple[Box, ...]
    obstacles: tuple[Box, ...]
    workspace: Box
    install_time: float  # T_ins, s (mission data)
    refill_time: float  # T_rs, s
    horizon: float  # T_N, s
    step: float  # T_s, s (dense sampling step)
    separation: float  # Γ_dis, m (0 if none)


@dataclass(frozen=True, slots=True)
class Visit:  # one planned dwell inside a region
    drone: str
    kind: str  # "install" | "refill" | "home"
    region: str  # target or station name
    start: float  # s, drone inside the region (dwell begins)
    end: float  # s, dwell ends (end - start >= install/refill time)


@dataclass(frozen=True, slots=True)
class PayloadEvent:  # what the payload rule derived from a trajectory
    drone: str
    kind: str  # "install" | "refill"
    region: str
    start: float  # dwell start time
    end: float  # time the event completes (last sample of the dwell; payload changes
    #             at the next sample, end + step — see stlc.team.payload)


@dataclass
class TeamPlan:  # a team trajectory on the dense grid
    times: np.ndarray  # (n,), 0, step, ..., horizon
    pos: dict[str, np.ndarray]  # drone -> (n, 3)
    vel: dict[str, np.ndarray]  # drone -> (n, 3)
    acc: dict[str, np.ndarray]  # drone -> (n, 3)
    visits: list[Visit]  # the planned dwells, in time order per drone
    route: dict[str, list[str]]  # drone -> ordered region names (targets and stations)


class TeamError(Exception):
    """A team-planning problem that is the mission's fault, not a bug.

    ``reason`` is a short machine-readable tag (``capacity``, ``unreachable``, ``horizon``,
    ``no-station``, ``scenario``, ``route``); ``subject`` names the drone or region the
    message is about (or ``""``), so the caller can point a diagnostic at its declaration.
    """

    def __init__(self, message: str, *, reason: str, subject: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.reason = reason
        self.subject = subject


class AssignmentError(TeamError):
    """The task assignment (MILP) has no solution; the message says why."""


class ScenarioError(TeamError):
    """The program / mission cannot be turned into a team scenario."""


def centre(box: Box) -> np.ndarray:
    """Centre of a box as a float array (3,)."""
    return (np.asarray(box.lo, dtype=float) + np.asarray(box.hi, dtype=float)) / 2.0


def inside(pos: np.ndarray, box: Box) -> np.ndarray:
    """Closed-box membership of positions ``(n, 3)`` (or ``(3,)``): ``lo <= p <= hi``."""
    p = np.asarray(pos, dtype=float)
    lo = np.asarray(box.lo, dtype=float)
    hi = np.asarray(box.hi, dtype=float)
    return np.all((p >= lo) & (p <= hi), axis=-1)


def samples_for(duration: float, step: float) -> int:
    """Whole steps needed to cover ``duration``: ``ceil(duration / step)``, where a ratio
    within 1e-9 (relative) of an integer counts as that integer (so 5 s / 0.05 s = 100)."""
    r = duration / step
    k = round(r)
    if abs(r - k) <= 1e-9 * max(1.0, abs(r)):
        return int(k)
    return int(np.ceil(r))


__all__ = [
    "AssignmentError",
    "Box",
    "Drone",
    "PayloadEvent",
    "ScenarioError",
    "TeamError",
    "TeamPlan",
    "TeamScenario",
    "Visit",
    "centre",
    "inside",
    "samples_for",
]
