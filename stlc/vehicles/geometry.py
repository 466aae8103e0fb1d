"""Rotor geometry: force/torque allocation and generators for common multirotor layouts.

A multirotor is "just geometry": a tuple of ``model.Rotor`` (body position, unit thrust axis,
spin).  This module turns that tuple into the allocation matrices used by the dynamics and
provides generators so the language can declare a flat quadrotor, a flat hexarotor or a
fully-actuated tilted hexarotor without typing every rotor.

Conventions (body frame x forward, y left, z up; world z up)
------------------------------------------------------------
* Rotor i pushes with force ξ_i ≥ 0 (N) along its unit axis z_i at body position p_i.
* ``spin = +1``: the propeller turns counter-clockwise seen from above (from +z_i), so the
  reaction (drag) torque on the body is along **−z_i**; ``spin = −1`` (clockwise) gives +z_i.
  With the paper's rotor model ξ_i = c_f Ω_i and drag torque c_τ Ω_i (Ω_i = squared rotor
  speed in Hz²) the drag torque is (c_τ/c_f) ξ_i, so the torque column of rotor i is

      G_τ[:, i] = p_i × z_i − spin_i (c_τ/c_f) z_i.

  For the textbook "+" quadrotor (front/back rotors counter-clockwise, left/right clockwise)
  this gives yaw torque k(−ξ_front + ξ_left − ξ_back + ξ_right), k = c_τ/c_f: speeding up the
  clockwise pair yaws the body counter-clockwise (positive yaw), as in Mahony–Kumar–Corke.
* Angles of rotors around the body z axis are measured counter-clockwise from +x (front);
  generated rotors are numbered counter-clockwise in that order.
"""

from __future__ import annotations

import math

import numpy as np

from stlc.vehicles.declared import Rotor

#: entries of generated geometry / allocation smaller than this are trig round-off → 0
_ROUND_OFF = 1e-12


class GeometryError(ValueError):
    """A rotor layout that cannot be used (zero axis, bad spin, unknown configuration)."""


def _clean(a: np.ndarray) -> np.ndarray:
    """Zero out trig round-off (cos(π/2) = 6e-17) so CasADi sees structural zeros."""
    out = np.array(a, dtype=float)
    out[np.abs(out) < _ROUND_OFF] = 0.0
    return out


def allocation(
    rotors: tuple[Rotor, ...] | list[Rotor], c_f: float, c_tau: float
) -> tuple[np.ndarray, np.ndarray]:
    """Force and torque allocation ``(G_f (3×n), G_τ (3×n))`` in the body frame.

    Body force = G_f ξ and body torque = G_τ ξ for rotor forces ξ (N).  Column i of G_f is the
    unit axis z_i; column i of G_τ is p_i × z_i − spin_i (c_τ/c_f) z_i (see module docstring
    for the spin convention).  Axes are normalised defensively.
    """
    if c_f <= 0:
        raise GeometryError(f"force constant c_f must be positive, got {c_f}")
    n = len(rotors)
    g_f = np.zeros((3, n))
    g_tau = np.zeros((3, n))
    k = c_tau / c_f
    for i, r in enumerate(rotors):
        z = np.asarray(r.axis, dtype=float)
        norm = float(np.linalg.norm(z))
        if norm < 1e-9:
            raise GeometryError(f"rotor {i + 1} has a zero thrust axis")
        if r.spin not in (1, -1):
            raise GeometryError(f"rotor {i + 1} spin must be +1 or -1, got {r.spin}")
        z = z / norm
        p = np.asarray(r.position, dtype=float)
        g_f[:, i] = z
        g_tau[:, i] = np.cross(p, z) - r.spin * k * z
    return _clean(g_f), _clean(g_tau)


def wrench_matrix(rotors: tuple[Rotor, ...], c_f: float, c_tau: float) -> np.ndarray:
    """The stacked 6×n allocation ``[G_f; G_τ]``."""
    g_f, g_tau = allocation(rotors, c_f, c_tau)
    return np.vstack([g_f, g_tau])


def tilted_axis(arm_angle: float, tilt: float) -> np.ndarray:
    """Unit z rotated by ``tilt`` (rad) about the arm direction (cos a, sin a, 0).

    Rodrigues: z' = (sin t sin a, −sin t cos a, cos t) — the thrust leans tangentially,
    perpendicular to the arm (the Rajappa/Ryll/Franchi tilted-hexarotor design).
    """
    s, c = math.sin(tilt), math.cos(tilt)
    return _clean(np.array([s * math.sin(arm_angle), -s * math.cos(arm_angle), c]))


def star(
    n: int,
    arm: float,
    *,
    tilt: float = 0.0,
    start_angle: float = 0.0,
    first_spin: int = 1,
    height: float = 0.0,
) -> tuple[Rotor, ...]:
    """``n`` rotors evenly spaced on a circle of radius ``arm`` in the body xy-plane.

    Rotor k (0-based) sits at angle ``start_angle + 2πk/n`` (counter-clockwise from +x), at
    body height ``height``; spins alternate starting with ``first_spin``; axes are tilted by
    ``(−1)^k · tilt`` about the arm direction (``tilt = 0`` gives a flat multirotor).
    """
    if n < 1:
        raise GeometryError(f"need at least one rotor, got {n}")
    if arm <= 0:
        raise GeometryError(f"arm length must be positive, got {arm}")
    if first_spin not in (1, -1):
        raise GeometryError(f"first_spin must be +1 or -1, got {first_spin}")
    out = []
    for k in range(n):
        a = start_angle + 2.0 * math.pi * k / n
        sign = 1 if k % 2 == 0 else -1
        pos = _clean(np.array([arm * math.cos(a), arm * math.sin(a), height]))
        axis = tilted_axis(a, sign * tilt)
        out.append(
            Rotor(
                position=(float(pos[0]), float(pos[1]), float(pos[2])),
                axis=(float(axis[0]), float(axis[1]), float(axis[2])),
                spin=sign * first_spin,
            )
        )
    return tuple(out)


def quadrotor(arm: float, config: str = "x", *, first_spin: int = 1) -> tuple[Rotor, ...]:
    """A flat quadrotor with arm length ``arm`` (m, centre to rotor).

    ``"+"``: rotors front (+x), left (+y), back, right; ``"x"``: front-left (45°),
    back-left, back-right, front-right.  Spins alternate starting with ``first_spin``
    (default: front / front-left counter-clockwise), so diagonal rotors share a spin.
    """
    if config == "+":
        return star(4, arm, start_angle=0.0, first_spin=first_spin)
    if config == "x":
        return star(4, arm, start_angle=math.pi / 4, first_spin=first_spin)
    raise GeometryError(f'quadrotor configuration must be "x" or "+", got {config!r}')


def hexarotor(
    arm: float, tilt: float = 0.0, *, start_angle: float = 0.0, first_spin: int = 1
) -> tuple[Rotor, ...]:
    """A hexarotor: rotors at 60° steps from ``start_angle``, alternating spin and tilt.

    ``tilt`` (rad) = 0 is a flat (under-actuated) hexarotor.  With ``tilt ≠ 0`` rotor k's
    axis is tilted by ``(−1)^k tilt`` about its arm — the classic fully-actuated tilted
    hexarotor (Rajappa, Ryll, Bülthoff, Franchi 2015): the 6×6 allocation has full rank, so
    the vehicle can hold any attitude while hovering, within its force limits.  With the
    default signs the yaw moment of each tilted thrust (−arm·sin(α_k) per newton) adds to
    that rotor's drag torque; pass a negative ``tilt`` for the opposite pairing.
    """
    return star(6, arm, tilt=tilt, start_angle=start_angle, first_spin=first_spin)
