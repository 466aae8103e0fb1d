"""Team planning for paper B (bird diverters): shared data types.

The discrete planner (MILP assignment, motion-primitive seed, payload rule) and the
continuous refinement (``stlc.team.refine``) exchange these plain dataclasses, in SI units
and the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Box:                      # axis-aligned region, world frame, metres
    name: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Drone:
    name: str
    start: tuple[float, float, float]
    vel_max: tuple[float, float, float]     # per axis, m/s
    acc_max: tuple[float, float, float]     # per axis, m/s^2
    capacity: int


@dataclass(frozen=True, slots=True)
class TeamScenario:             # everything the discrete planner needs, SI units
    drones: tuple[Drone, ...]
    targets: tuple[Box, ...]
    stations: tuple[Box, ...]
    obstacles: tuple[Box, ...]
    workspace: Box
    install_time: float         # T_ins, s (mission data)
    refill_time: float          # T_rs, s
    horizon: float              # T_N, s
    step: float                 # T_s, s (dense sampling step)
    separation: float           # Γ_dis, m (0 if none)


@dataclass(frozen=True, slots=True)
class Visit:                    # one planned dwell inside a region
    drone: str
    kind: str                   # "install" | "refill" | "home"
    region: str                 # target or station name
    start: float                # s, drone inside the region (dwell begins)
    end: float                  # s, dwell ends (end - start >= install/refill time)


@dataclass(frozen=True, slots=True)
class PayloadEvent:             # what the payload rule derived from a trajectory
    drone: str
    kind: str                   # "install" | "refill"
    region: str
    start: float                # dwell start time
    end: float                  # time the event completes (payload changes here)


@dataclass
class TeamPlan:                 # a team trajectory on the dense grid
    times: np.ndarray           # (n,), 0, step, ..., horizon
    pos: dict[str, np.ndarray]  # drone -> (n, 3)
    vel: dict[str, np.ndarray]  # drone -> (n, 3)
    acc: dict[str, np.ndarray]  # drone -> (n, 3)
    visits: list[Visit]         # the planned dwells, in time order per drone
    route: dict[str, list[str]]  # drone -> ordered region names (targets and stations)
