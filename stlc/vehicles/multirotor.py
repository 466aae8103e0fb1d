"""The rigid-body multirotor model (paper A eq. 1): state (p, η, v, ω, ξ), input ξ̇.

The equations live in ``stlc.dynamics``; this module is the model's entry in the vehicle
registry: layout, bounds, start state, derived signals (speed, course, heading, rotor
speed), energy (paper A eq. 5) and the guess built from a kinematic path.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from stlc import dynamics
from stlc.model import AXES, Multirotor

POS, ATT, VEL, RATE, FORCE = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), 12


class MultirotorModel:
    kind = "multirotor"

    def state_size(self, v: Multirotor) -> tuple[int, int]:
        n = len(v.rotors)
        return 12 + n, n

    def state_channels(self, v: Multirotor) -> list[str]:
        return v.channels()

    def input_channels(self, v: Multirotor) -> list[str]:
        return v.input_channels()

    def derived_names(self, v: Multirotor) -> list[str]:
        return ([f"{v.name}.speed", f"{v.name}.course", f"{v.name}.heading"]
                + [f"{v.name}.rotor_speed.{i + 1}" for i in range(len(v.rotors))])

    def all_channels(self, v: Multirotor) -> list[str]:
        return self.state_channels(v) + self.input_channels(v) + self.derived_names(v)

    def pos_index(self) -> slice:
        return POS

    def vel_index(self) -> slice:
        return VEL

    def ode(self, v: Multirotor) -> ca.Function:
        return dynamics.multirotor_ode(v)

    def bounds(self, v: Multirotor) -> dynamics.Bounds:
        nx, nu = self.state_size(v)
        x_lo, x_hi = np.full(nx, -np.inf), np.full(nx, np.inf)
        u_lo, u_hi = np.full(nu, -np.inf), np.full(nu, np.inf)
        x_lo[FORCE:], x_hi[FORCE:] = v.force_min, v.force_max
        if v.dforce_max is not None:
            u_lo[:], u_hi[:] = -v.dforce_max, v.dforce_max
        return dynamics.Bounds(x_lo, x_hi, u_lo, u_hi)

    def initial_state(self, v: Multirotor) -> np.ndarray:
        return np.concatenate([v.start_pos, v.start_att, v.start_vel, v.start_rate,
                               dynamics.hover_forces(v, check_bounds=False)]).astype(float)

    def derived_channels(self, v: Multirotor, X: np.ndarray) -> dict[str, np.ndarray]:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        vel = X[:, VEL]
        out = {f"{v.name}.speed": np.linalg.norm(vel, axis=1),
               f"{v.name}.course": np.arctan2(vel[:, 1], vel[:, 0]),
               f"{v.name}.heading": X[:, 5].copy()}
        speeds = dynamics.rotor_speed_hz(v, X[:, FORCE:])
        for i in range(speeds.shape[1]):
            out[f"{v.name}.rotor_speed.{i + 1}"] = speeds[:, i]
        return out

    def derived_channels_sx(self, v: Multirotor, x: ca.SX, eps: float = 0.0
                            ) -> dict[str, ca.SX]:
        vel = x[VEL]
        out = {f"{v.name}.speed": ca.sqrt(ca.dot(vel, vel) + eps**2),
               f"{v.name}.course": ca.atan2(vel[1], vel[0]),
               f"{v.name}.heading": x[5]}
        for i in range(len(v.rotors)):
            out[f"{v.name}.rotor_speed.{i + 1}"] = ca.sqrt(x[FORCE + i] / v.c_f + eps**2)
        return out

    def energy_terms(self, v: Multirotor, x: ca.SX, dt: float) -> ca.SX:
        return dynamics.energy_terms(v, x, dt)

    def energy_profile(self, v: Multirotor, X: np.ndarray, dt: float) -> np.ndarray:
        return np.array([dynamics.energy(v, X[k:k + 1], dt, normalize=False)
                         for k in range(X.shape[0])])

    def kinematic_limits(self, v: Multirotor) -> tuple[np.ndarray, np.ndarray]:
        from stlc.backends.schedule import GUESS_ACC, GUESS_VEL

        return np.full(3, GUESS_VEL), np.full(3, GUESS_ACC)

    def guess(self, v: Multirotor, P: np.ndarray, V: np.ndarray, A: np.ndarray, dt: float
              ) -> tuple[np.ndarray, np.ndarray]:
        from stlc.backends.schedule import multirotor_guess

        return multirotor_guess(v, P, V, A, dt)

    def plot_bounds(self, v: Multirotor) -> dict[str, list[float]]:
        return {"force": [v.force_min, v.force_max]}


__all__ = ["MultirotorModel", "AXES"]
