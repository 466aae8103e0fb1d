"""The time grid: turns seconds into sample indices (kept apart from the declarative mission).

A grid has ``n_intervals`` steps of ``dt`` seconds, i.e. ``n = n_intervals + 1`` samples at
t = 0, dt, …, T.  Window bounds follow the contract: ``[a, b]`` covers samples
``ceil(a/dt) … floor(b/dt)`` relative to the evaluation sample, computed with a small
tolerance so that 1.7 / 0.1 is 17, not 16.999….
"""

from __future__ import annotations

import math
from dataclasses import dataclass

EPS = 1e-9


def steps_ceil(t: float, dt: float) -> int:
    if math.isinf(t):
        return 1 << 40
    return math.ceil(t / dt - EPS)


def steps_floor(t: float, dt: float) -> int:
    if math.isinf(t):
        return 1 << 40
    return math.floor(t / dt + EPS)


def is_aligned(t: float, dt: float) -> bool:
    return math.isinf(t) or abs(t / dt - round(t / dt)) < 1e-6


@dataclass(frozen=True, slots=True)
class TimeGrid:
    dt: float
    n_intervals: int

    @staticmethod
    def from_horizon(horizon: float, dt: float) -> TimeGrid:
        return TimeGrid(dt, steps_floor(horizon, dt))

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.n_intervals + 1

    @property
    def horizon(self) -> float:
        return self.n_intervals * self.dt

    def window(self, lo: float, hi: float) -> tuple[int, int]:
        """Relative sample offsets (first, last) of the interval ``[lo, hi]`` seconds."""
        return steps_ceil(lo, self.dt), steps_floor(hi, self.dt)

    def times(self):
        import numpy as np

        return np.arange(self.n) * self.dt
