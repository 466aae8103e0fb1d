"""What a backup drone's planner (``stlc.backends.replan.takeover``) and the takeover simulation
(``stlc.replan.takeover``) exchange: the other drones' trajectories held ``Fixed`` on the
segment, and the ``BackupPlan`` that comes back."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from stlc.team import Drone


@dataclass
class BackupPlan:
    """The backup's trajectory on the segment grid (times from 0 = t0) and the statistics."""

    status: str  # a ``stlc.backends.base.SolverStatus`` (a ``StrEnum``)
    route: list[str] = field(default_factory=list)
    pos: np.ndarray | None = None  # (n, 3)
    vel: np.ndarray | None = None
    acc: np.ndarray | None = None
    stats: dict = field(default_factory=dict)
    message: str = ""


@dataclass(frozen=True)
class Fixed:
    """Another drone's trajectory on the segment grid (an operational drone's plan, or the
    failed drone parked)."""

    drone: Drone
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
