"""Rest-to-rest motion primitives with per-axis velocity and acceleration bounds.

Paper B §III / §IV-B (after its ref. [47]): between two regions the drone moves from rest to
rest; each axis ``j`` obeys ``|v_j| ≤ v̄_j`` and ``|a_j| ≤ ā_j``; the duration is the
minimum feasible one.  Per axis, with distance ``D = |Δp_j|``:

* trapezoid (``D ≥ v̄²/ā``): accelerate at ``ā`` to ``v̄``, cruise, brake;
  ``T_j = D/v̄ + v̄/ā``;
* triangle (``D < v̄²/ā``): accelerate at ``ā`` half-way, brake; ``T_j = 2·√(D/ā)``.

All axes are synchronised to the slowest one, ``T = max_j T_j`` (or a longer duration asked
for): every other axis keeps the acceleration ``ā_j`` and lowers its peak speed to
``v_p = (ā T − √(ā²T² − 4 ā D)) / 2``, the root of ``D = v_p (T − v_p/ā)``, so that it
arrives at rest at the same time.  ``v_p ≤ v̄_j`` whenever ``T ≥ T_j``, so the bounds hold.
Acceleration is piecewise constant and sampled right-continuously (the value on
``[t, t+dt)``); position and velocity are exact.

The synchronised motion is not on the chord ``p0 → p1`` (each axis has its own profile).
``straight=True`` gives the motion *on the chord*: one scalar profile ``s(t) ∈ [0, 1]``,
``p = p0 + s·Δp``, with the bounds ``v̄_s = min_j v̄_j/|Δp_j|`` and ``ā_s = min_j ā_j/|Δp_j|``;
every axis then shares the acceleration phase length.  Its minimum duration is
``axis_time(1, v̄_s, ā_s)`` — equal to the synchronised one when one axis binds both bounds
(isotropic bounds), never shorter.  The obstacle-aware legs (``stlc.team.paths``) use it so
that a detour through via points stays on its collision-checked segments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def axis_time(dist: float, vmax: float, amax: float) -> float:
    """Minimum rest-to-rest time for one axis (``inf`` if the bounds forbid any motion)."""
    d = abs(dist)
    if d == 0.0:
        return 0.0
    if vmax <= 0.0 or amax <= 0.0:
        return math.inf
    if d >= vmax * vmax / amax:
        return d / vmax + vmax / amax
    return 2.0 * math.sqrt(d / amax)


def _scalar_bounds(p0, p1, vel_max, acc_max) -> tuple[float, float]:
    """(v̄_s, ā_s) of the chord parameter s ∈ [0, 1] (``inf`` when the points coincide)."""
    vs = as_ = math.inf
    for a, b, v, c in zip(p0, p1, vel_max, acc_max, strict=True):
        d = abs(float(b) - float(a))
        if d > 0.0:
            vs, as_ = min(vs, float(v) / d), min(as_, float(c) / d)
    return vs, as_


def min_duration(p0, p1, vel_max, acc_max, straight: bool = False) -> float:
    """Minimum feasible rest-to-rest time from ``p0`` to ``p1`` (``inf`` if impossible);
    ``straight``: on the chord (see the module docstring)."""
    if straight:
        vs, as_ = _scalar_bounds(p0, p1, vel_max, acc_max)
        return 0.0 if math.isinf(vs) else axis_time(1.0, vs, as_)
    return max(
        axis_time(float(b) - float(a), float(v), float(c))
        for a, b, v, c in zip(p0, p1, vel_max, acc_max, strict=True)
    )


@dataclass(frozen=True, slots=True)
class Primitive:
    """A synchronised rest-to-rest motion ``p0 → p1`` of the given duration."""

    p0: np.ndarray  # (3,)
    p1: np.ndarray  # (3,)
    duration: float
    acc: np.ndarray  # (3,) signed acceleration of the first phase per axis
    t_acc: np.ndarray  # (3,) length of the acceleration (= braking) phase per axis

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration at times ``t`` (scalar or (n,)), each (n, 3)
        (or (3,) for a scalar); times outside ``[0, duration]`` are clamped (at rest)."""
        scalar = np.ndim(t) == 0
        tt = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), 0.0, self.duration)[:, None]
        a, ta, T = self.acc[None, :], self.t_acc[None, :], self.duration
        vp = a * ta  # signed peak velocity
        t1 = np.minimum(tt, ta)  # time spent accelerating
        t2 = np.clip(tt - ta, 0.0, np.maximum(T - 2 * ta, 0.0))  # cruising
        t3 = np.clip(tt - (T - ta), 0.0, ta)  # braking
        pos = self.p0[None, :] + 0.5 * a * t1**2 + vp * t2 + vp * t3 - 0.5 * a * t3**2
        vel = a * t1 - a * t3
        acc = np.where(tt < ta, a, np.where(tt >= T - ta, -a, 0.0))
        acc = np.where(tt >= T, 0.0, acc)
        done = tt[:, 0] >= T
        pos[done] = self.p1
        vel[done] = 0.0
        if scalar:
            return pos[0], vel[0], acc[0]
        return pos, vel, acc


def rest_to_rest(p0, p1, vel_max, acc_max, duration: float | None = None,
                 straight: bool = False) -> Primitive:
    """The synchronised primitive from ``p0`` to ``p1`` (on the chord if ``straight``);
    ``duration`` (if given) must be at least the minimum feasible time and stretches the
    motion (raises ``ValueError`` if the motion is impossible or the duration too short)."""
    p0 = np.asarray(p0, dtype=float)
    p1 = np.asarray(p1, dtype=float)
    vmax = np.asarray(vel_max, dtype=float)
    amax = np.asarray(acc_max, dtype=float)
    t_min = min_duration(p0, p1, vmax, amax, straight)
    if math.isinf(t_min):
        raise ValueError(f"no motion from {p0.tolist()} to {p1.tolist()} within the bounds")
    T = t_min if duration is None else float(duration)
    if T < t_min * (1.0 - 1e-12) - 1e-12:
        raise ValueError(f"duration {T} s is below the minimum feasible time {t_min} s")
    acc = np.zeros(3)
    t_acc = np.zeros(3)
    if straight:
        vs, a = _scalar_bounds(p0, p1, vmax, amax)
        if math.isinf(vs) or T <= 0.0:
            return Primitive(p0, p1, T, acc, t_acc)
        disc = max(a * a * T * T - 4.0 * a, 0.0)
        vp = 2.0 * a / (a * T + math.sqrt(disc))  # peak of s', the root for distance 1
        return Primitive(p0, p1, T, a * (p1 - p0), np.full(3, vp / a))
    for j in range(3):
        d = p1[j] - p0[j]
        if d == 0.0:
            continue
        a = amax[j]
        disc = max(a * a * T * T - 4.0 * a * abs(d), 0.0)
        vp = 2.0 * a * abs(d) / (a * T + math.sqrt(disc))  # stable form of the root
        acc[j] = math.copysign(a, d)
        t_acc[j] = vp / a
    return Primitive(p0, p1, T, acc, t_acc)
