"""Energy-aware forward speed of paper B (Section IV-D, eq. 8–10).

* ``optimal_forward_speed`` is eq. (8) exactly as printed::

      v* = sqrt(m / (2 ρ A)) · (4 κ A / (n_r f))^(1/4)

  with m the vehicle mass, n_r the number of rotors, A the rotor disk area, f the
  equivalent flat-plate area of the fuselage, κ the induced-power correction factor and ρ
  the air density. (As printed, the first factor is the hover induced velocity
  sqrt(T/(2ρA)) with the thrust T replaced by the mass; we keep the paper's formula and its
  inputs, so callers pass the numbers the paper's formula expects.)
* ``feasible_forward_speed`` clamps v* as the paper says: when v* exceeds what the drone can
  fly it is replaced by the largest feasible forward speed, the norm of the horizontal
  velocity bound vector ‖(v̄⁽¹⁾, v̄⁽²⁾)‖ (the paper writes ‖v̄⁽¹⁾ + v̄⁽²⁾‖; with per-axis bounds
  the reachable horizontal speeds are exactly those up to hypot(v̄⁽¹⁾, v̄⁽²⁾)).
* ``forward_speed`` is eq. (10): v_for = sqrt(v_x² + v_y²) (vertical velocity excluded),
  and ``forward_cost`` the energy term Σ_k (1 − v_for,k / v*)² of eq. (9), summed over the
  *transit* samples only (samples where the drone is not dwelling in a target or station
  and has not yet reached its final station: hovering is not forward flight).
"""

from __future__ import annotations

import math

import numpy as np


def optimal_forward_speed(mass: float, rotors: int, disk_area: float, flat_plate_area: float,
                          induced_factor: float, air_density: float = 1.225) -> float:
    """Eq. (8) of paper B: the energetically optimal forward speed v* (m/s)."""
    for name, value in (("mass", mass), ("rotors", rotors), ("disk_area", disk_area),
                        ("flat_plate_area", flat_plate_area),
                        ("induced_factor", induced_factor), ("air_density", air_density)):
        if not value > 0 or not math.isfinite(value):
            raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return (math.sqrt(mass / (2.0 * air_density * disk_area))
            * (4.0 * induced_factor * disk_area / (rotors * flat_plate_area)) ** 0.25)


def feasible_forward_speed(v_star: float, vel_max: tuple[float, float, float]) -> float:
    """v* clamped to the largest horizontal speed the per-axis bounds allow."""
    return min(float(v_star), math.hypot(vel_max[0], vel_max[1]))


def forward_speed(vel: np.ndarray) -> np.ndarray:
    """Eq. (10): horizontal speed of an (n, 3) velocity array."""
    vel = np.asarray(vel, dtype=float)
    return np.hypot(vel[:, 0], vel[:, 1])


def forward_cost(vel: np.ndarray, transit: np.ndarray, v_star: float) -> float:
    """The energy term Σ_k (1 − v_for,k / v*)² over the samples where ``transit`` is true."""
    if v_star <= 0:
        raise ValueError("v* must be positive")
    vf = forward_speed(vel)[np.asarray(transit, dtype=bool)]
    return float(np.sum((1.0 - vf / v_star) ** 2))
