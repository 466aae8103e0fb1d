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
#: "beyond any trace": a window offset this large selects no sample (traces and grids are
#: far shorter); quotients t/dt beyond it (t = 1 s at dt = 1e-310 s is 1e310, i.e. ∞) are
#: clamped to it instead of overflowing ``math.ceil``
FAR = 1 << 40


def _quotient(t: float, dt: float) -> float:
    if not dt > 0 or math.isnan(t):
        raise ValueError(f"time {t} s on a grid of step {dt} s")
    return t / dt


def _clamp(q: float) -> int | None:
    if q >= FAR:
        return FAR
    if q <= -FAR:
        return -FAR
    return None


def steps_ceil(t: float, dt: float) -> int:
    q = _quotient(t, dt)
    far = _clamp(q)
    return far if far is not None else math.ceil(q - EPS)


def steps_floor(t: float, dt: float) -> int:
    q = _quotient(t, dt)
    far = _clamp(q)
    return far if far is not None else math.floor(q + EPS)


def is_aligned(t: float, dt: float) -> bool:
    q = _quotient(t, dt)
    return math.isinf(q) or abs(q - round(q)) < 1e-6


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
