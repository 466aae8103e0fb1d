"""Paper B's power model (``stlc.vehicles.power``) against values computed by hand, and its
minimum-energy-per-distance speed against paper B eq. 8 (``stlc.team.energy``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stlc.team.energy import optimal_forward_speed
from stlc.vehicles import power

#: the README's example drone: 4 rotors of 0.05 m², f = 0.01 m², κ = 1.15, ρ = 1.225 kg/m³
AERO = (4, 0.05, 0.01, 1.15, 1.225)
MASS = 1.5


def test_hover_power_by_hand():
    """T = 1.5 · 9.81 = 14.715 N; v_h = √(T / (2ρ n A)) = √(14.715 / 0.49) = 5.480019 m/s;
    P = κ T v_h = 1.15 · 14.715 · 5.480019 = 92.7343 W."""
    p = power.power(MASS, AERO, np.zeros((1, 3)))
    assert p[0] == pytest.approx(92.7343, rel=1e-5)


def test_forward_flight_power_by_fixed_point():
    """V = 10 m/s level: v_i from Glauert's v_i = v_h² / √(V² + v_i²) by fixed-point
    iteration (independent of the closed form): 2.885355 m/s; P = κ T v_i + ½ ρ f V³ =
    1.15 · 14.715 · 2.885355 + 6.125 = 54.9517 W.  A climb does not count (eq. 10)."""
    vh = math.sqrt(14.715 / 0.49)
    vi = vh
    for _ in range(200):
        vi = vh**2 / math.sqrt(100.0 + vi * vi)
    assert vi == pytest.approx(2.885355, rel=1e-6)
    p = power.power(MASS, AERO, np.array([[6.0, 8.0, 0.0], [6.0, 8.0, 1.5]]))
    assert p == pytest.approx([54.9517, 54.9517], rel=1e-5)


def test_thrust_follows_acceleration():
    """Hovering while accelerating up at 1 m/s²: T = 1.5 · 10.81 = 16.215 N, P = κ T v_h(T)
    = 1.15 · 16.215 · √(16.215 / 0.49) = 107.2692 W; sideways at 3 m/s²: T = 1.5 · √(9 +
    9.81²) = 15.38770 N, P = 1.15 · 15.38770 · √(15.38770 / 0.49) = 99.1654 W."""
    p = power.power(MASS, AERO, np.zeros((2, 3)), np.array([[0, 0, 1.0], [3.0, 0, 0]]))
    assert p == pytest.approx([107.2692, 99.1654], rel=1e-5)


def test_energy_per_distance_is_least_at_eq8_speed():
    """P(V)/V is least at eq. 8 with the thrust in place of the printed mass, once v* is
    well above the hover induced velocity (the model's high-speed form): f = 1e-4 m² gives
    v* = 53.67 m/s against v_h = 5.48 m/s."""
    aero = (4, 0.05, 1e-4, 1.15, 1.225)
    V = np.linspace(20.0, 100.0, 80001)
    vel = np.stack([V, np.zeros_like(V), np.zeros_like(V)], axis=1)
    best = V[np.argmin(power.power(MASS, aero, vel) / V)]
    v_star = optimal_forward_speed(MASS * 9.81, 4, 0.05, 1e-4, 1.15, 1.225)
    assert v_star == pytest.approx(53.67, rel=1e-3)
    assert best == pytest.approx(v_star, rel=2e-3)


def test_energy_profile_is_dt_times_power_with_the_input_acceleration():
    """A 3-sample history at dt = 0.5 s: v = 0, 0, 0 hovers (3 · 0.5 · 92.7343 J); v_z
    rising 0 → 0.5 → 1 m/s accelerates at 1 m/s² (the last interval's input repeated)."""
    dt = 0.5
    e = power.energy_profile(MASS, AERO, np.zeros((3, 3)), dt)
    assert e == pytest.approx([46.36713] * 3, rel=1e-5)
    climb = np.array([[0, 0, 0.0], [0, 0, 0.5], [0, 0, 1.0]])
    assert power.energy_profile(MASS, AERO, climb, dt) == pytest.approx([53.63462] * 3,
                                                                        rel=1e-5)
