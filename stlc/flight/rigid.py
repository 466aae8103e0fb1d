"""The simulators of the closed loop, vectorised over runs: N copies of a vehicle step
together as arrays (``(N, 3)`` positions, ``(N, 3, 3)`` attitudes, …), each with its own
wind and sensor noise.

* **Rigid-body multirotor** (the full model of ``stlc.vehicles.dynamics``, with the
  attitude kept as a rotation matrix): ``m v̇ = m g + R G_f ξ + D``, ``J ω̇ = G_τ ξ − ω × Jω``,
  ``Ṙ = R ω̂``; rotor forces follow their commands with a first-order lag
  (exactly discretised, ``FlightSetup.rotor_tau``, 30 ms) within the declared bounds; D is
  the quadratic drag of the air velocity ``½ ρ C_dA |w − v| (w − v)`` (``drag_area``
  C_dA = 0.1 m², ρ = 1.225 kg/m³).  Semi-implicit Euler at ``FlightSetup.dt``
  (velocity first, then position; the attitude through Rodrigues' formula, so R stays a
  rotation).
* **Point mass**: ``ṗ = v``, ``v̇ = a + D/m`` with the tracker's acceleration ``a``
  (declared mass, else ``POINT_MASS_KG``).

Sensor noise: the controller sees position and velocity with white Gaussian errors of
``noise_pos`` m and ``noise_vel`` m/s per axis.  Pushes (the mission's ``simulate``
disturbances) displace the vehicle (and change its velocity) at their instants.  The
state is recorded at the plan's sample times, and the tracking error ‖p − p_plan‖ at
every step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from stlc.flight import frames
from stlc.flight.control import Gains, Geometric, PointTracker, cross, hat
from stlc.flight.wind import GUST_STEP, Wind

AIR_DENSITY = 1.225  # kg/m³
POINT_MASS_KG = 1.5  # a point mass without a declared mass


@dataclass(frozen=True)
class FlightSetup:
    dt: float = 0.002  # s, the integration step (independent of the plan's grid)
    wind: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s, ENU
    turbulence: str = "none"
    noise_pos: float = 0.0  # m
    noise_vel: float = 0.0  # m/s
    pushes: tuple = ()  # ``model.Disturbance`` of the flown vehicles
    gains: Gains = field(default_factory=Gains)
    rotor_tau: float = 0.03  # s, rotor force time constant
    drag_area: float = 0.1  # m², C_d·A of a multirotor body (point mass: the same)


@dataclass
class Reference:
    """The plan of one drone on the fine steps: pos, vel, acc (k, 3), yaw, yaw_rate (k,),
    R (k, 3, 3) from the plan's attitude."""

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    yaw: np.ndarray
    yaw_rate: np.ndarray
    R: np.ndarray

    def at(self, k: int) -> "_Point":
        return _Point(self.pos[k], self.vel[k], self.acc[k], float(self.yaw[k]),
                      float(self.yaw_rate[k]), self.R[k])


@dataclass
class _Point:
    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    yaw: float
    yaw_rate: float
    R: np.ndarray


def reference(track, dt: float) -> Reference:
    """The plan (``stlc.flight.export.Track``) on steps of ``dt``: position and velocity by
    cubic Hermite interpolation of the planned positions and velocities (consistent with
    each other), acceleration, yaw, yaw rate and roll/pitch linearly."""
    from scipy.interpolate import CubicHermiteSpline

    t = np.arange(0.0, float(track.t[-1]) + 1e-9, dt)
    if track.t.size > 1:
        spl = CubicHermiteSpline(track.t, track.pos, track.vel, axis=0)
        pos, vel = spl(t), spl(t, 1)
    else:
        pos, vel = np.repeat(track.pos, t.size, 0), np.repeat(track.vel, t.size, 0)

    def lin(x):
        return np.stack([np.interp(t, track.t, x[:, i]) for i in range(x.shape[1])], axis=1)

    att = lin(np.column_stack([track.att[:, :2], np.unwrap(track.att[:, 2])]))
    return Reference(t, pos, vel, lin(track.acc), att[:, 2],
                     np.interp(t, track.t, track.yaw_rate), frames.rotation(att))


@dataclass
class Flown:
    """N runs of one vehicle at the plan's samples: ``states`` (N, n, nx) in the vehicle
    model's state-channel order, ``inputs`` (N, n, nu); the tracking error's maximum and
    RMS over the whole flight (N,)."""

    states: np.ndarray
    inputs: np.ndarray
    err_max: np.ndarray
    err_rms: np.ndarray


def _push_steps(pushes, dt: float) -> dict[int, list]:
    out: dict[int, list] = {}
    for d in pushes:
        out.setdefault(int(round(d.time / dt)), []).append(d)
    return out


def _rodrigues(w: np.ndarray, dt: float) -> np.ndarray:
    """exp(ŵ dt) for (N, 3) body rates."""
    th2 = np.einsum("ni,ni->n", w, w) * dt * dt
    K = hat(w * dt)
    th = np.sqrt(th2)
    small = th < 1e-4  # series: sin θ/θ = 1 − θ²/6, (1 − cos θ)/θ² = 1/2 − θ²/24
    safe = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - th2 / 24.0, (1.0 - np.cos(safe)) / (safe * safe))
    return np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K)


def fly(v, track, grid: np.ndarray, setup: FlightSetup, runs: int,
        rng: np.random.Generator) -> Flown:
    """Fly ``runs`` copies of vehicle ``v`` along ``track`` (its plan); record at ``grid``."""
    from stlc.vehicles import model_of

    dt = setup.dt
    ref = reference(track, dt)
    steps = ref.t.size
    rec = {int(round(t / dt)): j for j, t in enumerate(grid)}
    wind = Wind(setup.wind, setup.turbulence, float(np.mean(track.pos[:, 2])), GUST_STEP, runs,
                rng)
    hold = max(1, int(round(GUST_STEP / dt)))
    pushes = _push_steps(setup.pushes, dt)
    rotor = model_of(v).rotor_forces(v) is not None
    p = np.repeat(track.pos[:1], runs, 0)
    vel = np.repeat(track.vel[:1], runs, 0)
    drag = 0.5 * AIR_DENSITY * setup.drag_area
    if rotor:
        ctl = Geometric(v, setup.gains)
        m, J = ctl.m, ctl.J
        Jinv = np.linalg.inv(J)
        R = np.repeat(frames.rotation(track.att[:1]), runs, 0)
        w = np.repeat(track.rate[:1], runs, 0)
        from stlc.vehicles.dynamics import hover_forces

        xi = np.repeat(np.asarray(hover_forces(v, check_bounds=False))[None], runs, 0)
        lag = 1.0 - np.exp(-dt / setup.rotor_tau)
        gvec = np.array([0.0, 0.0, -ctl.g])
        nx, nu = 12 + xi.shape[1], xi.shape[1]
    else:
        ctl = PointTracker(v, setup.gains)
        m = float(v.mass) if getattr(v, "mass", None) else POINT_MASS_KG
        nx, nu = 6, 3
    states = np.zeros((runs, grid.size, nx))
    inputs = np.zeros((runs, grid.size, nu))
    emax = np.zeros(runs)
    esq = np.zeros(runs)
    air = wind.sample()
    for k in range(steps):
        if k in pushes:
            for d in pushes[k]:
                p = p + np.asarray(d.displacement)
                vel = vel + np.asarray(d.velocity)
        if k % hold == 0 and k:
            air = wind.sample()
        r = ref.at(k)
        d = p - r.pos
        e2 = np.einsum("ni,ni->n", d, d)
        emax = np.maximum(emax, e2)
        esq += e2
        pm = p + setup.noise_pos * rng.standard_normal(p.shape) if setup.noise_pos else p
        vm = vel + setup.noise_vel * rng.standard_normal(p.shape) if setup.noise_vel else vel
        rel = air - vel
        f_air = (drag * np.sqrt(np.einsum("ni,ni->n", rel, rel)))[:, None] * rel
        if rotor:
            cmd = ctl(pm, vm, R, w, r)
            u = (cmd - xi) / setup.rotor_tau
            j = rec.get(k)
            if j is not None:
                states[:, j] = np.concatenate([p, frames.euler(R), vel, w, xi], axis=1)
                inputs[:, j] = u
            acc = gvec + (np.einsum("nij,nj->ni", R, xi @ ctl.G_f.T) + f_air) / m
            wdot = (xi @ ctl.G_tau.T - cross(w, w @ J.T)) @ Jinv.T
            xi = xi + (cmd - xi) * lag
            vel = vel + acc * dt
            p = p + vel * dt
            R = R @ _rodrigues(w, dt)
            w = w + wdot * dt
        else:
            a = ctl(pm, vm, r)
            j = rec.get(k)
            if j is not None:
                states[:, j] = np.concatenate([p, vel], axis=1)
                inputs[:, j] = a
            vel = vel + (a + f_air / m) * dt
            p = p + vel * dt
    return Flown(states, inputs, np.sqrt(emax), np.sqrt(esq / steps))
