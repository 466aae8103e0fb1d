"""The power model behind paper B's energy-aware forward speed (Section IV-D, eq. 8).

Paper B prints only the speed v* that minimises energy, "described in [59, Ch. 5]" (the
momentum-theory performance model of a rotorcraft).  The model whose energy per distance
flown, P(V)/V, is smallest at exactly eq. 8 is induced power plus parasitic power::

    P(V) = κ T v_i(V) + ½ ρ f V³

with T the thrust, V the forward speed (eq. 10: horizontal, the vertical component is
excluded as in the paper), κ the induced-power factor, f the equivalent flat-plate area,
ρ the air density and v_i the induced velocity of momentum theory for n_r rotors of disk
area A (Glauert, level flight)::

    v_i = v_h² / √(V² + v_i²),   v_h = √(T / (2 ρ n_r A))   (hover induced velocity)
    ⟹ v_i² = (√(V⁴ + 4 v_h⁴) − V²) / 2

At V ≫ v_h, v_i ≈ v_h²/V and P/V = κT²/(2ρ n_r A V²) + ½ρ f V², smallest at
V⁴ = κ T² / (ρ² n_r A f) — eq. 8 with T in place of the printed m.  The thrust here is
the one the point mass needs, T = m ‖a + g e_z‖ (m g in steady flight), so the energy is in
joules; the profile power of the blades is not in the paper's model and not here.

Energy per sample is ``dt · P_k`` (the convention of the multirotor's eq. 5 energy: a sum
over the plan's samples).
"""

from __future__ import annotations

import numpy as np

GRAVITY = 9.81


def induced_velocity(thrust: np.ndarray, forward_speed: np.ndarray, rotors: int,
                     disk_area: float, air_density: float) -> np.ndarray:
    """v_i (m/s) of momentum theory in level forward flight (see the module docstring)."""
    vh2 = np.asarray(thrust, dtype=float) / (2.0 * air_density * rotors * disk_area)
    V2 = np.asarray(forward_speed, dtype=float) ** 2
    return np.sqrt((np.sqrt(V2 * V2 + 4.0 * vh2 * vh2) - V2) / 2.0)


def power(mass: float, aero: tuple[int, float, float, float, float], vel: np.ndarray,
          acc: np.ndarray | None = None, gravity: float = GRAVITY) -> np.ndarray:
    """P_k (W) for (n, 3) velocities and accelerations (None: steady flight, T = m g);
    ``aero`` = (rotors, disk area m², flat-plate area m², induced factor κ, air density)."""
    rotors, disk, flat, kappa, rho = aero
    vel = np.atleast_2d(np.asarray(vel, dtype=float))
    acc = np.zeros_like(vel) if acc is None else np.atleast_2d(np.asarray(acc, dtype=float))
    thrust = mass * np.linalg.norm(acc + np.array([0.0, 0.0, gravity]), axis=1)
    V = np.hypot(vel[:, 0], vel[:, 1])
    v_i = induced_velocity(thrust, V, rotors, disk, rho)
    return kappa * thrust * v_i + 0.5 * rho * flat * V**3


def energy_profile(mass: float, aero: tuple[int, float, float, float, float],
                   vel: np.ndarray, dt: float, acc: np.ndarray | None = None,
                   gravity: float = GRAVITY) -> np.ndarray:
    """dt · P_k (J) per sample of a point-mass velocity history (n, 3); the acceleration is
    the plan's own (``acc``, n × 3) or, without it, (v_{k+1} − v_k) / dt (the last one
    repeated: the input of the point mass's exact discretisation)."""
    vel = np.atleast_2d(np.asarray(vel, dtype=float))
    if acc is not None:
        acc = np.atleast_2d(np.asarray(acc, dtype=float))
    elif vel.shape[0] > 1:
        acc = np.diff(vel, axis=0) / dt
        acc = np.vstack([acc, acc[-1:]])
    else:
        acc = np.zeros_like(vel)
    return dt * power(mass, aero, vel, acc, gravity)
