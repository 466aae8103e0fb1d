"""Wind: a constant mean wind plus Dryden turbulence (MIL-F-8785C, low altitude), seeded,
for many runs at once.

Each axis of the gust is white noise through the Dryden shaping filter, realised in state
space and discretised exactly at the simulator's step (transition ``expm(A dt)``, noise
covariance by Van Loan's method), scaled so the stationary standard deviation is the
standard's σ — the spectrum's shape is the standard's, its variance exact at any step:

* along the mean wind (u): ``H_u(s) ∝ 1 / (1 + τ_u s)``;
* across (v) and vertical (w): ``H(s) ∝ (1 + √3 τ s) / (1 + τ s)²``;

with τ = L/V.  Low-altitude scales (h in feet, clamped to at least 10 ft as the standard's
lower end): ``L_w = h``, ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2``; intensities
``σ_w = 0.1 W20``, ``σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4`` with the wind speed at
20 ft ``W20`` of the level: light 15 kt, moderate 30 kt, severe 45 kt.  V, the speed of
the air past the vehicle, is taken as max(|mean wind|, 1 m/s) (a hovering vehicle in
calm air has no V; 1 m/s keeps the correlation lengths finite).  The u axis is the mean
wind's horizontal direction (x when there is none).
"""

from __future__ import annotations

import numpy as np

FT = 0.3048
KNOT = 0.514444
GUST_STEP = 0.02  # s
LEVELS = {"none": 0.0, "light": 15 * KNOT, "moderate": 30 * KNOT, "severe": 45 * KNOT}


def _discrete(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of dx = A x dt + B dW: (Φ, chol(Q_d)) (Van Loan)."""
    from scipy.linalg import expm

    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n], m[:n, n:], m[n:, n:] = -a, b @ b.T, a.T
    e = expm(m * dt)
    phi = e[n:, n:].T
    q = phi @ e[:n, n:]
    return phi, np.linalg.cholesky(q + 1e-15 * np.trace(q) * np.eye(n))


def _filter(tau: float, second_order: bool):
    """(A, B, C) of the Dryden shape with unit stationary variance."""
    from scipy.linalg import solve_continuous_lyapunov

    if second_order:
        a = 1.0 / tau
        A = np.array([[0.0, 1.0], [-a * a, -2.0 * a]])
        B = np.array([[0.0], [1.0]])
        C = np.array([[1.0 / tau**2, np.sqrt(3.0) / tau]])
    else:
        A, B, C = np.array([[-1.0 / tau]]), np.array([[1.0]]), np.array([[1.0]])
    P = solve_continuous_lyapunov(A, -B @ B.T)
    return A, B, C / np.sqrt((C @ P @ C.T).item())


class Wind:
    """Mean wind + Dryden gusts for ``runs`` runs stepping together at ``dt`` s.

    ``sample()`` returns the (runs, 3) wind velocities (m/s, ENU) of the current step and
    advances; the filters start in their stationary distribution.  The simulator holds a
    sample for ``GUST_STEP`` s (the gusts' correlation times are ~1 s and more)."""

    def __init__(self, mean, level: str, altitude: float, dt: float, runs: int,
                 rng: np.random.Generator):
        self.mean = np.asarray(mean, dtype=float)
        self.rng = rng
        self.runs = runs
        w20 = LEVELS[level]
        self.on = w20 > 0
        if not self.on:
            return
        from scipy.linalg import solve_continuous_lyapunov

        h = max(altitude / FT, 10.0)
        k = 0.177 + 0.000823 * h
        sig_w = 0.1 * w20
        sig_u = sig_w / k**0.4
        L_w, L_u = h * FT, h / k**1.2 * FT
        V = max(float(np.linalg.norm(self.mean)), 1.0)
        self.sigma = np.array([sig_u, sig_u, sig_w])
        hor = self.mean[:2]
        u = hor / np.linalg.norm(hor) if np.linalg.norm(hor) > 1e-9 else np.array([1.0, 0.0])
        # columns: the u, v, w axes in ENU
        self.axes = np.array([[u[0], -u[1], 0.0], [u[1], u[0], 0.0], [0.0, 0.0, 1.0]])
        self.parts = []
        for tau, second in ((L_u / V, False), (L_u / V, True), (L_w / V, True)):
            A, B, C = _filter(tau, second)
            phi, chol = _discrete(A, B, dt)
            P = solve_continuous_lyapunov(A, -B @ B.T)
            x0 = rng.standard_normal((runs, A.shape[0])) @ np.linalg.cholesky(P).T
            self.parts.append([phi, chol, C, x0])

    def sample(self) -> np.ndarray:
        if not self.on:
            return np.broadcast_to(self.mean, (self.runs, 3))
        g = np.empty((self.runs, 3))
        for i, part in enumerate(self.parts):
            phi, chol, C, x = part
            g[:, i] = (x @ C.T)[:, 0] * self.sigma[i]
            part[3] = x @ phi.T + self.rng.standard_normal(x.shape) @ chol.T
        return self.mean + g @ self.axes.T
