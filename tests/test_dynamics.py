"""Tests for stlc.vehicles.geometry and stlc.vehicles.dynamics against independently computed
values."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from stlc.vehicles import geometry as geo
from stlc.vehicles import dynamics as dyn
from stlc.semantics.model import Multirotor, PointMass, Rotor
from stlc.vehicles import model_of

# paper A, Table 3 (arm and tilt are not published; ≈ 0.39 m and 20° are our choice)
MASS, C_F, C_TAU = 2.25, 11.5e-4, 2.38e-5
INERTIA = ((2.07e-2, 0.0, 0.0), (0.0, 2.10e-2, 0.0), (0.0, 0.0, 3.10e-2))
ARM, TILT = 0.39, math.radians(20.0)
K = C_TAU / C_F


def multirotor(rotors: tuple[Rotor, ...], **kw) -> Multirotor:
    args = dict(
        name="h",
        mass=MASS,
        inertia=INERTIA,
        c_f=C_F,
        c_tau=C_TAU,
        force_min=0.29,
        force_max=11.5,
        rotors=rotors,
        start_pos=(-1.8, 0.0, 1.0),
    )
    args.update(kw)
    return Multirotor(**args)


@pytest.fixture(scope="module")
def hexa() -> Multirotor:
    return multirotor(geo.hexarotor(ARM, TILT))


@pytest.fixture(scope="module")
def hexa_f(hexa):
    return dyn.multirotor_ode(hexa)


def near_hover_states(
    vehicle: Multirotor, rng: np.random.Generator, n: int, dxi: float = 1.0, rate: float = 0.8
) -> np.ndarray:
    """Random states: any position and yaw, roll/pitch ±0.4 rad, |v| ≤ 1 m/s per axis,
    body rates ±``rate`` rad/s, rotor forces hover ± ``dxi`` N."""
    xi = dyn.hover_forces(vehicle)
    out = []
    for _ in range(n):
        x = np.concatenate(
            [
                rng.uniform(-2, 2, 3),
                rng.uniform(-0.4, 0.4, 2).tolist() + [rng.uniform(-math.pi, math.pi)],
                rng.uniform(-1, 1, 3),
                rng.uniform(-rate, rate, 3),
                xi + rng.uniform(-dxi, dxi, xi.size),
            ]
        )
        out.append(x)
    return np.array(out)


# ----------------------------------------------------------------------------- allocation


def test_plus_quadrotor_allocation_is_textbook():
    l = 0.25  # noqa: E741
    rot = geo.quadrotor(l, "+")  # front, left, back, right; spins +, -, +, -
    g_f, g_tau = geo.allocation(rot, C_F, C_TAU)
    expected = np.array(
        [
            [1, 1, 1, 1],  # thrust
            [0, l, 0, -l],  # roll: left rotor lifts +y side
            [-l, 0, l, 0],  # pitch: front rotor pitches nose up (negative about y)
            [-K, K, -K, K],  # yaw: CCW rotors (front, back) push the body clockwise
        ]
    )
    got = np.vstack([g_f[2], g_tau])
    np.testing.assert_allclose(got, expected, atol=1e-15)
    np.testing.assert_allclose(g_f[:2], 0.0, atol=1e-15)


def test_x_quadrotor_allocation_is_textbook():
    l = 0.25  # noqa: E741
    d = l / math.sqrt(2)
    rot = geo.quadrotor(l, "x")  # front-left, back-left, back-right, front-right
    np.testing.assert_allclose(
        [r.position for r in rot], [[d, d, 0], [-d, d, 0], [-d, -d, 0], [d, -d, 0]], atol=1e-15
    )
    g_f, g_tau = geo.allocation(rot, C_F, C_TAU)
    expected = np.array(
        [
            [1, 1, 1, 1],
            [d, d, -d, -d],
            [-d, d, d, -d],
            [-K, K, -K, K],
        ]
    )
    np.testing.assert_allclose(np.vstack([g_f[2], g_tau]), expected, atol=1e-15)


def test_first_spin_flips_yaw_row():
    a = geo.allocation(geo.quadrotor(0.2, "x", first_spin=-1), C_F, C_TAU)[1]
    b = geo.allocation(geo.quadrotor(0.2, "x"), C_F, C_TAU)[1]
    np.testing.assert_allclose(a[2], -b[2])
    np.testing.assert_allclose(a[:2], b[:2])


def test_tilted_hexarotor_geometry():
    rot = geo.hexarotor(ARM, TILT)
    for k, r in enumerate(rot):
        ang = k * math.pi / 3
        arm_dir = np.array([math.cos(ang), math.sin(ang), 0.0])
        np.testing.assert_allclose(r.position, ARM * arm_dir, atol=1e-15)
        z = np.array(r.axis)
        assert abs(np.linalg.norm(z) - 1) < 1e-15
        assert abs(z @ arm_dir) < 1e-15  # tilted about the arm
        assert math.isclose(z[2], math.cos(TILT))
        # sign of the tilt alternates: tangential component along ±(arm × z_B)
        tangential = z @ np.array([math.sin(ang), -math.cos(ang), 0.0])
        assert math.isclose(tangential, (-1) ** k * math.sin(TILT))
        assert r.spin == (-1) ** k
    assert np.linalg.matrix_rank(geo.wrench_matrix(rot, C_F, C_TAU)) == 6
    flat = geo.hexarotor(ARM)
    assert np.linalg.matrix_rank(geo.wrench_matrix(flat, C_F, C_TAU)) == 4


def test_geometry_errors():
    with pytest.raises(geo.GeometryError):
        geo.quadrotor(0.2, "h")
    with pytest.raises(geo.GeometryError):
        geo.allocation((Rotor((0, 0, 0), (0, 0, 0), 1),), C_F, C_TAU)
    with pytest.raises(geo.GeometryError):
        geo.allocation((Rotor((0, 0, 0), (0, 0, 1), 2),), C_F, C_TAU)


# ----------------------------------------------------------------------------- hover


def test_hover_tilted_hexarotor(hexa, hexa_f):
    xi = dyn.hover_forces(hexa)
    mg = MASS * 9.81
    # by symmetry every rotor carries the same force; its vertical parts sum to m g
    np.testing.assert_allclose(xi, mg / (6 * math.cos(TILT)), rtol=1e-12)
    assert math.isclose(xi[0], 3.9148439805, rel_tol=1e-10)
    g_f, g_tau = geo.allocation(hexa.rotors, C_F, C_TAU)
    assert np.linalg.norm(g_f @ xi - [0, 0, mg]) < 1e-9
    assert np.linalg.norm(g_tau @ xi) < 1e-9
    assert np.all(xi >= hexa.force_min) and np.all(xi <= hexa.force_max)
    # rotor speed inside the paper's comfort band 40..80 Hz
    hz = dyn.rotor_speed_hz(hexa, xi)
    np.testing.assert_allclose(hz, math.sqrt(xi[0] / C_F))
    assert np.all((hz > 40) & (hz < 80))
    # the ODE is at rest at hover, at any position and yaw
    x = np.concatenate([[1, 2, 3], [0, 0, 0.7], np.zeros(6), xi])
    assert np.abs(np.array(hexa_f(x, np.zeros(6)))).max() < 1e-12


@pytest.mark.parametrize("rotors, n", [(geo.quadrotor(0.2, "x"), 4), (geo.hexarotor(0.3), 6)])
def test_hover_flat(rotors, n):
    xi = dyn.hover_forces(multirotor(rotors))
    np.testing.assert_allclose(xi, MASS * 9.81 / n, rtol=1e-12)


def test_hover_infeasible():
    with pytest.raises(dyn.DynamicsError, match="force limits"):
        dyn.hover_forces(multirotor(geo.quadrotor(0.2), force_max=5.0))
    sideways = tuple(Rotor(r.position, (1.0, 0.0, 0.0), r.spin) for r in geo.quadrotor(0.2))
    with pytest.raises(dyn.DynamicsError, match="cannot hover"):
        dyn.hover_forces(multirotor(sideways))


# ----------------------------------------------------------------------------- ODE


def test_rotation_and_euler_matrices():
    rng = np.random.default_rng(1)
    eta_s = ca.SX.sym("eta", 3)
    r_fun = ca.Function("R", [eta_s], [dyn.rotation_sx(eta_s), dyn.euler_rate_matrix_sx(eta_s)])
    for _ in range(5):
        eta = rng.uniform(-1.2, 1.2, 3)
        r = dyn.rotation_np(eta)
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-14)
        assert math.isclose(np.linalg.det(r), 1.0)
        r_sx, t_sx = (np.array(a) for a in r_fun(eta))
        np.testing.assert_allclose(r_sx, r, atol=1e-14)
        np.testing.assert_allclose(t_sx, dyn.euler_rate_matrix_np(eta), atol=1e-14)
    # pure roll: body z leans towards -y world
    np.testing.assert_allclose(
        dyn.rotation_np([0.3, 0, 0]) @ [0, 0, 1], [0, -math.sin(0.3), math.cos(0.3)]
    )


def test_casadi_ode_matches_numpy(hexa, hexa_f):
    f_np = dyn.multirotor_ode_np(hexa)
    rng = np.random.default_rng(2)
    for x in near_hover_states(hexa, rng, 10):
        u = rng.uniform(-5, 5, 6)
        np.testing.assert_allclose(np.array(hexa_f(x, u)).ravel(), f_np(x, u), atol=1e-12)


def test_rolled_flat_quad_accelerates_sideways():
    quad = multirotor(geo.quadrotor(0.2, "+"))
    f = dyn.multirotor_ode(quad)
    xi = dyn.hover_forces(quad)
    x = np.concatenate([np.zeros(3), [0.1, 0, 0], np.zeros(6), xi])
    xdot = np.array(f(x, np.zeros(4))).ravel()
    np.testing.assert_allclose(xdot[6:9], [0, -9.81 * math.sin(0.1), 9.81 * (math.cos(0.1) - 1)])
    np.testing.assert_allclose(xdot[9:12], 0, atol=1e-12)


def test_torque_free_body_keeps_world_angular_momentum(hexa):
    """With torque-free forces, R(η) J ω is constant — checks T(η) against R(η)."""
    f_np = dyn.multirotor_ode_np(hexa)
    j = np.array(INERTIA)
    x0 = np.concatenate(
        [np.zeros(3), [0.2, -0.3, 1.0], np.zeros(3), [1.5, -0.7, 2.0], dyn.hover_forces(hexa)]
    )
    sol = solve_ivp(lambda t, x: f_np(x, np.zeros(6)), (0, 1.0), x0, rtol=1e-11, atol=1e-12)
    moments = [dyn.rotation_np(x[3:6]) @ j @ x[9:12] for x in sol.y.T]
    energies = [0.5 * x[9:12] @ j @ x[9:12] for x in sol.y.T]
    np.testing.assert_allclose(moments, np.tile(moments[0], (len(moments), 1)), atol=1e-8)
    np.testing.assert_allclose(energies, energies[0], rtol=1e-9)


# ----------------------------------------------------------------------------- discretisation


def reference_step(f_np, x, u, dt):
    sol = solve_ivp(lambda t, y: f_np(y, u), (0, dt), x, rtol=1e-10, atol=1e-12, method="DOP853")
    return sol.y[:, -1]


def test_rk4_matches_solve_ivp(hexa, hexa_f):
    """RK4 is exact to O(dt⁴) only: the chain u → ξ → ω → η → v → p has five integrators, so
    a constant ξ̇ leaves an unrepresented t⁵ term ≈ g (l ξ̇ / J) dt⁵ / 120 in p (≈ 1e-5 m for
    ξ̇ = 1 N/s, dt = 0.1 s).  Measured max |error| (m, rad, m/s, rad/s) over these cases:
    substeps 1: 4.0e-5, 2: 2.5e-6, 4: 9.3e-8; explicit Euler 0.25."""
    f_np = dyn.multirotor_ode_np(hexa)
    rng = np.random.default_rng(3)
    steps = {s: dyn.rk4_step(hexa_f, 0.1, substeps=s) for s in (1, 2, 4)}
    euler = dyn.euler_step(hexa_f, 0.1)
    errs = {1: 0.0, 2: 0.0, 4: 0.0, "euler": 0.0}
    for x in near_hover_states(hexa, rng, 8, dxi=0.1, rate=0.5):
        u = rng.uniform(-1, 1, 6)
        ref = reference_step(f_np, x, u, 0.1)
        for s, step in steps.items():
            errs[s] = max(errs[s], np.abs(np.array(step(x, u)).ravel() - ref).max())
        errs["euler"] = max(errs["euler"], np.abs(np.array(euler(x, u)).ravel() - ref).max())
    assert errs[1] < 1e-4
    assert errs[2] < 1e-5
    assert errs[4] < 1e-6
    assert errs[2] < errs[1] / 8  # fourth order: halving the step divides the error by ~16
    assert errs["euler"] > 100 * errs[1]


def test_rk4_map_matches_single_calls(hexa, hexa_f):
    step = dyn.rk4_step(hexa_f, 0.1)
    rng = np.random.default_rng(4)
    X = near_hover_states(hexa, rng, 20).T
    U = rng.uniform(-5, 5, (6, 20))
    mapped = np.array(step.map(20)(X, U))
    single = np.column_stack([np.array(step(X[:, k], U[:, k])).ravel() for k in range(20)])
    np.testing.assert_allclose(mapped, single, rtol=1e-14, atol=1e-14)
    # an MX-built ODE is expanded to SX transparently
    xm, um = ca.MX.sym("x", 18), ca.MX.sym("u", 6)
    f_mx = ca.Function("f", [xm, um], [hexa_f(xm, um)])
    np.testing.assert_allclose(
        np.array(dyn.rk4_step(f_mx, 0.1)(X[:, 0], U[:, 0])),
        np.array(step(X[:, 0], U[:, 0])),
        atol=1e-14,
    )


def test_point_mass_dynamics_and_bounds():
    pm = PointMass("d", vel_max=(3.1, 3.1, 2.0), acc_max=(3.1, 3.1, 1.0), start_pos=(0, 0, 1))
    step = dyn.discrete_dynamics(model_of(pm).ode(pm), 0.05)
    x, a = np.array([1, 2, 3, 0.5, -0.5, 0.1]), np.array([1.0, -2.0, 0.3])
    dt = 0.05
    expected = np.concatenate([x[:3] + dt * x[3:] + 0.5 * dt**2 * a, x[3:] + dt * a])
    np.testing.assert_allclose(np.array(step(x, a)).ravel(), expected, atol=1e-15)
    b = model_of(pm).bounds(pm)
    np.testing.assert_array_equal(b.x_hi, [np.inf] * 3 + [3.1, 3.1, 2.0])
    np.testing.assert_array_equal(b.x_lo[3:], [-3.1, -3.1, -2.0])
    np.testing.assert_array_equal(b.u_hi, [3.1, 3.1, 1.0])
    np.testing.assert_array_equal(b.u_lo, [-3.1, -3.1, -1.0])
    np.testing.assert_array_equal(model_of(pm).initial_state(pm), [0, 0, 1, 0, 0, 0])


def test_multirotor_bounds_and_initial_state(hexa):
    mr = multirotor(hexa.rotors, dforce_max=20.0)
    b = model_of(mr).bounds(mr)
    np.testing.assert_array_equal(b.x_lo[12:], 0.29)
    np.testing.assert_array_equal(b.x_hi[12:], 11.5)
    assert np.all(np.isinf(b.x_lo[:12]))
    np.testing.assert_array_equal(b.u_hi, 20.0)
    assert np.all(np.isinf(model_of(hexa).bounds(hexa).u_hi))
    x0 = model_of(hexa).initial_state(hexa)
    assert x0.shape == (len(hexa.channels()),)
    np.testing.assert_allclose(x0[:3], [-1.8, 0, 1])
    np.testing.assert_allclose(x0[12:], dyn.hover_forces(hexa))


# ----------------------------------------------------------------------------- energy


def test_energy_at_hover_by_hand(hexa):
    dt, n = 0.1, 171
    xi = MASS * 9.81 / (6 * math.cos(TILT))
    omega = xi / C_F  # squared speed, Hz²
    p_hover = 6 * C_TAU * omega * 2 * math.pi * math.sqrt(omega)  # torque × angular speed
    assert math.isclose(dyn.hover_power(hexa), p_hover, rel_tol=1e-12)
    assert 150 < p_hover < 200  # ≈ 178 W
    X = np.tile(model_of(hexa).initial_state(hexa), (n, 1))
    assert math.isclose(dyn.energy(hexa, X, dt), n, rel_tol=1e-12)
    assert math.isclose(dyn.energy(hexa, X, dt, normalize=False), n * dt * p_hover, rel_tol=1e-12)
    # moving at 0.4 m/s adds ½ m v² per sample
    X[:, 6] = 0.4
    extra = 0.5 * MASS * 0.16
    assert math.isclose(
        dyn.energy(hexa, X, dt, normalize=False), n * (dt * p_hover + extra), rel_tol=1e-12
    )


def test_energy_casadi_matches_numpy(hexa):
    dt = 0.1
    x = ca.SX.sym("x", 18)
    rng = np.random.default_rng(5)
    X = near_hover_states(hexa, rng, 30)
    for normalize in (True, False):
        e = ca.Function("e", [x], [dyn.energy_terms(hexa, x, dt, normalize)])
        total = float(np.sum(np.array(e.map(30)(X.T))))
        assert math.isclose(total, dyn.energy(hexa, X, dt, normalize), rel_tol=1e-12)


def test_forward_speed_term():
    x = ca.SX.sym("x", 6)
    term = ca.Function("t", [x], [dyn.forward_speed_terms(x, 2.5)])
    X = np.array([[0, 0, 0, 0, 0, 0], [0, 0, 0, 1.5, 2.0, 1.0], [0, 0, 0, 3, 0, -1]], float)
    vals = np.array(term.map(3)(X.T)).ravel()
    np.testing.assert_allclose(vals, [(1 - 1e-3 / 2.5) ** 2, 0.0, 0.2**2], atol=1e-6)
    assert math.isclose(dyn.forward_speed_cost(X, 2.5), vals.sum(), rel_tol=1e-12)
    g = ca.Function("g", [x], [ca.gradient(dyn.forward_speed_terms(x, 2.5), x)])
    assert np.all(np.isfinite(np.array(g(np.zeros(6)))))  # smooth at rest
    pm = PointMass("d", vel_max=(1.0, 1.0, 1.0), acc_max=(1, 1, 1), start_pos=(0, 0, 0))
    assert math.isclose(dyn.forward_speed_target(pm, 2.5), math.sqrt(2))
    # eq. 8 by hand: m = 1, ρ = 1.225, A = 0.05, κ = 1.15, n_r = 4, f = 0.01
    v = math.sqrt(1 / (2 * 1.225 * 0.05)) * (4 * 1.15 * 0.05 / (4 * 0.01)) ** 0.25
    assert math.isclose(dyn.optimal_forward_speed(1, 1.225, 0.05, 1.15, 4, 0.01), v)


# ----------------------------------------------------------------------------- derived signals


def test_derived_channels(hexa):
    X = np.tile(model_of(hexa).initial_state(hexa), (3, 1))
    X[1, 6:9] = [0.0, 0.3, 0.4]
    X[2, 6:9] = [-1.0, 0.0, 0.0]
    X[:, 5] = [0.1, 0.2, -3.0]
    X[2, 12] = 11.5
    d = model_of(hexa).derived_channels(hexa, X)
    assert set(d) == {"h.speed", "h.heading", "h.course"} | {
        f"h.rotor_speed.{i}" for i in range(1, 7)
    }
    np.testing.assert_allclose(d["h.speed"], [0, 0.5, 1.0])
    np.testing.assert_allclose(d["h.course"], [0, math.pi / 2, math.pi])
    np.testing.assert_allclose(d["h.heading"], [0.1, 0.2, -3.0])
    np.testing.assert_allclose(d["h.rotor_speed.1"][2], 100.0)  # √(11.5 / 11.5e-4)
    np.testing.assert_allclose(d["h.rotor_speed.2"], 58.34562672, rtol=1e-9)
    x = ca.SX.sym("x", 18)
    sx = model_of(hexa).derived_channels_sx(hexa, x)
    assert set(sx) == set(d)
    fun = ca.Function("d", [x], [sx[k] for k in sorted(sx)])
    for k_row in range(3):
        for name, val in zip(sorted(sx), fun(X[k_row]), strict=True):
            assert math.isclose(float(val), d[name][k_row], abs_tol=1e-12)
    pm = PointMass("p", vel_max=(1, 1, 1), acc_max=(1, 1, 1), start_pos=(0, 0, 0))
    assert set(model_of(pm).derived_channels(pm, np.zeros((2, 6)))) == {"p.speed", "p.course"}


def test_point_mass_linear_model_matches_its_ode_and_rk4():
    """``linear_model``: the continuous (A, B) reproduces the ODE; the discrete one equals
    the RK4 step the planners use (exact for this polynomial flow) and the closed form."""
    v = PointMass("d", (2.0, 2.0, 2.0), (1.5, 1.5, 1.5), (0.0, 0.0, 0.0))
    vm = model_of(v)
    A, B = vm.linear_model(v)
    rng = np.random.default_rng(3)
    x, u = rng.normal(size=6), rng.normal(size=3)
    assert np.allclose(A @ x + B @ u, np.asarray(vm.ode(v)(x, u)).ravel())
    dt = 0.3
    Ad, Bd = vm.linear_model(v, dt)
    F = dyn.discrete_dynamics(vm.ode(v), dt, "rk4", 1)
    assert np.allclose(Ad @ x + Bd @ u, np.asarray(F(x, u)).ravel(), atol=1e-12)
    p, vel = x[:3], x[3:]
    assert np.allclose(Ad @ x + Bd @ u, np.concatenate([p + dt * vel + 0.5 * dt**2 * u,
                                                        vel + dt * u]))


def test_multirotor_has_no_linear_model(hexa):
    assert model_of(hexa).linear_model(hexa) is None
    assert model_of(hexa).linear_model(hexa, 0.1) is None
