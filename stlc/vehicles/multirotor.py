"""The rigid-body multirotor model (paper A eq. 1): state (p, η, v, ω, ξ), input ξ̇.

The equations live in ``stlc.vehicles.dynamics``; this module is the model's entry in the vehicle
registry: layout, bounds, start state, derived signals (speed, course, heading, rotor
speed), energy (paper A eq. 5) and the guess built from a kinematic path.
"""

from __future__ import annotations

from stlc.lazy import lazy

ca = lazy("casadi")  # CasADi runs only when a plan is built (``stlc.lazy``)
import numpy as np

from stlc.vehicles import geometry
from stlc.vehicles import dynamics
from stlc.vehicles.declared import AXES, FormulaField, Multirotor

POS, ATT, VEL, RATE, FORCE = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), 12
#: a multirotor's kinematic guess flies at this share of its declared ``vel_max`` per axis;
#: one that declares none at ``GUESS_VEL`` (m/s per axis, 0.3 of the envelope's speed)
GUESS_VEL_SHARE = 0.8
GUESS_VEL = 1.5
#: … and accelerates at this share of what its rotors give (``thrust_accelerations``), at
#: most ``GUESS_ACC``: the handover's hexarotor min(0.12 × 17.0, 2) = 2 m/s² (its plans as
#: before), a quadrotor with thrust/weight 2.6 1.91 m/s², with thrust/weight 1.3 0.35 m/s²
GUESS_ACC_SHARE = 0.12
GUESS_ACC = 2.0
KNOT_STEP = 0.2  #: s, a long plan's knots at most this far apart (``knot_step``)
#: flight envelope added to a multirotor's own bounds by the planners, so that IPOPT cannot
#: wander into the Euler singularity or take huge input steps: |roll|, |pitch| <= 60 deg,
#: |body rate| <= 6 rad/s, |v| <= 5 m/s per axis, |dξ/dt| <= (force range) / 0.25 s unless
#: the vehicle sets dforce_max
ENVELOPE_TILT = np.deg2rad(60.0)
ENVELOPE_RATE = 6.0
ENVELOPE_VEL = 5.0
ENVELOPE_DFORCE_TIME = 0.25


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

    def energy_profile(self, v: Multirotor, X: np.ndarray, dt: float,
                       U: np.ndarray | None = None) -> np.ndarray:
        return np.array([dynamics.energy(v, X[k:k + 1], dt, normalize=False)
                         for k in range(X.shape[0])])

    def knot_step(self, v: Multirotor) -> float:
        """Knots of a long plan at most this far apart: its attitude turns within 0.5 s,
        and a plan on 0.5 s knots (a 30 s tower inspection) flew a yaw spin at 2.6 m/s
        between knots that kept 2 m/s; on 0.2 s knots the same mission's fastest sample
        was 1.66 m/s (its safety margin +0.30 on the knots, +0.28 on the mission grid)."""
        return KNOT_STEP

    def kinematic_limits(self, v: Multirotor) -> tuple[np.ndarray, np.ndarray]:
        """Per-axis speed and acceleration of the kinematic guess, from the declaration:
        a share of ``vel_max`` (or ``GUESS_VEL``, within the envelope) and of the smaller of
        the horizontal and the climbing acceleration the rotors give (at most
        ``GUESS_ACC``)."""
        vel = np.full(3, GUESS_VEL) if v.vel_max is None else \
            GUESS_VEL_SHARE * np.asarray(v.vel_max, float)
        vel = np.minimum(vel, ENVELOPE_VEL)
        a_h, a_up = thrust_accelerations(v)
        acc = min(GUESS_ACC_SHARE * max(min(a_h, a_up), 0.0), GUESS_ACC)
        return vel, np.full(3, max(acc, 1e-3))

    def guess(self, v: Multirotor, P: np.ndarray, V: np.ndarray, A: np.ndarray, dt: float,
              needed=None) -> tuple[np.ndarray, np.ndarray]:
        return multirotor_guess(v, P, V, A, dt, needed)

    def kinematic_envelope(self, v: Multirotor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sound bounds of every flyable trajectory: no speed bound (inf), and per axis an
        acceleration interval that contains R(η) G_f ξ / m + g for every attitude and every
        rotor force in bounds: each component of R G_f ξ is at most ‖G_f ξ‖ ≤ Σ ξ_i ≤
        n·force_max in size (rotor axes are unit vectors, forces are non-negative)."""
        a = len(v.rotors) * max(abs(v.force_max), abs(v.force_min)) / v.mass
        lo = np.array([-a, -a, -a - v.gravity])
        hi = np.array([a, a, a - v.gravity])
        return np.full(3, np.inf), lo, hi

    def plot_bounds(self, v: Multirotor) -> dict[str, list[float]]:
        return {"force": [v.force_min, v.force_max]}

    def formula_fields(self, v: Multirotor) -> dict[str, FormulaField]:
        n = v.name
        idx = tuple(str(i + 1) for i in range(len(v.rotors)))

        def vec(field: str, dim, names=AXES) -> FormulaField:
            chans = tuple(f"{n}.{field}.{a}" for a in names)
            return FormulaField(dim, chans, chans, True)

        return {
            "att": vec("att", (0, 0, 0, 1)),
            "rate": vec("rate", (0, 0, -1, 1)),
            "heading": FormulaField((0, 0, 0, 1), (f"{n}.att.z",), (f"{n}.heading",), False),
            "force": vec("force", (1, 1, -2, 0), idx),
            "dforce": vec("dforce", (1, 1, -3, 0), idx),
            "rotor_speed": FormulaField((0, 0, -1, 0), tuple(f"{n}.force.{i}" for i in idx),
                                        tuple(f"{n}.rotor_speed.{i}" for i in idx), True,
                                        sqrt_of_ratio=v.c_f),
        }

    def envelope(self, v: Multirotor, b: dynamics.Bounds) -> dynamics.Bounds:
        x_lo, x_hi, u_lo, u_hi = (np.array(a, dtype=float)
                                  for a in (b.x_lo, b.x_hi, b.u_lo, b.u_hi))
        x_lo[3:5], x_hi[3:5] = -ENVELOPE_TILT, ENVELOPE_TILT
        vel = np.full(3, ENVELOPE_VEL) if v.vel_max is None else \
            np.minimum(np.asarray(v.vel_max, float), ENVELOPE_VEL)
        x_lo[6:9], x_hi[6:9] = -vel, vel
        x_lo[9:12], x_hi[9:12] = -ENVELOPE_RATE, ENVELOPE_RATE
        if v.dforce_max is None:
            r = (v.force_max - v.force_min) / ENVELOPE_DFORCE_TIME
            u_lo[:], u_hi[:] = -r, r
        return dynamics.Bounds(x_lo, x_hi, u_lo, u_hi)

    def fit_guess_inputs(self, v: Multirotor, U: np.ndarray, lo: np.ndarray, hi: np.ndarray
                         ) -> np.ndarray:
        return np.clip(U, lo[:, None], hi[:, None])  # guessed force rates may exceed the envelope

    def has_rotor_energy(self, v: Multirotor) -> bool:
        return True

    def carries_payload(self, v: Multirotor) -> bool:
        return False

    def axis_limits(self, v: Multirotor) -> dict[str, tuple[float, ...]]:
        return {}

    def rotor_forces(self, v: Multirotor) -> tuple[float, float, float]:
        return v.force_min, v.force_max, v.c_f

    def linear_model(self, v: Multirotor, dt: float | None = None) -> None:
        return None  # rigid-body dynamics: nonlinear


def _yaw_guess(V: np.ndarray, yaw0: float, dt: float, needed: np.ndarray | None
               ) -> np.ndarray:
    """The guess's heading: along the horizontal direction of motion only at the samples
    where the requirement reads the heading (``needed``) and the vehicle moves (> 0.1 m/s),
    on the branch nearest to the heading before (so the first turn is the shorter way
    round from the start heading); linear between those samples and from the start, held
    after the last one (held throughout when nothing reads the heading), then smoothed
    (1 s moving average).  Following the course everywhere made the heading wind up along
    the whole path (handover_left: +226° where −134° meets the comfort spec)."""
    n = V.shape[1]
    anchors = np.hypot(V[0], V[1]) > 0.1
    anchors &= np.zeros(n, dtype=bool) if needed is None else np.asarray(needed, dtype=bool)
    anchors[0] = False  # the start heading is fixed
    ks = np.flatnonzero(anchors)
    if ks.size == 0:
        return np.full(n, float(yaw0))
    course = np.arctan2(V[1, ks], V[0, ks])
    vals = np.empty(ks.size)
    cur = float(yaw0)
    for i, c in enumerate(course):
        cur = cur + np.arctan2(np.sin(c - cur), np.cos(c - cur))
        vals[i] = cur
    yaw = np.interp(np.arange(n), np.concatenate([[0], ks]), np.concatenate([[yaw0], vals]))
    w = max(1, int(round(1.0 / dt)))
    pad = np.concatenate([np.full(w, yaw[0]), yaw, np.full(w, yaw[-1])])
    smooth = np.convolve(pad, np.ones(2 * w + 1) / (2 * w + 1), mode="same")[w:-w]
    smooth[0] = yaw0
    return smooth


def multirotor_guess(v: Multirotor, P: np.ndarray, V: np.ndarray, A: np.ndarray,
                     dt: float, needed=None) -> tuple[np.ndarray, np.ndarray]:
    """A nearly dynamically consistent state/input guess along a kinematic path: roll and
    pitch level, yaw along the course where the requirement reads the heading
    (``_yaw_guess``; ``needed(channel)`` is the mask of samples at which it reads a
    channel, ``stlc.semantics.reads``), rotor forces from the allocation that realise the
    path's acceleration and yaw acceleration (least squares, clipped to the force range)."""
    n = P.shape[1]
    mask = None if needed is None else needed(f"{v.name}.att.z")
    yaw = _yaw_guess(V, v.start_att[2], dt, mask)
    yaw_rate = np.gradient(yaw, dt)
    yaw_acc = np.gradient(yaw_rate, dt)
    W = geometry.wrench_matrix(v.rotors, v.c_f, v.c_tau)
    Wp = np.linalg.pinv(W)
    Jzz = np.array(v.inertia)[2, 2]
    acc = np.hstack([A, A[:, -1:]])
    forces = np.empty((len(v.rotors), n))
    for k in range(n):
        c, s = np.cos(yaw[k]), np.sin(yaw[k])
        Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        f_body = Rz.T @ (v.mass * (acc[:, k] + np.array([0.0, 0.0, v.gravity])))
        wrench = np.concatenate([f_body, [0.0, 0.0, Jzz * yaw_acc[k]]])
        forces[:, k] = np.clip(Wp @ wrench, v.force_min, v.force_max)
    X = np.zeros((12 + len(v.rotors), n))
    X[0:3], X[6:9] = P, V
    X[3:5] = 0.0
    X[5] = yaw
    X[11] = yaw_rate
    X[12:] = forces
    X[:, 0] = MultirotorModel().initial_state(v)
    U = np.diff(X[12:], axis=1) / dt
    return X, U


__all__ = ["MultirotorModel", "AXES"]


def thrust_accelerations(v: Multirotor) -> tuple[float, float]:
    """(horizontal, climbing) acceleration (m/s²) of ``v`` at full thrust along its body z
    axis: level flight at the largest tilt the envelope allows where the thrust still holds
    the weight (g·tan θ), and straight up (T/m − g)."""
    thrust = float(sum(max(r.axis[2], 0.0) for r in v.rotors)) * v.force_max
    weight = v.mass * v.gravity
    if thrust <= weight:
        return 0.0, 0.0
    tilt = min(ENVELOPE_TILT, float(np.arccos(weight / thrust)))
    return v.gravity * float(np.tan(tilt)), thrust / v.mass - v.gravity
