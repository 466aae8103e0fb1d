"""The point-mass model (paper B): state (p, v), input a, per-axis velocity and
acceleration bounds; a team drone may carry a payload (a derived signal, see
``stlc.team.payload``).  A drone that declares its mass and aerodynamic data has the energy
of paper B's power model (``stlc.vehicles.power``)."""

from __future__ import annotations

from stlc.lazy import lazy

ca = lazy("casadi")  # CasADi runs only when a plan is built (``stlc.lazy``)
import numpy as np

from stlc.vehicles import dynamics, power
from stlc.vehicles.declared import AXES, FormulaField, PointMass

POS, VEL = slice(0, 3), slice(3, 6)


class PointMassModel:
    kind = "point_mass"

    def state_size(self, v: PointMass) -> tuple[int, int]:
        return 6, 3

    def state_channels(self, v: PointMass) -> list[str]:
        return v.channels()

    def input_channels(self, v: PointMass) -> list[str]:
        return v.input_channels()

    def derived_names(self, v: PointMass) -> list[str]:
        return [f"{v.name}.speed", f"{v.name}.course"]

    def all_channels(self, v: PointMass) -> list[str]:
        return self.state_channels(v) + self.input_channels(v) + self.derived_names(v)

    def pos_index(self) -> slice:
        return POS

    def vel_index(self) -> slice:
        return VEL

    def ode(self, v: PointMass) -> ca.Function:
        return dynamics.point_mass_ode(v)

    def bounds(self, v: PointMass) -> dynamics.Bounds:
        vmax = np.asarray(v.vel_max, dtype=float)
        amax = np.asarray(v.acc_max, dtype=float)
        x_lo, x_hi = np.full(6, -np.inf), np.full(6, np.inf)
        x_lo[3:6], x_hi[3:6] = -vmax, vmax
        return dynamics.Bounds(x_lo, x_hi, -amax, amax.copy())

    def initial_state(self, v: PointMass) -> np.ndarray:
        return np.concatenate([v.start_pos, v.start_vel]).astype(float)

    def derived_channels(self, v: PointMass, X: np.ndarray) -> dict[str, np.ndarray]:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        vel = X[:, VEL]
        return {f"{v.name}.speed": np.linalg.norm(vel, axis=1),
                f"{v.name}.course": np.arctan2(vel[:, 1], vel[:, 0])}

    def derived_channels_sx(self, v: PointMass, x: ca.SX, eps: float = 0.0
                            ) -> dict[str, ca.SX]:
        vel = x[VEL]
        return {f"{v.name}.speed": ca.sqrt(ca.dot(vel, vel) + eps**2),
                f"{v.name}.course": ca.atan2(vel[1], vel[0])}

    def energy_terms(self, v: PointMass, x: ca.SX, dt: float) -> None:
        return None  # no energy model: paper B's planner uses the forward-speed term

    def energy_profile(self, v: PointMass, X: np.ndarray, dt: float,
                       U: np.ndarray | None = None) -> np.ndarray:
        """dt · P_k of paper B's power model (``stlc.vehicles.power``) when the drone
        declares its mass and aerodynamic data, else zeros (``has_rotor_energy`` False);
        the thrust from the plan's accelerations ``U`` (n × 3) when given."""
        X = np.atleast_2d(X)
        if not self.has_rotor_energy(v):
            return np.zeros(X.shape[0])
        return power.energy_profile(v.mass, v.aero, X[:, VEL], dt, U)

    def knot_step(self, v: PointMass) -> float:
        """Knots of a long plan at most this far apart (s): its acceleration is the input,
        held between knots, so the path between them is a parabola the knots bound."""
        return 0.5

    def kinematic_limits(self, v: PointMass) -> tuple[np.ndarray, np.ndarray]:
        return np.array(v.vel_max, dtype=float), np.array(v.acc_max, dtype=float)

    def guess(self, v: PointMass, P: np.ndarray, V: np.ndarray, A: np.ndarray, dt: float,
              needed=None) -> tuple[np.ndarray, np.ndarray]:
        return np.vstack([P, V]), A

    def kinematic_envelope(self, v: PointMass) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sound bounds of every flyable trajectory: per-axis speed bound, acceleration
        interval (lo, hi) — here the declared bounds themselves."""
        amax = np.asarray(v.acc_max, dtype=float)
        return np.asarray(v.vel_max, dtype=float), -amax, amax.copy()

    def plot_bounds(self, v: PointMass) -> dict[str, list[float]]:
        return {"speed_axis": list(v.vel_max)}

    def formula_fields(self, v: PointMass) -> dict[str, FormulaField]:
        n = v.name
        acc = tuple(f"{n}.acc.{a}" for a in AXES)
        return {"acc": FormulaField((1, 0, -2, 0), acc, acc, True),
                "payload": FormulaField(None, (f"{n}.payload",), (f"{n}.payload",), False)}

    def envelope(self, v: PointMass, b: dynamics.Bounds) -> dynamics.Bounds:
        return b  # the declared per-axis bounds are the whole envelope

    def fit_guess_inputs(self, v: PointMass, U: np.ndarray, lo: np.ndarray, hi: np.ndarray
                         ) -> np.ndarray:
        return U

    def has_rotor_energy(self, v: PointMass) -> bool:
        return v.aero is not None and v.mass is not None  # paper B's power model

    def carries_payload(self, v: PointMass) -> bool:
        return True

    def axis_limits(self, v: PointMass) -> dict[str, tuple[float, ...]]:
        return {"vel": tuple(v.vel_max), "acc": tuple(v.acc_max)}

    def rotor_forces(self, v: PointMass) -> None:
        return None

    def linear_model(self, v: PointMass, dt: float | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
        """State (p, v), input a.  Without ``dt``: continuous time, ẋ = A x + B u.  With
        ``dt``: the exact discretisation for an input held over each step,
        x[k+1] = A x[k] + B u[k] (which RK4 reproduces exactly: the flow is a polynomial of
        degree 2 in time)."""
        eye, zero = np.eye(3), np.zeros((3, 3))
        if dt is None:
            return np.block([[zero, eye], [zero, zero]]), np.vstack([zero, eye])
        return (np.block([[eye, dt * eye], [zero, eye]]),
                np.vstack([0.5 * dt * dt * eye, dt * eye]))
