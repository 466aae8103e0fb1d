"""Vehicle dynamics: the model-specific math — continuous ODEs, discretisation, hover,
energy and rotor speed.

Consumed through the vehicle registry (``stlc.vehicles``: layout, bounds, start state,
derived signals per model), by the CasADi backend (SX expressions, multiple shooting), by
the simulator / replay and by the monitor and reports (numpy).  Rotor geometry and
allocation live in ``stlc.vehicles.geometry``.

Multirotor (paper A, eq. 1), state in ``Multirotor.channels()`` order
    x = (p (3), η = (roll φ, pitch θ, yaw ψ) (3), v (3, world), ω (3, body), ξ (n)),  u = ξ̇ (n)
    ṗ = v
    η̇ = T(η) ω                          (ZYX Euler rates; singular at θ = ±90°)
    m v̇ = m g + R(η) G_f ξ              g = (0, 0, −gravity), R = Rz(ψ) Ry(θ) Rx(φ) body→world
    J ω̇ = −ω × Jω + G_τ ξ
    ξ̇ = u
Point mass (paper B): x = (p, v), u = a, ṗ = v, v̇ = a.

Energy (paper A, eq. 5).  The paper writes Σ_i c_f Ω_i³ + ½ vᵀ m v + ½ ωᵀ J ω with Ω_i the
*squared* rotor speed (Table 2, §3.1).  Read literally that is c_f (ξ_i/c_f)³ ≈ 4.5·10⁷ per
rotor at hover for Table 3's parameters, in N·Hz⁴ — not a power, and it would swamp the
kinetic terms and the robustness.  The physical shaft power of a rotor is drag torque ×
angular speed: P_i = c_τ Ω_i · 2π √Ω_i = 2π c_τ (ξ_i/c_f)^{3/2} W (≈ 29.7 W per rotor at
hover for paper A's hexarotor — a plausible figure), i.e. the "speed³" law the paper
evidently means.  Per sample we take the energy e_k = T_s Σ_i P_i + ½ m|v|² + ½ ωᵀJω (J), the
paper's structure with dimensionally consistent terms, and by default divide it by the hover
energy per sample T_s P_hover, so a sample at hover costs exactly 1 and Σ_k e_k over N
samples is N at hover; manoeuvres change a sample's cost by ~0.001–0.1 (e.g. +0.01 for
0.4 m/s at T_s = 0.1 s), the same order as robustness in metres (see ``energy_terms``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from stlc.lazy import lazy

ca = lazy("casadi")  # CasADi runs only when a plan is built (``stlc.lazy``)
import numpy as np

from stlc.vehicles.geometry import allocation, wrench_matrix
from stlc.vehicles.declared import Multirotor, PointMass

#: state layout offsets of the multirotor (see module docstring)
POS, ATT, VEL, RATE, FORCE = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), 12


class DynamicsError(ValueError):
    """The vehicle cannot be modelled as asked (e.g. it cannot hover within its limits)."""


# --------------------------------------------------------------------------- rotations


def rotation_np(eta: np.ndarray) -> np.ndarray:
    """R = Rz(ψ) Ry(θ) Rx(φ) (body → world) for η = (φ, θ, ψ)."""
    cf, sf = math.cos(eta[0]), math.sin(eta[0])
    ct, st = math.cos(eta[1]), math.sin(eta[1])
    cp, sp = math.cos(eta[2]), math.sin(eta[2])
    rx = np.array([[1, 0, 0], [0, cf, -sf], [0, sf, cf]])
    ry = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
    rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1]])
    return rz @ ry @ rx


def euler_rate_matrix_np(eta: np.ndarray) -> np.ndarray:
    """T(η) with η̇ = T(η) ω, ω the body angular velocity (ZYX Euler angles)."""
    cf, sf = math.cos(eta[0]), math.sin(eta[0])
    ct, tt = math.cos(eta[1]), math.tan(eta[1])
    return np.array([[1, sf * tt, cf * tt], [0, cf, -sf], [0, sf / ct, cf / ct]])


def rotation_sx(eta: ca.SX) -> ca.SX:
    """CasADi version of ``rotation_np`` (written out element-wise, no matrix products)."""
    cf, sf = ca.cos(eta[0]), ca.sin(eta[0])
    ct, st = ca.cos(eta[1]), ca.sin(eta[1])
    cp, sp = ca.cos(eta[2]), ca.sin(eta[2])
    return ca.vertcat(
        ca.horzcat(cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf),
        ca.horzcat(sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf),
        ca.horzcat(-st, ct * sf, ct * cf),
    )


def euler_rate_matrix_sx(eta: ca.SX) -> ca.SX:
    cf, sf = ca.cos(eta[0]), ca.sin(eta[0])
    ct, tt = ca.cos(eta[1]), ca.tan(eta[1])
    return ca.vertcat(
        ca.horzcat(1, sf * tt, cf * tt),
        ca.horzcat(0, cf, -sf),
        ca.horzcat(0, sf / ct, cf / ct),
    )


# --------------------------------------------------------------------------- ODEs


def _sparse_dm(a: np.ndarray) -> ca.DM:
    return ca.sparsify(ca.DM(a))


def multirotor_ode(vehicle: Multirotor) -> ca.Function:
    """``f(x, u) -> ẋ`` as an SX Function (names ``x``, ``u`` → ``xdot``)."""
    nu = len(vehicle.rotors)
    x = ca.SX.sym("x", 12 + nu)
    u = ca.SX.sym("u", nu)
    eta, v, w, xi = x[ATT], x[VEL], x[RATE], x[FORCE:]
    g_f, g_tau = allocation(vehicle.rotors, vehicle.c_f, vehicle.c_tau)
    j = np.array(vehicle.inertia, dtype=float)
    j_inv = np.linalg.inv(j)
    j_inv[np.abs(j_inv) < 1e-15 * np.abs(j_inv).max()] = 0.0
    f_body = ca.mtimes(_sparse_dm(g_f), xi)
    tau = ca.mtimes(_sparse_dm(g_tau), xi)
    jw = ca.mtimes(_sparse_dm(j), w)
    acc = ca.mtimes(rotation_sx(eta), f_body) / vehicle.mass + ca.DM([0, 0, -vehicle.gravity])
    wdot = ca.mtimes(_sparse_dm(j_inv), tau - ca.cross(w, jw))
    etadot = ca.mtimes(euler_rate_matrix_sx(eta), w)
    xdot = ca.vertcat(v, etadot, acc, wdot, u)
    return ca.Function("f", [x, u], [xdot], ["x", "u"], ["xdot"])


def multirotor_ode_np(vehicle: Multirotor) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Plain-numpy ``f(x, u) -> ẋ`` (simulation, tests); independent of the CasADi code."""
    g_f, g_tau = allocation(vehicle.rotors, vehicle.c_f, vehicle.c_tau)
    j = np.array(vehicle.inertia, dtype=float)
    gvec = np.array([0.0, 0.0, -vehicle.gravity])
    m = vehicle.mass

    def f(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        eta, v, w, xi = x[ATT], x[VEL], x[RATE], x[FORCE:]
        acc = gvec + rotation_np(eta) @ (g_f @ xi) / m
        wdot = np.linalg.solve(j, g_tau @ xi - np.cross(w, j @ w))
        return np.concatenate([v, euler_rate_matrix_np(eta) @ w, acc, wdot, np.asarray(u)])

    return f


def point_mass_ode(vehicle: PointMass) -> ca.Function:
    """``f(x, u) -> ẋ`` for x = (p, v), u = a (double integrator per axis)."""
    x = ca.SX.sym("x", 6)
    u = ca.SX.sym("u", 3)
    return ca.Function("f", [x, u], [ca.vertcat(x[3:6], u)], ["x", "u"], ["xdot"])


# --------------------------------------------------------------------------- bounds, start


@dataclass(frozen=True, slots=True)
class Bounds:
    """Simple box bounds of a vehicle model (±inf where unbounded)."""

    x_lo: np.ndarray
    x_hi: np.ndarray
    u_lo: np.ndarray
    u_hi: np.ndarray


def hover_forces(vehicle: Multirotor, *, check_bounds: bool = True) -> np.ndarray:
    """Rotor forces holding the vehicle level with zero torque.

    Least-norm solution of [G_f; G_τ] ξ = (0, 0, m g, 0, 0, 0) (unique for a fully-actuated
    layout).  Raises ``DynamicsError`` if the wrench cannot be produced (residual > 1e-9 m g)
    or, with ``check_bounds``, if a force lies outside [force_min, force_max].
    """
    a = wrench_matrix(vehicle.rotors, vehicle.c_f, vehicle.c_tau)
    mg = vehicle.mass * vehicle.gravity
    w = np.array([0.0, 0.0, mg, 0.0, 0.0, 0.0])
    xi = np.linalg.pinv(a, rcond=1e-10) @ w
    residual = float(np.linalg.norm(a @ xi - w))
    if residual > 1e-9 * max(mg, 1.0):
        raise DynamicsError(
            f"{vehicle.name} cannot hover: its rotors cannot cancel gravity and torque "
            f"(residual {residual:.3g} N)"
        )
    if check_bounds and (
        np.any(xi < vehicle.force_min - 1e-12) or np.any(xi > vehicle.force_max + 1e-12)
    ):
        raise DynamicsError(
            f"{vehicle.name} cannot hover within its force limits "
            f"[{vehicle.force_min}, {vehicle.force_max}] N: needs {np.round(xi, 4).tolist()} N"
        )
    return xi


# --------------------------------------------------------------------------- discretisation


def _as_sx(f: ca.Function) -> ca.Function:
    return f if f.is_a("SXFunction") else f.expand()


def _step(f: ca.Function, dt: float, substeps: int, name: str, rk4: bool) -> ca.Function:
    if substeps < 1:
        raise ValueError(f"substeps must be >= 1, got {substeps}")
    f = _as_sx(f)
    x = ca.SX.sym("x", f.size1_in(0))
    u = ca.SX.sym("u", f.size1_in(1))
    h = dt / substeps
    xk = x
    for _ in range(substeps):
        k1 = f(xk, u)
        if rk4:
            k2 = f(xk + (h / 2) * k1, u)
            k3 = f(xk + (h / 2) * k2, u)
            k4 = f(xk + h * k3, u)
            xk = xk + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
        else:
            xk = xk + h * k1
    return ca.Function(name, [x, u], [xk], ["x", "u"], ["x_next"], {"cse": True})


def rk4_step(f: ca.Function, dt: float, substeps: int = 1) -> ca.Function:
    """``F(x, u) -> x_next``: classic RK4 over ``dt`` with ``substeps`` equal sub-steps and u
    held constant (zero-order hold).  Built once in SX (common subexpressions merged); call
    it per interval or use ``F.map(N)`` for all intervals of a multiple-shooting grid."""
    return _step(f, dt, substeps, "F", rk4=True)


def euler_step(f: ca.Function, dt: float, substeps: int = 1) -> ca.Function:
    """``F(x, u) -> x_next`` by explicit Euler (cheaper; check accuracy by re-simulating)."""
    return _step(f, dt, substeps, "F", rk4=False)


MAX_SUBSTEP = 0.1  # s: integrator sub-steps per interval are at most this long


def substeps(dt: float) -> int:
    """RK4 sub-steps per interval: a coarse grid (e.g. 0.5 s in tests) is integrated as
    accurately as the 0.1 s grid of the papers (one RK4 step per 0.5 s was off by 3-4 cm)."""
    return max(1, int(np.ceil(dt / MAX_SUBSTEP - 1e-9)))


def discrete_dynamics(
    f: ca.Function, dt: float, method: str = "rk4", substeps: int = 1
) -> ca.Function:
    """Convenience: the discrete step of the ODE ``f`` (``method`` "rk4" or "euler"); a
    vehicle's ODE is ``stlc.vehicles.model_of(v).ode(v)``."""
    if method not in ("rk4", "euler"):
        raise ValueError(f'method must be "rk4" or "euler", got {method!r}')
    return _step(f, dt, substeps, "F", rk4=method == "rk4")


# --------------------------------------------------------------------------- energy


def rotor_power(vehicle: Multirotor, xi: np.ndarray) -> np.ndarray:
    """Aerodynamic shaft power (W) per rotor: 2π c_τ (ξ/c_f)^{3/2} (ξ clipped at 0)."""
    omega = np.maximum(np.asarray(xi, dtype=float), 0.0) / vehicle.c_f
    return 2.0 * math.pi * vehicle.c_tau * omega**1.5


def hover_power(vehicle: Multirotor) -> float:
    """Total rotor power (W) at hover (least-norm hover forces, bounds not checked)."""
    return float(np.sum(rotor_power(vehicle, hover_forces(vehicle, check_bounds=False))))


def _energy_scale(vehicle: Multirotor, dt: float, normalize: bool) -> float:
    if dt <= 0:
        raise ValueError(f"dt must be positive, got {dt}")
    return dt * hover_power(vehicle) if normalize else 1.0


def energy_terms(vehicle: Multirotor, x: ca.SX, dt: float, normalize: bool = True) -> ca.SX:
    """Per-sample energy of eq. 5 as an SX scalar of one state sample ``x`` (nx × 1).

    e = T_s Σ_i P_i(ξ_i) + ½ m vᵀv + ½ ωᵀJω  (J), P_i the rotor power (``rotor_power``).
    With ``normalize`` (default) e is divided by the hover energy per sample T_s P_hover:
    a sample at hover costs 1, so Σ_k e_k over N samples is N at hover and the weight w is
    compared with robustness in metres on an O(1)-per-sample scale.  ``normalize=False``
    returns joules.  ξ is clipped at 0 (ξ ≥ force_min > 0 in any feasible plan).
    """
    j = np.array(vehicle.inertia, dtype=float)
    xi, v, w = x[FORCE:], x[VEL], x[RATE]
    k = 2.0 * math.pi * vehicle.c_tau / vehicle.c_f**1.5
    xi_pos = ca.fmax(xi, 0)
    power = k * ca.sum1(xi_pos * ca.sqrt(xi_pos))
    kinetic = 0.5 * vehicle.mass * ca.dot(v, v) + 0.5 * ca.dot(w, ca.mtimes(_sparse_dm(j), w))
    return (dt * power + kinetic) / _energy_scale(vehicle, dt, normalize)


def energy(vehicle: Multirotor, X: np.ndarray, dt: float, normalize: bool = True) -> float:
    """Σ_k of ``energy_terms`` over the rows of ``X`` (n_samples × nx), in numpy."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    j = np.array(vehicle.inertia, dtype=float)
    v, w = X[:, VEL], X[:, RATE]
    power = rotor_power(vehicle, X[:, FORCE:]).sum(axis=1)
    kinetic = 0.5 * vehicle.mass * np.sum(v * v, axis=1) + 0.5 * np.einsum("ki,ij,kj->k", w, j, w)
    return float(np.sum(dt * power + kinetic) / _energy_scale(vehicle, dt, normalize))


def optimal_forward_speed(
    mass: float,
    air_density: float,
    disk_area: float,
    kappa: float,
    n_rotors: int,
    flat_plate_area: float,
) -> float:
    """Paper B eq. 8: v* = √(m / (2ρA)) · (4κA / (n_r f))^{1/4}."""
    return (
        math.sqrt(mass / (2 * air_density * disk_area))
        * (4 * kappa * disk_area / (n_rotors * flat_plate_area)) ** 0.25
    )


def forward_speed_target(vehicle: PointMass, v_star: float) -> float:
    """v* capped at the fastest feasible horizontal speed hypot(v̄_x, v̄_y) (paper B §IV)."""
    return min(v_star, math.hypot(vehicle.vel_max[0], vehicle.vel_max[1]))


def forward_speed_terms(x: ca.SX, v_star: float, eps: float = 1e-3) -> ca.SX:
    """Per-sample (1 − v_for/v*)² of paper B eq. 9–10, v_for = √(v_x² + v_y² + ε²) (smooth at
    v = 0) for a point-mass state x = (p, v); the NLP adds η Σ_k of it to the cost."""
    v_for = ca.sqrt(x[3] ** 2 + x[4] ** 2 + eps**2)
    return (1 - v_for / v_star) ** 2


def forward_speed_cost(X: np.ndarray, v_star: float, eps: float = 1e-3) -> float:
    """Σ_k ``forward_speed_terms`` over the rows of ``X`` (n_samples × 6), in numpy."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    v_for = np.sqrt(X[:, 3] ** 2 + X[:, 4] ** 2 + eps**2)
    return float(np.sum((1 - v_for / v_star) ** 2))


# --------------------------------------------------------------------------- derived signals


def rotor_speed_hz(vehicle: Multirotor, xi: np.ndarray) -> np.ndarray:
    """Rotor speed (Hz) from force: √(ξ/c_f) (Ω = ξ/c_f is the squared speed; ξ < 0 → 0)."""
    return np.sqrt(np.maximum(np.asarray(xi, dtype=float), 0.0) / vehicle.c_f)
